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

/** Normalise, round to nearest even and pack: the last four steps of every arithmetic operator but the multiplier
  * (FMul has its own). Step 0: leading-zero normalisation (level by level, Shift.normalise). Step 1: the kept
  * bits, a guard bit and the sticky rest, after a right shift into the subnormal range. Step 2: rounding
  * increment. Step 3: packing (the rounding carry ripples into the exponent), overflow to infinity, specials.
  * `regs(i)` registers follow step i (from the operator's Stages).
  *
  * Left normalisation is exact only if bits inserted below the LSB are not needed: an operator passing a
  * nonzero sticky must have at most (sig.getWidth - manW - 2) leading zeros, so that the guard bit is a
  * computed bit (FDiv: <= 1; FSqrt: 0; FAdd passes sticky = 0, its sticky bit being the sum's LSB).
  *
  * `maxLz`: the most leading zeros a nonzero `sig` can have (FDiv 1, FSqrt 0): fewer normalisation levels.
  * `tinyExact`: every tiny result is exact and the MSB of `sig` weighs at least 2^emin (sums: FAdd). The left
  * shift then stops at the smallest normal exponent (Shift.normalise with a cap), which leaves a tiny result
  * subnormal already: no right shift.
  */
class RoundPack(fmt: FloatFormat, sigW: Int, regs: Seq[Int], maxLz: Int = Int.MaxValue, tinyExact: Boolean = false)
    extends Module {
  require(regs.length == RoundPack.steps,
    s"RoundPack has ${RoundPack.steps} steps: got ${regs.length} register counts")
  val in  = IO(Input(new RawFloat(fmt, sigW)))
  val out = IO(Output(UInt(fmt.width.W)))
  val flags = IO(Output(new FloatFlags))

  override def desiredName = s"RoundPack_${fmt.tag}_s$sigW" + (if (tinyExact) "_x" else "") +
    (if (maxLz < sigW - 1) s"_z$maxLz" else "")

  private val m = fmt.manW
  // at least manW+1 kept bits, a guard bit and one more below it
  private val w = math.max(sigW, m + 3)

  // ---- step 0: normalise
  val s0 = Wire(new Bundle {
    val raw  = new RawFloat(fmt, sigW)
    val sigN = UInt(w.W)
    val expB = SInt((fmt.expIntW + 1).W) // biased exponent of the MSB of sigN
  })
  private val sigP   = if (w > sigW) Cat(in.sig, 0.U((w - sigW).W)) else in.sig
  private val expB0  = in.exp +& fmt.bias.S // biased exponent of the MSB of sig
  private val levels = log2Ceil(math.min(maxLz, w - 1) + 1)
  private val cap    = if (tinyExact) Some((expB0 - 1.S).asUInt) else None // >= 0 by the caller's promise
  private val (sigN, lz) = Shift.normalise(sigP, levels, cap)
  s0.raw  := in
  s0.sigN := sigN
  s0.expB := expB0 - lz.zext
  val r0 = Stages.delay(s0, regs(0))

  // ---- step 1: shift into the subnormal range; the kept bits, the guard bit and the sticky rest
  val s1 = Wire(new Bundle {
    val raw    = new RawFloat(fmt, sigW)
    val isZero = Bool()
    val tiny   = Bool()
    val expEff = SInt((fmt.expIntW + 1).W)
    val kept   = UInt((m + 1).W)
    val guard  = Bool()
    val rest   = Bool()
  })
  private val top   = r0.sigN(w - 1, w - 2 - m) // kept bits and the guard bit
  private val below = if (w - 3 - m >= 0) r0.sigN(w - 3 - m, 0).orR || r0.raw.sticky else r0.raw.sticky
  s1.raw    := r0.raw
  s1.isZero := r0.sigN === 0.U && !r0.raw.sticky
  if (tinyExact) {
    s1.tiny   := !r0.sigN(w - 1)
    s1.expEff := r0.expB
    s1.kept   := top(m + 1, 1)
    s1.guard  := top(0)
    s1.rest   := below
  } else {
    val tiny = r0.expB < 1.S
    val far  = r0.expB < (1 - (m + 2)).S
    val rsh  = Mux(far, (m + 2).U, Mux(tiny, (1.S - r0.expB).asUInt, 0.U))(log2Ceil(m + 3) - 1, 0)
    val (sh, dropped) = Shift.rightSticky(top, rsh)
    s1.tiny   := tiny
    s1.expEff := Mux(tiny, 1.S, r0.expB)
    s1.kept   := sh(m + 1, 1)
    s1.guard  := sh(0)
    s1.rest   := dropped || below
  }
  val r1 = Stages.delay(s1, regs(1))

  // ---- step 2: round to nearest, ties to even
  val s2 = Wire(new Bundle {
    val raw     = new RawFloat(fmt, sigW)
    val isZero  = Bool()
    val tiny    = Bool()
    val expEff  = SInt((fmt.expIntW + 1).W)
    val rounded = UInt((m + 2).W)
    val inexact = Bool()
  })
  s2.raw     := r1.raw
  s2.isZero  := r1.isZero
  s2.tiny    := r1.tiny
  s2.expEff  := r1.expEff
  s2.rounded := r1.kept +& (r1.guard && (r1.rest || r1.kept(0)))
  s2.inexact := r1.guard || r1.rest
  val r2 = Stages.delay(s2, regs(2))

  // ---- step 3: pack (a rounding carry out of the significand increments the exponent field)
  private val field    = (r2.expEff - 1.S).asUInt +& r2.rounded(m + 1, m) // expEff >= 1
  private val overflow = field >= fmt.maxExpField.U
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
  out   := Stages.delay(o, regs(3))
  flags := Stages.delay(f, regs(3))
}

object RoundPack {
  val steps = 4
}
