package float

import chisel3._

/** sqrt(a) rounded to nearest even, in `latency` cycles: restoring digit recurrence on the integer square root,
  * one root bit per step, unrolled. Steps: 0 classify, then normalise a subnormal operand (two levels a step),
  * make the exponent even, the manW+2 root bits (the last gives the sticky bit from the remainder), then
  * RoundPack.
  * sqrt(-0) = -0; any other negative operand gives NaN and invalid.
  */
class FSqrt(val fmt: FloatFormat, val latency: Int) extends Module {
  val in_valid  = IO(Input(Bool()))
  val a         = IO(Input(UInt(fmt.width.W)))
  val out_valid = IO(Output(Bool()))
  val out       = IO(Output(UInt(fmt.width.W)))
  val flags     = IO(Output(new FloatFlags))

  override def desiredName = s"FSqrt_${fmt.tag}_l$latency"

  private val n    = FSqrt.rootBits(fmt) // root bits: manW+1 kept and a guard bit
  private val remW = n + 2
  val stages = Stages(latency, FSqrt.weights(fmt))

  // ---- step 0: classify and specials
  val s0 = Wire(new Bundle {
    val ua  = new Unpacked(fmt)
    val raw = new RawFloat(fmt, 1)
  })
  private val ua  = Unpack(fmt, a)
  private val neg = ua.sign && !ua.isZero && !ua.isNaN
  s0.ua            := ua
  s0.raw.sign      := ua.sign
  s0.raw.exp       := 0.S
  s0.raw.sig       := 0.U
  s0.raw.sticky    := false.B
  s0.raw.isNaN     := ua.isNaN || neg
  s0.raw.isInf     := ua.isInf
  s0.raw.isZero    := ua.isZero
  s0.raw.invalid   := ua.isSNaN || neg
  s0.raw.divByZero := false.B
  val r0 = stages.cut(0, s0)

  // ---- normalise, then a = X * 2^(E2 - manW) with E2 even and X in [2^manW, 2^(manW+2));
  // root of Y = X * 2^n: n bits, MSB weight 2^(E2/2)
  class Rec extends Bundle {
    val y    = UInt((2 * n).W) // radicand bits not yet consumed, two per step, from the top
    val rem  = UInt(remW.W)
    val root = UInt(n.W)
    val raw  = new RawFloat(fmt, 1)
  }
  class Pre extends Bundle {
    val na  = new Unpack.NormSig(fmt)
    val raw = new RawFloat(fmt, 1)
    val e   = SInt(fmt.expIntW.W)
  }
  private val groups = Unpack.normaliseSteps(fmt)
  private val pre0 = Wire(new Pre)
  pre0.na  := Unpack.startNormalise(fmt, r0.ua.sig)
  pre0.raw := r0.raw
  pre0.e   := r0.ua.exp
  private val pre = groups.zipWithIndex.foldLeft(pre0) { case (r, (ks, g)) =>
    val s = Wire(new Pre)
    s    := r
    s.na := Unpack.normaliseStep(fmt, r.na, ks)
    stages.cut(1 + g, s)
  }
  private val bit0 = 1 + groups.length
  private val na   = pre.na.sig
  private val ea   = pre.e - pre.na.lz.zext
  private val odd  = ea(0)
  private val x    = Mux(odd, na ## 0.U(1.W), 0.U(1.W) ## na) // n bits
  val s1 = Wire(new Rec)
  s1.y       := x ## 0.U(n.W)
  s1.rem     := 0.U
  s1.root    := 0.U
  s1.raw     := pre.raw
  s1.raw.exp := (ea - odd.zext) >> 1
  val r1 = stages.cut(bit0, s1)

  // ---- then one root bit a step
  private val rec = (0 until n).foldLeft(r1) { (r, i) =>
    val s     = Wire(new Rec)
    val remT  = r.rem ## r.y(2 * n - 1, 2 * n - 2)
    val trial = r.root ## 1.U(2.W)
    val diff  = remT.zext - trial.zext // one subtracter: its sign is the comparison
    val ge    = !diff(diff.getWidth - 1)
    s.y    := (r.y << 2)(2 * n - 1, 0)
    s.rem  := Mux(ge, diff.asUInt, remT)(remW - 1, 0)
    s.root := (r.root << 1)(n - 1, 0) | ge
    s.raw  := r.raw
    stages.cut(bit0 + 1 + i, s)
  }

  val raw = Wire(new RawFloat(fmt, n))
  raw.sign      := rec.raw.sign
  raw.exp       := rec.raw.exp
  raw.sig       := rec.root
  raw.sticky    := rec.rem =/= 0.U
  raw.isNaN     := rec.raw.isNaN
  raw.isInf     := rec.raw.isInf
  raw.isZero    := rec.raw.isZero
  raw.invalid   := rec.raw.invalid
  raw.divByZero := false.B

  val rp = Module(new RoundPack(fmt, n, stages.from(bit0 + 1 + n), maxLz = 0)) // root MSB set
  rp.in     := raw
  out       := rp.out
  flags     := rp.flags
  out_valid := Stages.delayValid(in_valid, latency)
}

object FSqrt {
  def rootBits(fmt: FloatFormat): Int     = fmt.manW + 2
  /** Step weights (Stages): classify, the normaliser's steps, the even exponent, one per root bit (a subtracter and a select), then RoundPack's. */
  def weights(fmt: FloatFormat): Seq[Int] =
    Seq(3) ++ Unpack.normaliseSteps(fmt).map(_.length * 2) ++ Seq(3) ++ Seq.fill(rootBits(fmt))(3) ++ RoundPack.weights(fmt, rootBits(fmt), maxLz = 0)
  def steps(fmt: FloatFormat): Int        = weights(fmt).length
  /** About two root bits per cycle. */
  def defaultLatency(fmt: FloatFormat): Int = (rootBits(fmt) + 7) / 2
}
