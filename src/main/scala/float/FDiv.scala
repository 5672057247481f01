package float

import chisel3._

/** a / b rounded to nearest even, in `latency` cycles: restoring radix-2 digit recurrence, one quotient bit per
  * step, unrolled. Steps: 0 classify, 1 normalise subnormal operands, 2 .. manW+4 the manW+3 quotient bits
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

  // ---- step 1: normalise both significands to [2^manW, 2^(manW+1)); quotient MSB weight 2^(ea - eb)
  class Rec extends Bundle {
    val rem = UInt((fmt.sigW + 1).W)
    val d   = UInt(fmt.sigW.W)
    val q   = UInt(qW.W)
    val raw = new RawFloat(fmt, 1)
  }
  private val (na, ea) = Unpack.normalise(r0.ua.sig, r0.ua.exp)
  private val (nb, eb) = Unpack.normalise(r0.ub.sig, r0.ub.exp)
  val s1 = Wire(new Rec)
  s1.rem     := na
  s1.d       := nb
  s1.q       := 0.U
  s1.raw     := r0.raw
  s1.raw.exp := ea - eb
  val r1 = stages.cut(1, s1)

  // ---- steps 2 ..: one quotient bit each (rem < 2d holds throughout)
  private val rec = (0 until qW).foldLeft(r1) { (r, i) =>
    val s  = Wire(new Rec)
    val ge = r.rem >= r.d
    s.rem := (Mux(ge, r.rem - r.d, r.rem) << 1)(fmt.sigW, 0)
    s.d   := r.d
    s.q   := (r.q << 1)(qW - 1, 0) | ge
    s.raw := r.raw
    stages.cut(2 + i, s)
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

  val rp = Module(new RoundPack(fmt, qW, stages.from(2 + qW), maxLz = 1)) // quotient in (1/2, 2)
  rp.in     := raw
  out       := rp.out
  flags     := rp.flags
  out_valid := Stages.delayValid(in_valid, latency)
}

object FDiv {
  /** A quotient in (1/2, 2): manW+1 kept bits, a guard bit, and one more for the case quotient < 1. */
  def quotientBits(fmt: FloatFormat): Int = fmt.manW + 3
  /** Step weights (Stages): classify, normalise, one per quotient bit (a subtracter and a select), then RoundPack's. */
  def weights(fmt: FloatFormat): Seq[Int] =
    Seq(3, 8) ++ Seq.fill(quotientBits(fmt))(3) ++ RoundPack.weights(fmt, quotientBits(fmt), maxLz = 1)
  def steps(fmt: FloatFormat): Int        = weights(fmt).length
  /** About two quotient bits per cycle. */
  def defaultLatency(fmt: FloatFormat): Int = (quotientBits(fmt) + 7) / 2
}
