package float

import chisel3._

/** IEEE 754 comparison of a and b in `latency` cycles: lt (a < b), eq (a == b), le (a <= b) and unordered (a or b
  * NaN; then lt, eq and le are all low). +0 and -0 are equal. `invalid` is raised for a signalling NaN operand,
  * and for any NaN operand when `signaling` is high (the signalling predicates <, <= of IEEE 754 5.11; ==
  * is quiet).
  * Steps: 0 classify and compare magnitudes, 1 combine with the signs.
  */
class FCompare(val fmt: FloatFormat, val latency: Int) extends Module {
  val in_valid  = IO(Input(Bool()))
  val a         = IO(Input(UInt(fmt.width.W)))
  val b         = IO(Input(UInt(fmt.width.W)))
  val signaling = IO(Input(Bool()))
  val out_valid = IO(Output(Bool()))
  val lt        = IO(Output(Bool()))
  val eq        = IO(Output(Bool()))
  val le        = IO(Output(Bool()))
  val unordered = IO(Output(Bool()))
  val invalid   = IO(Output(Bool()))

  override def desiredName = s"FCompare_${fmt.tag}_l$latency"

  val stages = Stages(latency, FCompare.steps)

  // ---- step 0: the bit patterns without the sign order the magnitudes
  val s0 = Wire(new Bundle {
    val signA, signB, magLt, magEq, bothZero, unordered, invalid = Bool()
  })
  private val ua   = Unpack(fmt, a)
  private val ub   = Unpack(fmt, b)
  private val magA = a(fmt.width - 2, 0)
  private val magB = b(fmt.width - 2, 0)
  s0.signA     := ua.sign
  s0.signB     := ub.sign
  s0.magLt     := magA < magB
  s0.magEq     := magA === magB
  s0.bothZero  := ua.isZero && ub.isZero
  s0.unordered := ua.isNaN || ub.isNaN
  s0.invalid   := ua.isSNaN || ub.isSNaN || (signaling && (ua.isNaN || ub.isNaN))
  val r0 = stages.cut(0, s0)

  // ---- step 1: signs
  val s1 = Wire(new Bundle { val lt, eq, unordered, invalid = Bool() })
  private val eqV = r0.bothZero || (r0.signA === r0.signB && r0.magEq)
  private val ltV = !r0.bothZero && Mux(r0.signA =/= r0.signB, r0.signA,
    Mux(r0.signA, !r0.magLt && !r0.magEq, r0.magLt))
  s1.lt        := !r0.unordered && ltV
  s1.eq        := !r0.unordered && eqV
  s1.unordered := r0.unordered
  s1.invalid   := r0.invalid
  val r1 = stages.cut(1, s1)

  lt        := r1.lt
  eq        := r1.eq
  le        := r1.lt || r1.eq
  unordered := r1.unordered
  invalid   := r1.invalid
  out_valid := Stages.delayValid(in_valid, latency)
}

object FCompare {
  val steps = 2
  def defaultLatency(fmt: FloatFormat): Int = 1
}
