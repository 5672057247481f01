package float

import chisel3._

/** a * b rounded to nearest even, in `latency` cycles. Steps: 0 classify and add exponents, 1 and 2 the
  * significand product (operands registered before the multiplier when there are enough registers), then
  * RoundPack. The full 2(manW+1)-bit product is exact, so subnormal operands need no pre-normalisation:
  * RoundPack's leading-zero shift does it.
  */
class FMul(val fmt: FloatFormat, val latency: Int) extends Module {
  val in_valid  = IO(Input(Bool()))
  val a         = IO(Input(UInt(fmt.width.W)))
  val b         = IO(Input(UInt(fmt.width.W)))
  val out_valid = IO(Output(Bool()))
  val out       = IO(Output(UInt(fmt.width.W)))
  val flags     = IO(Output(new FloatFlags))

  override def desiredName = s"FMul_${fmt.tag}_l$latency"

  val stages = Stages(latency, FMul.steps)
  private val prodW = 2 * fmt.sigW

  // ---- step 0: classify, specials, exponent of the product's MSB
  val s0 = Wire(new Bundle {
    val sigA = UInt(fmt.sigW.W)
    val sigB = UInt(fmt.sigW.W)
    val raw  = new RawFloat(fmt, 1) // everything but the significand
  })
  private val ua = Unpack(fmt, a)
  private val ub = Unpack(fmt, b)
  private val zeroTimesInf = (ua.isZero && ub.isInf) || (ua.isInf && ub.isZero)
  s0.sigA          := ua.sig
  s0.sigB          := ub.sig
  s0.raw.sign      := ua.sign ^ ub.sign
  s0.raw.exp       := ua.exp + ub.exp + 1.S // the product of two [1, 2) significands is in [1, 4)
  s0.raw.sig       := 0.U
  s0.raw.sticky    := false.B
  s0.raw.isNaN     := ua.isNaN || ub.isNaN || zeroTimesInf
  s0.raw.isInf     := ua.isInf || ub.isInf
  s0.raw.isZero    := ua.isZero || ub.isZero
  s0.raw.invalid   := ua.isSNaN || ub.isSNaN || zeroTimesInf
  s0.raw.divByZero := false.B
  val r0 = stages.cut(0, s0)

  // ---- steps 1 and 2: the product (a register after step 1 lands on the multiplier's inputs' side)
  val r1 = stages.cut(1, r0)
  val s2 = Wire(new RawFloat(fmt, prodW))
  s2.sign      := r1.raw.sign
  s2.exp       := r1.raw.exp
  s2.sig       := r1.sigA * r1.sigB
  s2.sticky    := false.B
  s2.isNaN     := r1.raw.isNaN
  s2.isInf     := r1.raw.isInf
  s2.isZero    := r1.raw.isZero
  s2.invalid   := r1.raw.invalid
  s2.divByZero := false.B
  val r2 = stages.cut(2, s2)

  val rp = Module(new RoundPack(fmt, prodW, stages.from(3)))
  rp.in     := r2
  out       := rp.out
  flags     := rp.flags
  out_valid := Stages.delayValid(in_valid, latency)
}

object FMul {
  val steps = 3 + RoundPack.steps
  def defaultLatency(fmt: FloatFormat): Int = 3
}
