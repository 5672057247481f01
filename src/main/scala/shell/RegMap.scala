package shell

/** A bit field of a register, bits [lsb + width - 1 : lsb].
  *
  * @param sw    software access: "r", "rw" or "w"
  * @param hw    hardware access: "r" (the core uses the value), "w" (the core sets it) or "na" (a constant)
  * @param reset value after reset (None: no reset, e.g. a write-only data word)
  * @param w1c   writing 1 clears the bit (sw = "rw": reads the flag, a write of 1 clears it)
  */
case class Field(name: String, lsb: Int, width: Int, sw: String, hw: String, reset: Option[BigInt], desc: String,
    w1c: Boolean = false) {
  require(Set("r", "rw", "w")(sw), s"field $name: sw must be r, rw or w, got $sw")
  require(Set("r", "w", "na")(hw), s"field $name: hw must be r, w or na, got $hw")
  require(lsb >= 0 && width >= 1 && lsb + width <= 32, s"field $name: bits [${lsb + width - 1}:$lsb] outside a 32-bit word")
  require(!w1c || (sw == "rw" && width == 1), s"field $name: a write-1-to-clear field is one rw bit")
  require(hw != "na" || (sw == "r" && reset.isDefined), s"field $name: a constant is read-only with a reset value")
  require(reset.forall(v => v >= 0 && v < (BigInt(1) << width)), s"field $name: reset value ${reset.get} does not fit $width bits")

  def msb: Int = lsb + width - 1
  def readable: Boolean = sw != "w"
  def writable: Boolean = sw != "r"
}

object Field {
  /** a constant: read-only, the value is its reset value */
  def const(name: String, lsb: Int, width: Int, value: BigInt, desc: String): Field =
    Field(name, lsb, width, "r", "na", Some(value), desc)
  /** read-only, set by the core, 0 after reset */
  def status(name: String, lsb: Int, width: Int, desc: String): Field = Field(name, lsb, width, "r", "w", Some(0), desc)
  /** read-write control bits the core uses */
  def ctrl(name: String, lsb: Int, width: Int, reset: BigInt, desc: String): Field =
    Field(name, lsb, width, "rw", "r", Some(reset), desc)
  /** a sticky flag set by the core, cleared by writing 1 */
  def w1c(name: String, lsb: Int, desc: String): Field = Field(name, lsb, 1, "rw", "w", Some(0), desc, w1c = true)
  /** a write-only 32-bit data word */
  def data(desc: String): Field = Field("VALUE", 0, 32, "w", "r", None, desc)
}

/** A 32-bit register at word address `word` (byte address 4 * word). */
case class Register(name: String, word: Int, desc: String, fields: Seq[Field]) {
  require(fields.nonEmpty, s"register $name has no fields")
  require(fields.map(_.name).distinct.length == fields.length, s"register $name: field names repeat")
  private val bits = fields.flatMap(f => f.lsb to f.msb)
  require(bits.distinct.length == bits.length, s"register $name: fields overlap")

  def field(nm: String): Field =
    fields.find(_.name == nm).getOrElse(throw new NoSuchElementException(s"register $name has no field $nm"))
  def has(nm: String): Boolean = fields.exists(_.name == nm)
  def readable: Boolean = fields.exists(_.readable)
  /** the word read after reset (fields without a reset value read as 0) */
  def resetValue: BigInt = fields.map(f => f.reset.getOrElse(BigInt(0)) << f.lsb).sum
  /** access summary of hw.json */
  def access: String =
    if (fields.forall(_.sw == "r")) "RO"
    else if (fields.forall(_.sw == "w")) "WO"
    else if (fields.filter(_.writable).forall(_.w1c)) "RO/W1C"
    else "RW"
}

/** A write-only data memory of 32-bit words at word address `word`, `size` words (a power of two, the region's
  * span), addressed as an array of the given dimensions: element [i0][i1]...[ik] is the word
  * word + ((i0 * d1 + i1) * d2 + ...) + ik.
  */
case class Region(name: String, word: Int, size: Int, dims: Seq[Int], desc: String, value: Field) {
  require(dims.nonEmpty && dims.forall(_ >= 1), s"region $name: dimensions must be >= 1: $dims")
  require(dims.product <= size, s"region $name: ${dims.mkString("[", "][", "]")} exceeds its $size words")
  def words: Int = dims.product
}

/** The register map of a core: registers and data regions, named after the core's module. The RTL register file
  * (SolverRegs), hw.json and the SystemRDL description (gen.Rdl) are all made from it.
  */
case class RegMap(name: String, desc: String, regs: Seq[Register], regions: Seq[Region]) {
  private val spans = regs.map(r => (r.name, r.word, 1)) ++ regions.map(g => (g.name, g.word, g.size))
  require(spans.map(_._1).distinct.length == spans.length, s"$name: register and region names repeat")
  for (Seq(a, b) <- spans.sortBy(_._2).sliding(2))
    require(a._2 + a._3 <= b._2, s"$name: ${a._1} overlaps ${b._1}")

  def reg(nm: String): Register =
    regs.find(_.name == nm).getOrElse(throw new NoSuchElementException(s"$name has no register $nm"))
  def region(nm: String): Region =
    regions.find(_.name == nm).getOrElse(throw new NoSuchElementException(s"$name has no region $nm"))
  /** words of the address map */
  def words: Int = spans.map { case (_, w, s) => w + s }.max
}
