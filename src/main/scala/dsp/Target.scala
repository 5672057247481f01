package dsp

/** The FPGA family the arithmetic is built for (the spec's `solver: target:`, `make ... TARGET=`).
  *
  *  - generic: portable RTL; the synthesis tool maps each product (here into bare MULT18X18D / DSP48E1 cells
  *    between fabric registers).
  *  - ecp5: every product on MULT18X18D primitives with their input, pipeline and output registers on
  *    (Ecp5Mult18); products wider than 18 x 18 are split into registered partial products.
  *  - xilinx7: the pipeline registers placed around 25 x 18 partial products so that Yosys synth_xilinx packs
  *    them into the DSP48E1's AREG/BREG, MREG and PREG.
  *
  * A target changes the RTL's structure, never its words or its cycle counts: the multiplier latency l_M is the
  * design's, and `minLatency` says how many stages a target needs.
  */
sealed abstract class Target(val name: String) {
  /** signed input widths (a, b) of one hard multiplier */
  def dspA: Int
  def dspB: Int
  /** The fewest multiplier stages (l_M) this target needs for an `aW` x `bW` product: generic 0; ecp5 3
    * (MULT18X18D input, pipeline and output registers), 4 with partial products to sum (a rounding offset is
    * added in that fourth stage when there is one, else after the DSP); xilinx7 3 (AREG/BREG, MREG, PREG), 4
    * with partial products to sum. */
  def minLatency(aW: Int, bW: Int): Int
  /** partial products of an aW x bW product (the wider operand on the A port if it fits there) */
  def parts(aW: Int, bW: Int): Int = {
    val (x, y) = if (bW > aW && bW <= dspA) (bW, aW) else (aW, bW)
    Target.limbCount(x, dspA) * Target.limbCount(y, dspB)
  }
}

object Target {
  case object Generic extends Target("generic") {
    val dspA = 18
    val dspB = 18
    def minLatency(aW: Int, bW: Int): Int = 0
  }
  case object Ecp5 extends Target("ecp5") {
    val dspA = 18
    val dspB = 18
    def minLatency(aW: Int, bW: Int): Int = if (parts(aW, bW) > 1) 4 else 3
  }
  case object Xilinx7 extends Target("xilinx7") {
    val dspA = 25
    val dspB = 18
    def minLatency(aW: Int, bW: Int): Int = if (parts(aW, bW) > 1) 4 else 3
  }

  val all: Seq[Target] = Seq(Generic, Ecp5, Xilinx7)

  def apply(name: String): Target =
    all.find(_.name == name).getOrElse(
      throw new IllegalArgumentException(s"target must be one of ${all.map(_.name).mkString(", ")}: got '$name'"))

  /** limbs of a w-bit signed word for `dspW`-bit signed multiplier inputs: unsigned (dspW - 1)-bit limbs from the
    * bottom and a signed top limb of at most dspW bits. */
  def limbCount(w: Int, dspW: Int): Int = if (w <= dspW) 1 else (w - 2) / (dspW - 1) + 1
}
