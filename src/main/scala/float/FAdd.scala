package float

import chisel3._
import chisel3.util._

/** a + b, or a - b when `sub` is high, rounded to nearest even, in `latency` cycles (fixed, one operation per
  * cycle). Steps: 0 classify and order by magnitude, 1 align the smaller operand (guard, round and sticky bits),
  * 2 add or subtract (one adder: a - b = a + ~b + 1), then RoundPack (normalise, round, pack). A tiny sum is
  * exact, so RoundPack's normalisation stops at the smallest normal exponent and needs no right shift
  * (tinyExact).
  * An exact zero sum is +0, except (-0) + (-0) = -0 (IEEE 754 6.3, round to nearest).
  */
class FAdd(val fmt: FloatFormat, val latency: Int) extends Module {
  val in_valid  = IO(Input(Bool()))
  val a         = IO(Input(UInt(fmt.width.W)))
  val b         = IO(Input(UInt(fmt.width.W)))
  val sub       = IO(Input(Bool()))
  val out_valid = IO(Output(Bool()))
  val out       = IO(Output(UInt(fmt.width.W)))
  val flags     = IO(Output(new FloatFlags))

  override def desiredName = s"FAdd_${fmt.tag}_l$latency"

  val stages = Stages(latency, FAdd.steps)
  private val m    = fmt.manW
  private val extW = fmt.sigW + 3 // significand, guard, round, sticky
  private val sumW = extW + 1

  /** The larger operand, as far as the sum needs it: sign, significand, biased exponent (1 for subnormals). */
  class Big extends Bundle {
    val sign = Bool()
    val sig  = UInt(fmt.sigW.W)
    val expF = UInt(fmt.expW.W)
  }

  // ---- step 0: classify, effective sign of b, order by magnitude (the bit patterns order the magnitudes)
  val s0 = Wire(new Bundle {
    val big      = new Big
    val smallSig = UInt(fmt.sigW.W)
    val diff     = UInt(fmt.expW.W)
    val effSub   = Bool()
    val isNaN    = Bool()
    val isInf    = Bool()
    val invalid  = Bool()
  })
  private val ua = Unpack(fmt, a)
  private val ub = Unpack(fmt, b)
  private val signB = ub.sign ^ sub
  private def expF(u: UInt) = { val e = u(fmt.width - 2, m); Mux(e === 0.U, 1.U, e) }
  private val swap    = b(fmt.width - 2, 0) > a(fmt.width - 2, 0)
  private val infDiff = ua.isInf && ub.isInf && ua.sign =/= signB
  s0.big.sign := Mux(swap, signB, ua.sign)
  s0.big.sig  := Mux(swap, ub.sig, ua.sig)
  s0.big.expF := Mux(swap, expF(b), expF(a))
  s0.smallSig := Mux(swap, ua.sig, ub.sig)
  s0.diff     := Mux(swap, expF(b) - expF(a), expF(a) - expF(b))
  s0.effSub   := ua.sign =/= signB
  s0.isNaN    := ua.isNaN || ub.isNaN || infDiff
  s0.isInf    := ua.isInf || ub.isInf
  s0.invalid  := ua.isSNaN || ub.isSNaN || infDiff
  val r0 = stages.cut(0, s0)

  // ---- step 1: align the smaller significand; the bits shifted out are ORed into the sticky LSB
  val s1 = Wire(new Bundle {
    val big     = new Big
    val aligned = UInt(extW.W)
    val effSub  = Bool()
    val isNaN   = Bool()
    val isInf   = Bool()
    val invalid = Bool()
  })
  private val dCap = Mux(r0.diff > extW.U, extW.U, r0.diff(math.min(log2Ceil(extW + 1), fmt.expW) - 1, 0))
  private val (sh, dropped) = Shift.rightSticky(Cat(r0.smallSig, 0.U(3.W)), dCap)
  s1.big     := r0.big
  s1.aligned := sh(extW - 1, 1) ## (sh(0) || dropped)
  s1.effSub  := r0.effSub
  s1.isNaN   := r0.isNaN
  s1.isInf   := r0.isInf
  s1.invalid := r0.invalid
  val r1 = stages.cut(1, s1)

  // ---- step 2: add or subtract (|big| >= |small|, so the difference is >= 0 and the sign is big's)
  private val bigExt = Cat(r1.big.sig, 0.U(3.W))
  private val addend = Mux(r1.effSub, ~r1.aligned.pad(sumW), r1.aligned.pad(sumW)) // one adder: a - b = a + ~b + 1
  private val sum    = (bigExt.pad(sumW) + addend + r1.effSub.asUInt)(sumW - 1, 0)
  val s2 = Wire(new RawFloat(fmt, sumW))
  s2.sign      := Mux(r1.effSub && sum === 0.U, false.B, r1.big.sign)
  s2.exp       := r1.big.expF.zext - (fmt.bias - 1).S // MSB of sum: one place above the hidden bit
  s2.sig       := sum
  s2.sticky    := false.B // already in the LSB of sum
  s2.isNaN     := r1.isNaN
  s2.isInf     := r1.isInf
  s2.isZero    := false.B // a zero sum has sig = 0; RoundPack returns the signed zero
  s2.invalid   := r1.invalid
  s2.divByZero := false.B
  val r2 = stages.cut(2, s2)

  val rp = Module(new RoundPack(fmt, sumW, stages.from(3), tinyExact = true))
  rp.in     := r2
  out       := rp.out
  flags     := rp.flags
  out_valid := Stages.delayValid(in_valid, latency)
}

object FAdd {
  val steps = 3 + RoundPack.steps
  def defaultLatency(fmt: FloatFormat): Int = 4
}
