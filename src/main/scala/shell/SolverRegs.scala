package shell

import chisel3._
import chisel3.util._
import bus.{AxiLiteIO, AxiLiteResp, AxiLiteSlave}
import mem.InitRam

/** Register word addresses shared by the solver cores (byte address = 4 x word address), their description (the
  * register map every core extends, see RegMap) and the placement of the data regions above them.
  */
object SolverRegs {
  val ID              = 0
  val CONFIG0         = 1
  val CONFIG1         = 2
  val CTRL            = 3
  val IMAX            = 4
  val STATUS          = 5
  val SOLVES          = 6
  val LAST_CYCLES     = 7
  val CYCLES_PER_ITER = 8
  /** First core-specific register; every address from here on reads as DECERR (the data are write-only). */
  val FirstCoreReg = 9
  /** Data regions start at this word address. */
  val RegionStart = 16

  /** The ID word of four ASCII characters, the first in the top byte ("FGM1" = 0x46474D31). */
  def idValue(id: String): BigInt = {
    require(id.length == 4 && id.forall(c => c >= ' ' && c < 127), s"an ID is four ASCII characters: got '$id'")
    id.foldLeft(BigInt(0))((a, c) => (a << 8) | c.toInt)
  }

  /** CTRL: `out` says what is streamed without OUT_ALL; the texts of a core without warm start or output choice
    * say so. */
  def ctrlFields(warmDefault: Boolean, outAllDefault: Boolean, out: String,
      warmText: String = "start from the previous solution shifted by one stage when STATUS.WARM_VALID, else cold",
      outText: String = ""): Seq[Field] = Seq(
    Field.ctrl("WARM_START", 0, 1, if (warmDefault) 1 else 0, warmText),
    Field.ctrl("HOLD", 1, 1, 0, "finish the current solve, accept no new frame"),
    Field.ctrl("OUT_ALL", 2, 1, if (outAllDefault) 1 else 0,
      if (outText.nonEmpty) outText else s"stream all n words of z, else $out"))

  /** STATUS: BUSY and the sticky flags; WARM_VALID where the core has a warm start; `extra` the core's own bits;
    * `unused` the flags the core never sets. */
  def statusFields(warm: Boolean = true, extra: Seq[Field] = Nil, unused: Set[String] = Set()): Seq[Field] = {
    def flag(nm: String, lsb: Int, desc: String) =
      Field.w1c(nm, lsb, if (unused(nm)) s"$desc (never set by this core)" else desc)
    Seq(
      Field.status("BUSY", 0, 1, "a frame is arriving, a solve runs or its result waits: data writes are rejected"),
      flag("SAT", 1, "a parameter word was outside its box and saturated"),
      flag("OVERFLOW", 2, "a datapath word saturated"),
      flag("WRITE_REJECTED", 3, "a data write was refused: while busy, or a value that does not fit its word"),
      flag("TLAST_ERROR", 4, "an input frame's tlast was not on its last word")
    ) ++ (if (warm) Seq(Field.status("WARM_VALID", 5, 1,
      "a solve finished since reset and the last bounds write: the next solve can start warm")) else Nil) ++ extra
  }

  /** The shared registers, ID to CYCLES_PER_ITER, of a core with the given identity and CONFIG fields. */
  def registers(id: String, config0: Seq[Field], config1: Seq[Field], ctrl: Seq[Field], status: Seq[Field],
      cyclesPerIteration: Int, imaxDefault: Int,
      lastCycles: String = "cycles of the last solve, first pass to last iteration",
      solves: String = "solves completed since reset (one problem: a solve is complete when its answer's last word " +
        "enters the output queue)"): Seq[Register] = Seq(
    Register("ID", ID, "core identity", Seq(Field.const("ID", 0, 32, idValue(id), s"'$id' in ASCII"))),
    Register("CONFIG0", CONFIG0, "sizes of the core", config0),
    Register("CONFIG1", CONFIG1, "sizes and word format of the core", config1),
    Register("CTRL", CTRL, "control", ctrl),
    Register("IMAX", IMAX, "iterations per solve; writing 0 or more than 65535: SLVERR, ignored",
      Seq(Field.ctrl("IMAX", 0, 16, imaxDefault, "iterations per solve, 1..65535, latched at the start of each solve"))),
    Register("STATUS", STATUS, "status; writing 1 clears a sticky flag", status),
    Register("SOLVES", SOLVES, solves, Seq(Field.status("COUNT", 0, 32, solves))),
    Register("LAST_CYCLES", LAST_CYCLES, lastCycles, Seq(Field.status("CYCLES", 0, 32, lastCycles))),
    Register("CYCLES_PER_ITER", CYCLES_PER_ITER, "cycles per iteration",
      Seq(Field.const("CYCLES", 0, 32, cyclesPerIteration, "cycles per iteration")))
  )

  /** Rules of the shared register file, for the description of a core's map. */
  val rules: String = "32-bit registers on AXI4-Lite. Data memories are write-only (reads: DECERR) and written only " +
    "while STATUS.BUSY is 0 (else SLVERR and STATUS.WRITE_REJECTED); a value that does not fit its word: SLVERR; " +
    "an unmapped address or a data element without a word: DECERR."

  private def pow2(x: Int): Int = 1 << log2Ceil(math.max(1, x))

  /** Regions of the given word counts, each rounded up to a power of two and aligned to its size (largest first,
    * from RegionStart), so that a region's offset bits are the low address bits. Returns (size, base) per name
    * and the number of words of the map.
    */
  def layout(words: Seq[(String, Int)]): (Seq[(String, Int)], Map[String, Int], Int) = {
    val sizes = words.map { case (nm, w) => nm -> pow2(w) }
    var cur   = RegionStart
    val base = sizes.sortBy(-_._2).map { case (nm, sz) =>
      val b = ((cur + sz - 1) / sz) * sz
      cur = b + sz
      nm -> b
    }.toMap
    (sizes, base, sizes.map { case (nm, sz) => base(nm) + sz }.max)
  }
}

/** The control and status registers of a solver core and its AXI4-Lite register file, built inside the core's
  * module from the core's register map (constants, reset values, field positions). The core drives `busy` and
  * the status pulses; it adds its data regions through `writes`, and its own sticky STATUS bits (write 1 to
  * clear) as `extraStatus`, by field name.
  *
  * Rules common to the cores: the data memories are write-only; a data write while busy gets SLVERR and sets
  * WRITE_REJECTED, a value that does not fit its word gets SLVERR, an unmapped address DECERR.
  */
class SolverRegs(s_axil: AxiLiteIO, map: RegMap, extraStatus: Seq[(String, Bool)] = Nil,
    coreSources: Map[String, UInt] = Map()) {
  import SolverRegs._

  private val ctrlR   = map.reg("CTRL")
  private val imaxF   = map.reg("IMAX").field("IMAX")
  private val statusR = map.reg("STATUS")
  require(ctrlR.fields.map(_.name).toSet == Set("WARM_START", "HOLD", "OUT_ALL"),
    s"CTRL holds WARM_START, HOLD and OUT_ALL: got ${ctrlR.fields.map(_.name)}")
  require(imaxF.lsb == 0, "IMAX is the low bits of its register")
  /** readable registers of the core itself, words FirstCoreReg until RegionStart ("REGISTER.FIELD" sources) */
  private val coreWords = map.regs.filter(r => r.readable && r.word >= FirstCoreReg).map(_.word)
  require(map.regs.filter(_.readable).map(_.word).sorted == (0 until FirstCoreReg) ++ coreWords.sorted &&
    coreWords.forall(_ < RegionStart),
    "the readable registers are words 0 to CYCLES_PER_ITER and the core's own below the data regions (other reads: DECERR)")
  private def resetBit(f: String): Bool = (ctrlR.field(f).reset.get != 0).B

  val ctrlWarm   = RegInit(resetBit("WARM_START"))
  val ctrlHold   = RegInit(resetBit("HOLD"))
  val ctrlOutAll = RegInit(resetBit("OUT_ALL"))
  val imaxReg    = RegInit(imaxF.reset.get.U(imaxF.width.W))
  /** imaxReg === 1 */
  val imaxOne    = RegInit((imaxF.reset.get == 1).B)
  val stSat      = RegInit(false.B)
  val stOvf      = RegInit(false.B)
  val stRej      = RegInit(false.B)
  val stTlast    = RegInit(false.B)
  val warmValid  = RegInit(false.B)
  val solves     = RegInit(0.U(32.W))
  val lastCycles = RegInit(0.U(32.W))
  /** driven by the core: a frame is arriving (the handshake of its words included), a solve runs or results wait */
  val busy = Wire(Bool())
  /** `busy` a cycle later: the data-write rules and STATUS use it, so the write decode starts at a flip-flop. It is
    * high wherever `busy` is (a solve only begins with an input word's handshake, which `busy` covers) and for one
    * cycle after. */
  val busyR = RegNext(busy, false.B)

  /** Hold the input frame's first word while a write may still be on its way into a data memory: from the access
    * cycle to two cycles after it (the ECP5 block RAMs' write port has two registers, mem.InitRam). A word taken in
    * the cycle before the access makes the core busy and the write is refused; so no solve reads a memory that a
    * write accepted before it has not yet reached. One register, high for those three cycles. */
  private val writeHold = RegInit(false.B)
  /** the input stream's hold: CTRL.HOLD, or a write in flight */
  def frameHold: Bool = ctrlHold || writeHold

  /** A solve finished after `cycles` cycles: count it and validate the warm start. */
  def solveDone(cycles: UInt): Unit = {
    solves     := solves + 1.U
    lastCycles := cycles
    warmValid  := true.B
  }

  /** The sticky STATUS flags, cleared by writing 1 to their bit. */
  private val w1cFlags: Map[String, Bool] =
    Map("SAT" -> stSat, "OVERFLOW" -> stOvf, "WRITE_REJECTED" -> stRej, "TLAST_ERROR" -> stTlast) ++ extraStatus
  /** What the fields the core sets read: "REGISTER.FIELD" -> signal (constants come from the map). */
  private val sources: Map[String, UInt] = Map(
    "CTRL.WARM_START" -> ctrlWarm, "CTRL.HOLD" -> ctrlHold, "CTRL.OUT_ALL" -> ctrlOutAll, "IMAX.IMAX" -> imaxReg,
    "STATUS.BUSY" -> busyR, "STATUS.WARM_VALID" -> warmValid, "SOLVES.COUNT" -> solves,
    "LAST_CYCLES.CYCLES" -> lastCycles) ++ w1cFlags.map { case (k, v) => s"STATUS.$k" -> v.asUInt } ++ coreSources
  for (f <- statusR.fields if f.w1c) require(w1cFlags.contains(f.name), s"STATUS.${f.name}: no flag drives it")

  /** The word a register reads: its readable fields at their bits, 0 between them. */
  private def readWord(r: Register): UInt = {
    var at = 0
    val parts = r.fields.filter(_.readable).sortBy(_.lsb).flatMap { f =>
      val gap = if (f.lsb > at) Seq(0.U((f.lsb - at).W)) else Nil
      at = f.msb + 1
      val v = if (f.hw == "na") f.reset.get.U(f.width.W)
        else sources.getOrElse(s"${r.name}.${f.name}", throw new IllegalArgumentException(
          s"${map.name}: ${r.name}.${f.name} has no signal in the register file"))
      gap :+ v
    }
    Cat(parts.reverse)
  }

  val axil = Module(new AxiLiteSlave(s_axil.addrW))
  axil.axi <> s_axil

  // ---- reads: the word's one-hot select and the DECERR test are registers, made from the held request
  private val rdE = axil.rd.earlyAddr
  private val readable = map.regs.filter(_.readable)
  private val rdSel    = readable.map(r => RegNext(rdE === r.word.U, false.B))
  private val rdErr    = RegNext(rdE >= FirstCoreReg.U && !coreWords.map(w => rdE === w.U).foldLeft(false.B)(_ || _),
    false.B)
  axil.rd.data := readable.zip(rdSel).map { case (r, sel) => Mux(sel, readWord(r), 0.U) }.reduce(_ | _)
  axil.rd.resp := Mux(rdErr, AxiLiteResp.DECERR, AxiLiteResp.OKAY)

  // ---- writes: the access (wA, wD, axil.wr.valid) and predicates of it decoded a cycle ahead, in registers
  val wA   = axil.wr.addr
  val wD   = axil.wr.data
  axil.wr.resp := AxiLiteResp.OKAY
  private val wE  = axil.wr.earlyAddr
  writeHold := axil.wr.earlyValid || axil.wr.valid || RegNext(axil.wr.valid, false.B)
  private val wDE = axil.wr.earlyData
  private val atReg: Map[Int, Bool] = map.regs.map(r => r.word -> RegNext(wE === r.word.U, false.B)).toMap
  for (g <- map.regions) require(g.word % g.size == 0 && (g.size & (g.size - 1)) == 0,
    s"${map.name}: region ${g.name} at word ${g.word} is not aligned to its ${g.size} words")
  private def hits(name: String, a: UInt): Bool = {
    val g = map.region(name)
    a >= g.word.U && a < (g.word + g.size).U
  }
  private val inReg: Map[String, Bool] = map.regions.map(g => g.name -> RegNext(hits(g.name, wE), false.B)).toMap
  /** the early data word is a w-bit signed value (bits 31 .. w - 1 all equal) */
  private def fitsEarly(w: Int): Bool = {
    require(w >= 1 && w <= 32, s"a data word is 1 to 32 bits: got $w")
    (wDE(31, w - 1).andR || !wDE(31, w - 1).orR)
  }
  /** the data word is a valid IMAX (1 .. 2^width - 1), checked on the early data */
  private val imaxOk = RegNext(wDE =/= 0.U && wDE <= ((BigInt(1) << imaxF.width) - 1).U, false.B)
  private val dataOne = RegNext(wDE === 1.U, false.B)
  /** fits(w - 1): the data word is a w-bit signed value, for w = 1 .. 32 */
  private val fits: Seq[Bool] = (1 to 32).map(w => RegNext(fitsEarly(w), false.B))

  /** the access is to the register at word address `word` (a register of the map) */
  def at(word: Int): Bool = atReg.getOrElse(word,
    throw new IllegalArgumentException(s"${map.name}: no register at word $word"))
  /** the access is inside the region `name` of the map */
  def inRegion(name: String): Bool = inReg.getOrElse(name,
    throw new IllegalArgumentException(s"${map.name}: no region $name"))
  /** the word offset of the access inside the region `name`: its low address bits (regions are aligned), as wide
    * as the address */
  def offset(name: String): UInt = offsetOf(name, wA)
  private def offsetOf(name: String, a: UInt): UInt = {
    val size = map.region(name).size
    if (size == 1) 0.U(a.getWidth.W) else a(log2Ceil(size) - 1, 0).pad(a.getWidth)
  }
  /** `f` of the access's word offset inside the region `name`, formed from the request a cycle ahead (the early
    * address) and registered: the address checks and decodes of a data write then start at a register. */
  def ahead[T <: Data](name: String)(f: UInt => T): T = RegNext(f(offsetOf(name, wE)))
  /** the early request's address is inside the region `name` (not registered: for decisions made ahead) */
  def earlyIn(name: String): Bool = hits(name, wE)
  /** the early request's word offset inside the region `name` (not registered) */
  def earlyOffset(name: String): UInt = offsetOf(name, wE)
  def fitsS(w: Int): Bool = {
    require(w >= 1 && w <= 32, s"a data word is 1 to 32 bits: got $w")
    fits(w - 1)
  }

  /** Write enables of data memories, decided a cycle ahead: enable i is `go(i)` of the early request (its region,
    * address check and target, from `earlyIn` / `earlyOffset`), in one register, and at the access only gated by
    * the value's fit to `fitW` signed bits (a register) and busy. This is exactly when `dataWrite` with the same
    * region, check and width runs its body (which then gives the response and flags); the memories' enables come
    * from registers and one gate, and their address and lanes can be registered ahead the same way. */
  def writeEnables(fitW: Int)(go: Seq[Bool]): Seq[Bool] =
    go.map(g => RegNext(axil.wr.earlyValid && g, false.B) && fitsS(fitW) && !busyR)

  /** The write ports of per-unit data memories `rams` (one lane-masked word a write), driven from registers: memory
    * u writes when `go(u)` of the early request holds (writeEnables), at the early `row`, in the lane `lane`, the
    * data word's low `fitW` bits. */
  def unitWrites(rams: Seq[InitRam], fitW: Int, go: Int => Bool, row: UInt, lane: UInt): Unit = {
    val lanes = rams.head.lanes
    require(rams.forall(_.lanes == lanes), "unitWrites: memories of one lane count")
    val wen   = writeEnables(fitW)(rams.indices.map(go))
    val waddr = RegNext(row)
    val wmask = RegNext(UIntToOH(lane, lanes))
    for ((r, u) <- rams.zipWithIndex) {
      r.io.wen   := wen(u)
      r.io.waddr := waddr
      r.io.wmask := wmask
      r.io.wdata := Fill(lanes, wD(fitW - 1, 0))
    }
  }

  /** The input frame's box memory written from the region `name` (word 2 j + 1: hi of word j, 2 j: lo) as the
    * per-unit memories are (writeEnables): enable, word, bound and data from registers. The core's case for the
    * region is `dataWrite(fitW, ahead(name)(boxOk(words)))` with an empty body, for the response and flags. */
  def frameBoxWrites(frameIn: FrameIn, name: String, fitW: Int, words: Int): Unit = {
    val o = earlyOffset(name)
    frameIn.io.boxWen  := writeEnables(fitW)(Seq(earlyIn(name) && boxOk(words)(o))).head
    frameIn.io.boxWord := RegNext(o >> 1)
    frameIn.io.boxHi   := RegNext(o(0))
    frameIn.io.boxData := wD(fitW - 1, 0).asSInt
  }
  /** a box region's word offset `o` names one of the frame's `words` words */
  def boxOk(words: Int)(o: UInt): Bool = (o >> 1) < words.U

  /** A write into a data memory: refused while busy, at an address `ok` rejects, or when the value does not fit
    * `fitW` signed bits; otherwise `body` runs in the cycle of the write.
    */
  def dataWrite(fitW: Int, ok: Bool)(body: => Unit): Unit = {
    when(busyR) {
      axil.wr.resp := AxiLiteResp.SLVERR
      when(axil.wr.valid) { stRej := true.B }
    }.elsewhen(!ok) {
      axil.wr.resp := AxiLiteResp.DECERR
    }.elsewhen(!fitsS(fitW)) {
      axil.wr.resp := AxiLiteResp.SLVERR
      when(axil.wr.valid) { stRej := true.B }
    }.otherwise {
      when(axil.wr.valid) { body }
    }
  }

  /** Decode the shared registers, then the core's (condition, action) cases in order; anything else is DECERR. */
  def writes(cases: (Bool, () => Unit)*): Unit = {
    def bit(f: String) = wD(ctrlR.field(f).lsb)
    val shared = when(at(CTRL)) {
      when(axil.wr.valid) {
        ctrlWarm   := bit("WARM_START")
        ctrlHold   := bit("HOLD")
        ctrlOutAll := bit("OUT_ALL")
      }
    }.elsewhen(at(IMAX)) {
      when(!imaxOk) {
        axil.wr.resp := AxiLiteResp.SLVERR
      }.elsewhen(axil.wr.valid) {
        imaxReg := wD
        imaxOne := dataOne
      }
    }.elsewhen(at(STATUS)) {
      when(axil.wr.valid) {
        for (f <- statusR.fields.filter(_.w1c).sortBy(_.lsb)) when(wD(f.lsb)) { w1cFlags(f.name) := false.B }
      }
    }
    cases.foldLeft(shared) { case (ctx, (cond, body)) => ctx.elsewhen(cond)(body()) }.otherwise {
      axil.wr.resp := AxiLiteResp.DECERR
    }
  }
}
