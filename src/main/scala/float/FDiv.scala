package float

import chisel3._

/** a / b rounded to nearest even, in `latency` cycles: restoring radix-2 digit recurrence, one quotient bit per
  * step, unrolled. Steps: 0 classify, then normalise subnormal operands (two levels a step), then the manW+3 quotient bits
  * (the last one also gives the sticky bit from the remainder), then RoundPack.
  */
class FDiv(val fmt: FloatFormat, val latency: Int) extends Module {
  val in_valid  = IO(Input(Bool()))
  val a         = IO(Input(UInt(fmt.width.W)))
  val b         = IO(Input(UInt(fmt.width.W)))
  val out_valid = IO(Output(Bool()))
  val out       = IO(Output(UInt(fmt.width.W)))
  val flags     = IO(Output(new FloatFlags))

  override def desiredName = s"FDiv_${fmt.tag}_l$latency"

  private val qW = FDiv.quotientBits(fmt)
  val stages = Stages(latency, FDiv.weights(fmt))

  // ---- step 0: classify and specials
  val s0 = Wire(new Bundle {
    val ua  = new Unpacked(fmt)
    val ub  = new Unpacked(fmt)
    val raw = new RawFloat(fmt, 1)
  })
  private val ua = Unpack(fmt, a)
  private val ub = Unpack(fmt, b)
  private val zeroByZero = ua.isZero && ub.isZero
  private val infByInf   = ua.isInf && ub.isInf
  s0.ua            := ua
  s0.ub            := ub
  s0.raw.sign      := ua.sign ^ ub.sign
  s0.raw.exp       := 0.S
  s0.raw.sig       := 0.U
  s0.raw.sticky    := false.B
  s0.raw.isNaN     := ua.isNaN || ub.isNaN || zeroByZero || infByInf
  s0.raw.isInf     := ua.isInf || ub.isZero
  s0.raw.isZero    := ua.isZero || ub.isInf
  s0.raw.invalid   := ua.isSNaN || ub.isSNaN || zeroByZero || infByInf
  s0.raw.divByZero := ub.isZero && !ua.isZero && !ua.isInf && !ua.isNaN
  val r0 = stages.cut(0, s0)

  // ---- steps 1 ..: normalise both significands to [2^manW, 2^(manW+1)), two levels a step
  class Pre extends Bundle {
    val na  = new Unpack.NormSig(fmt)
    val nb  = new Unpack.NormSig(fmt)
    val ea  = SInt(fmt.expIntW.W)
    val eb  = SInt(fmt.expIntW.W)
    val raw = new RawFloat(fmt, 1)
  }
  private val groups = Unpack.normaliseSteps(fmt)
  private val pre0 = Wire(new Pre)
  pre0.na  := Unpack.startNormalise(fmt, r0.ua.sig)
  pre0.nb  := Unpack.startNormalise(fmt, r0.ub.sig)
  pre0.ea  := r0.ua.exp
  pre0.eb  := r0.ub.exp
  pre0.raw := r0.raw
  private val pre = groups.zipWithIndex.foldLeft(pre0) { case (r, (ks, g)) =>
    val s = Wire(new Pre)
    s    := r
    s.na := Unpack.normaliseStep(fmt, r.na, ks)
    s.nb := Unpack.normaliseStep(fmt, r.nb, ks)
    stages.cut(1 + g, s)
  }

  // the recurrence's start; the quotient's MSB weighs 2^(ea - eb), formed beside the quotient bits: each operand's
  // normalised exponent beside the first bit, their difference beside the first bit after a register
  class Rec extends Bundle {
    val rem = UInt((fmt.sigW + 1).W)
    val d   = UInt(fmt.sigW.W)
    val q   = UInt(qW.W)
    val eb  = SInt(fmt.expIntW.W) // b's normalised exponent, until the difference is formed
    val raw = new RawFloat(fmt, 1)
  }
  private val bit0 = 1 + groups.length
  val s1 = Wire(new Rec)
  s1.rem     := pre.na.sig
  s1.d       := pre.nb.sig
  s1.q       := 0.U
  s1.raw     := pre.raw
  s1.raw.exp := pre.ea - pre.na.lz.zext
  s1.eb      := pre.eb - pre.nb.lz.zext
  private val r1 = s1

  // ---- then one quotient bit a step (rem < 2d holds throughout)
  private val expAt = (1 until qW).find(i => stages.after(bit0 + i - 1) > 0).getOrElse(qW - 1)
  private val rec = (0 until qW).foldLeft(r1) { (r, i) =>
    val s  = Wire(new Rec)
    val diff = r.rem.zext - r.d.zext // one subtracter: its sign is the comparison
    val ge   = !diff(diff.getWidth - 1)
    s.rem := (Mux(ge, diff.asUInt, r.rem) << 1)(fmt.sigW, 0)
    s.d   := r.d
    s.q   := (r.q << 1)(qW - 1, 0) | ge
    s.eb  := (if (i < expAt) r.eb else 0.S) // carried only until the difference is formed
    s.raw := r.raw
    if (i == expAt) s.raw.exp := r.raw.exp - r.eb
    stages.cut(bit0 + i, s)
  }

  val raw = Wire(new RawFloat(fmt, qW))
  raw.sign      := rec.raw.sign
  raw.exp       := rec.raw.exp
  raw.sig       := rec.q
  raw.sticky    := rec.rem =/= 0.U
  raw.isNaN     := rec.raw.isNaN
  raw.isInf     := rec.raw.isInf
  raw.isZero    := rec.raw.isZero
  raw.invalid   := rec.raw.invalid
  raw.divByZero := rec.raw.divByZero

  val rp = Module(new RoundPack(fmt, qW, stages.from(bit0 + qW), maxLz = 1)) // quotient in (1/2, 2)
  rp.in     := raw
  out       := rp.out
  flags     := rp.flags
  out_valid := Stages.delayValid(in_valid, latency)
}

object FDiv {
  /** A quotient in (1/2, 2): manW+1 kept bits, a guard bit, and one more for the case quotient < 1. */
  def quotientBits(fmt: FloatFormat): Int = fmt.manW + 3
  /** Step weights (Stages): classify, the normaliser's steps, one per quotient bit (a subtracter and a select), then RoundPack's. */
  def weights(fmt: FloatFormat): Seq[Int] =
    Seq(3) ++ Unpack.normaliseSteps(fmt).map(_.length * 2) ++ Seq.fill(quotientBits(fmt))(3) ++ RoundPack.weights(fmt, quotientBits(fmt), maxLz = 1)
  def steps(fmt: FloatFormat): Int        = weights(fmt).length
  /** About two quotient bits per cycle. */
  def defaultLatency(fmt: FloatFormat): Int = (quotientBits(fmt) + 7) / 2
}
