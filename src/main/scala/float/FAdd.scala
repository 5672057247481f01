package float

import chisel3._
import chisel3.util._

/** a + b, or a - b when `sub` is high, rounded to nearest even, in `latency` cycles (fixed, one operation per
  * cycle). Steps: 0 classify and order by magnitude, 1 and 2 align the smaller operand (guard, round and sticky
  * bits; the shifter's wide levels, then its narrow ones), 3 add or subtract (one adder: a - b = a + ~b + 1),
  * then RoundPack (normalise, round, pack). A tiny sum is exact, so RoundPack's normalisation stops at the
  * smallest normal exponent and needs no right shift (tinyExact). Step 0's exponent difference comes from the
  * exponents' own subtraction, beside the full-width magnitude compare rather than after it.
  * An exact zero sum is +0, except (-0) + (-0) = -0 (IEEE 754 6.3, round to nearest): with an effective
  * subtraction the sum is zero exactly when the magnitudes are equal, which step 0 finds from the bit patterns.
  */
class FAdd(val fmt: FloatFormat, val latency: Int) extends Module {
  val in_valid  = IO(Input(Bool()))
  val a         = IO(Input(UInt(fmt.width.W)))
  val b         = IO(Input(UInt(fmt.width.W)))
  val sub       = IO(Input(Bool()))
  val out_valid = IO(Output(Bool()))
  val out       = IO(Output(UInt(fmt.width.W)))
  /** latency >= 1: `out` a cycle early, for a register beside the output's (an accumulator's feedback) */
  val outEarly  = if (latency >= 1) Some(IO(Output(UInt(fmt.width.W)))) else None
  val flags     = IO(Output(new FloatFlags))

  override def desiredName = s"FAdd_${fmt.tag}_l$latency"

  val stages = Stages(latency, FAdd.weights(fmt))
  private val m    = fmt.manW
  private val extW = FAdd.extW(fmt) // significand, guard, round, sticky
  private val sumW = extW + 1
  private val dW   = math.min(log2Ceil(extW + 1), fmt.expW) // alignment shifts 0 .. extW

  /** The larger operand, as far as the sum needs it: sign, significand, biased exponent (1 for subnormals). */
  class Big extends Bundle {
    val sign = Bool()
    val sig  = UInt(fmt.sigW.W)
    val expF = UInt(fmt.expW.W)
  }
  /** What passes the alignment unchanged. */
  class Pass extends Bundle {
    val big      = new Big
    val effSub   = Bool()
    val equalMag = Bool()
    val isNaN    = Bool()
    val isInf    = Bool()
    val invalid  = Bool()
  }

  // ---- step 0: classify, effective sign of b, order by magnitude (the bit patterns order the magnitudes)
  val s0 = Wire(new Bundle {
    val p        = new Pass
    val smallSig = UInt(fmt.sigW.W)
    val diff     = UInt(fmt.expW.W)
  })
  private val ua = Unpack(fmt, a)
  private val ub = Unpack(fmt, b)
  private val signB = ub.sign ^ sub
  private def expF(u: UInt) = { val e = u(fmt.width - 2, m); Mux(e === 0.U, 1.U, e) }
  private val swap    = b(fmt.width - 2, 0) > a(fmt.width - 2, 0)
  private val infDiff = ua.isInf && ub.isInf && ua.sign =/= signB
  s0.p.big.sign   := Mux(swap, signB, ua.sign)
  s0.p.big.sig    := Mux(swap, ub.sig, ua.sig)
  s0.p.big.expF   := Mux(swap, expF(b), expF(a))
  s0.p.effSub     := ua.sign =/= signB
  s0.p.equalMag   := b(fmt.width - 2, 0) === a(fmt.width - 2, 0)
  s0.p.isNaN      := ua.isNaN || ub.isNaN || infDiff
  s0.p.isInf      := ua.isInf || ub.isInf
  s0.p.invalid    := ua.isSNaN || ub.isSNaN || infDiff
  s0.smallSig     := Mux(swap, ua.sig, ub.sig)
  // |expF(a) - expF(b)| from the exponents alone: the order of the exponent fields agrees with the magnitudes'
  // (equal exponents give 0 either way), so the difference does not wait for the full-width compare
  private val dAB = expF(a).pad(fmt.expW + 1) - expF(b)
  s0.diff         := Mux(dAB(fmt.expW), expF(b) - expF(a), dAB(fmt.expW - 1, 0))
  val r0 = stages.cut(0, s0)

  // ---- steps 1 and 2: align the smaller significand; the bits shifted out are ORed into the sticky LSB
  class Align extends Bundle {
    val p       = new Pass
    val v       = UInt(extW.W)
    val d       = UInt(dW.W)
    val dropped = Bool()
  }
  private val (wide, narrow) = (0 until dW).reverse.splitAt((dW + 1) / 2)
  // a shift by 2^dW or more (a high bit of diff set) clears the value into the sticky bit, as every shift of at
  // least extW does: the levels take diff's low bits, with no compare ahead of them
  private val x0   = Cat(r0.smallSig, 0.U(3.W))
  private val dBig = if (fmt.expW > dW) r0.diff(fmt.expW - 1, dW).orR else false.B
  private val dLow = r0.diff(dW - 1, 0)
  val s1 = Wire(new Align)
  private val (v1, st1) = Shift.rightStickyLevels(Mux(dBig, 0.U(extW.W), x0), dLow, wide, dBig && x0.orR)
  s1.p       := r0.p
  s1.v       := v1
  s1.d       := dLow
  s1.dropped := st1
  val r1 = stages.cut(1, s1)

  val s2 = Wire(new Bundle {
    val p       = new Pass
    val aligned = UInt(extW.W)
  })
  private val (v2, st2) = Shift.rightStickyLevels(r1.v, r1.d, narrow, r1.dropped)
  s2.p       := r1.p
  s2.aligned := v2(extW - 1, 1) ## (v2(0) || st2)
  val r2 = stages.cut(2, s2)

  // ---- step 3: add or subtract (|big| >= |small|, so the difference is >= 0 and the sign is big's)
  private val big    = r2.p.big
  private val effSub = r2.p.effSub
  private val bigExt = Cat(big.sig, 0.U(3.W))
  private val addend = Mux(effSub, ~r2.aligned.pad(sumW), r2.aligned.pad(sumW)) // one adder: a - b = a + ~b + 1
  private val sum    = (bigExt.pad(sumW) + addend + effSub.asUInt)(sumW - 1, 0)
  val s3 = Wire(new Bundle {
    val raw = new RawFloat(fmt, sumW)
    val cap = UInt(fmt.expW.W)
  })
  s3.raw.sign      := Mux(effSub && r2.p.equalMag, false.B, big.sign)
  s3.raw.exp       := big.expF.zext - (fmt.bias - 1).S // MSB of sum: one place above the hidden bit
  s3.raw.sig       := sum
  s3.raw.sticky    := false.B // already in the LSB of sum
  s3.raw.isNaN     := r2.p.isNaN
  s3.raw.isInf     := r2.p.isInf
  s3.raw.isZero    := false.B // a zero sum has sig = 0; RoundPack returns the signed zero
  s3.raw.invalid   := r2.p.invalid
  s3.raw.divByZero := false.B
  s3.cap           := big.expF // exp + bias - 1
  val r3 = stages.cut(3, s3)

  val rp = Module(new RoundPack(fmt, sumW, stages.from(4), tinyExact = true))
  rp.in        := r3.raw
  rp.cap.get   := r3.cap
  out          := rp.out
  outEarly.foreach(_ := rp.outEarly.get)
  flags        := rp.flags
  out_valid    := Stages.delayValid(in_valid, latency)
}

object FAdd {
  def extW(fmt: FloatFormat): Int = fmt.sigW + 3
  /** Step weights (Stages): classify and order, the two alignment steps, the adder, then RoundPack's. */
  def weights(fmt: FloatFormat): Seq[Int] =
    Seq(4, 3, 3, 3) ++ RoundPack.weights(fmt, extW(fmt) + 1, tinyExact = true)
  def steps(fmt: FloatFormat): Int = weights(fmt).length
  def defaultLatency(fmt: FloatFormat): Int = 4
}
