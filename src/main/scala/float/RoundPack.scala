package float

import chisel3._
import chisel3.util._

/** IEEE 754 exception flags of one result. Underflow is signalled when the result is tiny before rounding and
  * inexact (tininess before rounding, allowed by IEEE 754-2008 7.5).
  */
class FloatFlags extends Bundle {
  val invalid   = Bool()
  val divByZero = Bool()
  val overflow  = Bool()
  val underflow = Bool()
  val inexact   = Bool()

  /** [0] invalid, [1] divByZero, [2] overflow, [3] underflow, [4] inexact. */
  def bits: UInt = Cat(inexact, underflow, overflow, divByZero, invalid)
}

/** An exact or sticky intermediate result before rounding. For finite nonzero results,
  * |value| = (sig + (sticky ? something in (0, 1) : 0)) * 2^(exp - (sig.getWidth - 1)): `exp` is the weight of
  * the MSB of `sig`, which may have leading zeros. Special outcomes (NaN, infinity, exact zero by rule) are
  * decided by the operator and override the significand.
  */
class RawFloat(fmt: FloatFormat, val sigW: Int) extends Bundle {
  val sign      = Bool()
  val exp       = SInt(fmt.expIntW.W)
  val sig       = UInt(sigW.W)
  val sticky    = Bool()
  val isNaN     = Bool()
  val isInf     = Bool()
  val isZero    = Bool()
  val invalid   = Bool()
  val divByZero = Bool()
}

/** Normalise, round to nearest even and pack: the last steps of every arithmetic operator but the multiplier
  * (FMul has its own). Steps (`RoundPack.weights`, `regs(i)` registers after step i, from the operator's Stages):
  *  - normalise: the leading-zero shift, level by level (Shift.normaliseLevels), two levels a step;
  *  - the exponent of the normalised significand; for a tinyExact operator also the kept bits, the guard bit and
  *    the sticky rest. Otherwise three more steps: the right shift into the subnormal range, then the shift, its
  *    wide levels and then its narrow ones with the kept bits;
  *  - the rounding increment;
  *  - packing (the rounding carry ripples into the exponent field), overflow to infinity, specials.
  *
  * Left normalisation is exact only if bits inserted below the LSB are not needed: an operator passing a
  * nonzero sticky must have at most (sig.getWidth - manW - 2) leading zeros, so that the guard bit is a
  * computed bit (FDiv: <= 1; FSqrt: 0; FAdd passes sticky = 0, its sticky bit being the sum's LSB).
  *
  * `maxLz`: the most leading zeros a nonzero `sig` can have (FDiv 1, FSqrt 0): fewer normalisation levels.
  * `tinyExact`: every tiny result is exact and the MSB of `sig` weighs at least 2^emin (sums: FAdd). The left
  * shift then stops at the smallest normal exponent (Shift.normalise with the cap `cap` = exp + bias - 1, which
  * the operator supplies, so that no adder precedes the shifter), which leaves a tiny result subnormal already:
  * no right shift.
  */
class RoundPack(fmt: FloatFormat, sigW: Int, regs: Seq[Int], maxLz: Int = Int.MaxValue, tinyExact: Boolean = false)
    extends Module {
  private val nSteps = RoundPack.weights(fmt, sigW, maxLz, tinyExact).length
  require(regs.length == nSteps, s"RoundPack has $nSteps steps: got ${regs.length} register counts")
  val in  = IO(Input(new RawFloat(fmt, sigW)))
  /** tinyExact only: in.exp + bias - 1 (>= 0), the normaliser's cap. */
  val cap = if (tinyExact) Some(IO(Input(UInt(fmt.expW.W)))) else None
  val out = IO(Output(UInt(fmt.width.W)))
  /** with a register after the last step: `out` a cycle early (the input of its last register) */
  val outEarly = if (regs.last >= 1) Some(IO(Output(UInt(fmt.width.W)))) else None
  val flags = IO(Output(new FloatFlags))

  override def desiredName = s"RoundPack_${fmt.tag}_s$sigW" + (if (tinyExact) "_x" else "") +
    (if (maxLz < sigW - 1) s"_z$maxLz" else "")

  private val m      = fmt.manW
  private val w      = RoundPack.sigNW(fmt, sigW) // at least manW+1 kept bits, a guard bit and one more below
  private val levels = RoundPack.levels(fmt, sigW, maxLz)
  private val lzW    = math.max(levels, 1)
  private val eW     = fmt.expIntW + 1
  private var step   = 0
  private def cut[T <: Data](x: T): T = { val r = Stages.delay(x, regs(step)); step += 1; r }

  // ---- normalise, two levels a step; the biased exponent and the zero test beside it
  class Norm extends Bundle {
    val raw    = new RawFloat(fmt, sigW)
    val sigN   = UInt(w.W)
    val lz     = UInt(lzW.W)
    val free   = Bool()
    val cap    = UInt(fmt.expW.W)
    val expB0  = SInt(eW.W) // biased exponent of the MSB of sig
    val isZero = Bool()
  }
  private val n0 = Wire(new Norm)
  n0.raw    := in
  n0.sigN   := (if (w > sigW) Cat(in.sig, 0.U((w - sigW).W)) else in.sig)
  n0.lz     := 0.U
  n0.cap    := cap.getOrElse(0.U)
  n0.free   := Shift.capFree(cap, levels)
  n0.expB0  := in.exp +& fmt.bias.S
  n0.isZero := in.sig === 0.U && !in.sticky
  private val norm = Shift.groups(levels).foldLeft(n0) { (r, ks) =>
    val s = Wire(new Norm)
    val (v, free, bits) = Shift.normaliseLevels(r.sigN, r.free, cap.map(_ => r.cap), ks)
    s      := r
    s.sigN := v
    s.free := free
    s.lz   := Shift.addMoves(r.lz, ks, bits)
    cut(s)
  }

  // ---- the exponent of the normalised significand; the kept bits, the guard bit and the sticky rest
  class Kept extends Bundle {
    val raw    = new RawFloat(fmt, sigW)
    val isZero = Bool()
    val tiny   = Bool()
    val fieldM = UInt(eW.W) // exponent field - 1 before rounding (0 for a tiny result)
    val kept   = UInt((m + 1).W)
    val guard  = Bool()
    val rest   = Bool()
  }
  private val top   = norm.sigN(w - 1, w - 2 - m) // kept bits and the guard bit
  private val below = if (w - 3 - m >= 0) norm.sigN(w - 3 - m, 0).orR || norm.raw.sticky else norm.raw.sticky
  private val kept: Kept = if (tinyExact) {
    val s = Wire(new Kept)
    s.raw    := norm.raw
    s.isZero := norm.isZero
    s.tiny   := !norm.sigN(w - 1)
    s.fieldM := (norm.expB0 - 1.S - norm.lz.zext).asUInt // the capped shift leaves a tiny result at expB 1
    s.kept   := top(m + 1, 1)
    s.guard  := top(0)
    s.rest   := below
    cut(s)
  } else {
    // the exponent and the right shift into the subnormal range; then the shift, its wide levels and then its
    // narrow ones
    val shW = log2Ceil(m + 3)
    class Sub extends Bundle {
      val k   = new Kept
      val v   = UInt((m + 2).W)
      val rsh = UInt(shW.W)
    }
    class Exps extends Bundle {
      val k     = new Kept
      val v     = UInt((m + 2).W)
      val expB  = SInt(eW.W)
      val negB  = SInt(eW.W) // 1 - expB
      val expBm = SInt(eW.W) // expB - 1
    }
    val e = Wire(new Exps)
    e.k.raw    := norm.raw
    e.k.isZero := norm.isZero
    e.k.tiny   := DontCare
    e.k.fieldM := DontCare
    e.k.kept   := DontCare
    e.k.guard  := DontCare
    e.k.rest   := below
    e.v        := top
    e.expB     := norm.expB0 - norm.lz.zext
    e.negB     := 1.S - norm.expB0 + norm.lz.zext
    e.expBm    := norm.expB0 - 1.S - norm.lz.zext
    val re   = cut(e)
    val tiny = re.expB < 1.S
    val far  = re.expB < (1 - (m + 2)).S
    val a = Wire(new Sub)
    a.k        := re.k
    a.k.tiny   := tiny
    a.k.fieldM := Mux(tiny, 0.S, re.expBm).asUInt
    a.v        := re.v
    a.rsh      := Mux(far, (m + 2).U, Mux(tiny, re.negB.asUInt, 0.U))(shW - 1, 0)
    val ra = cut(a)
    val (wide, narrow) = (0 until shW).reverse.splitAt((shW + 1) / 2)
    val (v1, st1) = Shift.rightStickyLevels(ra.v, ra.rsh, wide, ra.k.rest)
    val b = Wire(new Sub)
    b        := ra
    b.v      := v1
    b.k.rest := st1
    val rb = cut(b)
    val (v2, st2) = Shift.rightStickyLevels(rb.v, rb.rsh, narrow, rb.k.rest)
    val c = Wire(new Kept)
    c       := rb.k
    c.kept  := v2(m + 1, 1)
    c.guard := v2(0)
    c.rest  := st2
    cut(c)
  }

  // ---- round to nearest, ties to even
  val s2 = Wire(new Bundle {
    val raw     = new RawFloat(fmt, sigW)
    val isZero  = Bool()
    val tiny    = Bool()
    val fieldM  = UInt(eW.W)
    val rounded = UInt((m + 2).W)
    val carry   = UInt(2.W) // rounded(m + 1, m), from an AND of the kept bits beside the adder, not its carry out
    val inexact = Bool()
    val ovf     = Vec(4, Bool()) // field >= maxExpField if the significand adds c to it (c = 3 never occurs)
    val fieldC  = Vec(3, UInt(eW.W)) // fieldM + c for c = 0, 1, 2, beside the rounding
  })
  s2.raw     := kept.raw
  s2.isZero  := kept.isZero
  s2.tiny    := kept.tiny
  s2.fieldM  := kept.fieldM
  private val inc = kept.guard && (kept.rest || kept.kept(0))
  private val carryM = inc && kept.kept(m - 1, 0).andR // the increment ripples into the hidden bit
  s2.rounded := kept.kept +& inc
  s2.carry   := Cat(kept.kept(m) && carryM, kept.kept(m) ^ carryM)
  s2.inexact := kept.guard || kept.rest
  for (c <- 0 until 4) s2.ovf(c) := kept.fieldM >= (fmt.maxExpField - math.min(c, 2)).U
  for (c <- 0 until 3) s2.fieldC(c) := kept.fieldM + c.U
  val r2 = cut(s2)

  // ---- pack (the significand's top bits, 0 to 2 with a rounding carry, add to the exponent field; the three
  // sums and overflow tests were made beside the rounding, and the top bits beside its adder, so that only the
  // stored significand bits come from the adder's carry chain)
  private val c        = r2.carry
  private val field    = VecInit(r2.fieldC :+ (r2.fieldM + 3.U))(c)
  private val overflow = r2.ovf(c)
  private val raw      = r2.raw
  private val packed   = Cat(field(fmt.expW - 1, 0), r2.rounded(m - 1, 0))
  private val finite   = Mux(overflow, fmt.inf(false).U(fmt.width.W), packed)
  private val special  = raw.isNaN || raw.isInf || raw.isZero || r2.isZero
  private val mag = Mux(raw.isNaN, fmt.qNaN.U,
    Mux(raw.isInf, fmt.inf(false).U, Mux(raw.isZero || r2.isZero, 0.U, finite)))
  private val o = Wire(UInt(fmt.width.W))
  o := Cat(raw.sign && !raw.isNaN, mag(fmt.width - 2, 0))
  private val f = Wire(new FloatFlags)
  f.invalid   := raw.invalid
  f.divByZero := raw.divByZero
  f.overflow  := !special && overflow
  f.underflow := !special && r2.tiny && r2.inexact
  f.inexact   := !special && (r2.inexact || overflow)
  private val last = regs(step)
  out   := Stages.delay(o, last)
  outEarly.foreach(_ := Stages.delay(o, last - 1))
  flags := Stages.delay(f, last)
  require(step + 1 == nSteps, s"RoundPack: $step steps built, ${nSteps - 1} expected before the last")
}

object RoundPack {
  def sigNW(fmt: FloatFormat, sigW: Int): Int = math.max(sigW, fmt.manW + 3)
  def levels(fmt: FloatFormat, sigW: Int, maxLz: Int): Int =
    log2Ceil(math.min(maxLz, sigNW(fmt, sigW) - 1) + 1)

  /** The weights of its steps (Stages): the normaliser's groups, the exponent and the kept bits (four steps with
    * the subnormal right shift), rounding, packing. */
  def weights(fmt: FloatFormat, sigW: Int, maxLz: Int = Int.MaxValue, tinyExact: Boolean = false): Seq[Int] =
    Shift.groups(levels(fmt, sigW, maxLz)).map(_.length * 2) ++
      (if (tinyExact) Seq(2) else Seq(2, 3, 3, 3)) ++ Seq(3, 3)
}
