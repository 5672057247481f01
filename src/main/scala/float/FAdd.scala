package float

import chisel3._
import chisel3.util._

/** a + b, or a - b when `sub` is high, rounded to nearest even, in `latency` cycles (fixed, one operation per
  * cycle). Steps: 0 classify and order by magnitude, 1 align the smaller operand (guard, round and sticky bits),
  * 2 add or subtract, then RoundPack (normalise, round, pack).
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

  // ---- step 0: classify, effective sign of b, order by magnitude (the bit patterns order the magnitudes)
  val s0 = Wire(new Bundle {
    val big     = new Unpacked(fmt)
    val small   = new Unpacked(fmt)
    val diff    = UInt(fmt.expIntW.W)
    val effSub  = Bool()
    val isNaN   = Bool()
    val isInf   = Bool()
    val invalid = Bool()
  })
  private val ua = Unpack(fmt, a)
  private val ub = {
    val u = Unpack(fmt, b)
    val w = Wire(new Unpacked(fmt))
    w      := u
    w.sign := u.sign ^ sub
    w
  }
  private val swap    = b(fmt.width - 2, 0) > a(fmt.width - 2, 0)
  private val infDiff = ua.isInf && ub.isInf && ua.sign =/= ub.sign
  s0.big     := Mux(swap, ub, ua)
  s0.small   := Mux(swap, ua, ub)
  s0.diff    := (Mux(swap, ub.exp, ua.exp) - Mux(swap, ua.exp, ub.exp)).asUInt
  s0.effSub  := ua.sign =/= ub.sign
  s0.isNaN   := ua.isNaN || ub.isNaN || infDiff
  s0.isInf   := ua.isInf || ub.isInf
  s0.invalid := ua.isSNaN || ub.isSNaN || infDiff
  val r0 = stages.cut(0, s0)

  // ---- step 1: align the smaller significand; the bits shifted out are ORed into the sticky LSB
  val s1 = Wire(new Bundle {
    val big     = new Unpacked(fmt)
    val aligned = UInt(extW.W)
    val effSub  = Bool()
    val isNaN   = Bool()
    val isInf   = Bool()
    val invalid = Bool()
  })
  private val dCap = Mux(r0.diff > extW.U, extW.U, r0.diff(log2Ceil(extW + 1) - 1, 0))
  private val wide = Cat(r0.small.sig, 0.U(3.W), 0.U(extW.W)) >> dCap
  s1.big     := r0.big
  s1.aligned := wide(2 * extW - 1, extW + 1) ## (wide(extW, 0).orR)
  s1.effSub  := r0.effSub
  s1.isNaN   := r0.isNaN
  s1.isInf   := r0.isInf
  s1.invalid := r0.invalid
  val r1 = stages.cut(1, s1)

  // ---- step 2: add or subtract (|big| >= |small|, so the difference is >= 0 and the sign is big's)
  private val bigExt = Cat(r1.big.sig, 0.U(3.W))
  private val sum    = Mux(r1.effSub, bigExt -& r1.aligned, bigExt +& r1.aligned)(sumW - 1, 0)
  val s2 = Wire(new RawFloat(fmt, sumW))
  s2.sign      := Mux(r1.effSub && sum === 0.U, false.B, r1.big.sign)
  s2.exp       := r1.big.exp + 1.S // MSB of sum is one place above the hidden bit
  s2.sig       := sum
  s2.sticky    := false.B // already in the LSB of sum
  s2.isNaN     := r1.isNaN
  s2.isInf     := r1.isInf
  s2.isZero    := false.B // a zero sum has sig = 0; RoundPack returns the signed zero
  s2.invalid   := r1.invalid
  s2.divByZero := false.B
  val r2 = stages.cut(2, s2)

  val rp = Module(new RoundPack(fmt, sumW, stages.from(3)))
  rp.in     := r2
  out       := rp.out
  flags     := rp.flags
  out_valid := Stages.delayValid(in_valid, latency)
}

object FAdd {
  val steps = 3 + RoundPack.steps
  def defaultLatency(fmt: FloatFormat): Int = 4
}
