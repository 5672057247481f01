package float

import chisel3._
import chisel3.util._
import dsp.{Ecp5Mult18, Target}

/** a * b rounded to nearest even, in `latency` cycles, with its own rounding path (not RoundPack).
  *
  * Steps (`FMul.weights`): classify and pick the operand to normalise; its leading-zero normalisation, two
  * levels a step; the exponent as the right shift needs it (a register after it lands on the multiplier's
  * inputs); the significand product (wider than 18 x 18: registered partial products, then their sum) beside
  * its trailing zeros (the operands', counted at classification, plus the normalisation's shift); the product
  * cut to its top manW + 3 bits, and the sticky bit of each shift it may take from the trailing zeros; the 1-bit
  * normalisation and the shift into the subnormal range, both as one right shift (wide levels, then narrow ones);
  * round to nearest even; exponent field with the rounding carry, overflow; specials and flags.
  *
  * Why it is exact: one normaliser suffices. If exactly one operand is subnormal, it is normalised (its leading
  * one moved to the hidden bit), and the product of two [1, 2) significands lies in [1, 4): its MSB or the bit
  * below is set. If both are subnormal, only one is normalised and the product may have more leading zeros, but
  * it is then below 2^(2 (1 - bias)), so tiny: its bits are taken at fixed weights (the subnormal ulp) whatever
  * their leading zeros, and the hidden-bit position is never assumed. The bits dropped below the kept
  * significand and the guard bit only matter through their OR.
  *
  * Target ecp5 (a significand of at most 18 bits): the product is an unsigned MULT18X18D with its input, pipeline
  * and output registers on (Ecp5Mult18). Its input and output registers are the registers before and after the
  * product step (forced there) and its pipeline register is one cycle more: the other steps share latency - 1
  * registers (`FMul.minLatency`). Words are those of every target.
  */
class FMul(val fmt: FloatFormat, val latency: Int, val target: Target = Target.Generic) extends Module {
  val in_valid  = IO(Input(Bool()))
  val a         = IO(Input(UInt(fmt.width.W)))
  val b         = IO(Input(UInt(fmt.width.W)))
  val out_valid = IO(Output(Bool()))
  val out       = IO(Output(UInt(fmt.width.W)))
  val flags     = IO(Output(new FloatFlags))

  override def desiredName = s"FMul_${fmt.tag}_l$latency" + (if (FMul.onDsp(fmt, target)) s"_${target.name}" else "")

  private val onDsp = FMul.onDsp(fmt, target)
  FMul.checkLatency(fmt, target, latency, "latency")
  val stages =
    if (onDsp) Stages(latency - 1, FMul.weights(fmt), Set(FMul.productStep(fmt) - 1, FMul.productStep(fmt)))
    else Stages(latency, FMul.weights(fmt))
  private val m      = fmt.manW
  private val w      = fmt.sigW
  private val winW   = m + 3                 // product bits kept past step 2: significand, guard, one below
  private val shW    = log2Ceil(winW + 1)    // right shifts 0 .. winW (winW clears the window)
  private val fieldW = fmt.expW + 2          // exponent field before the overflow test, with its carry
  // signed width of the product's biased exponent: from 3 - bias - manW (two subnormals) to 2^(expW+1) - bias
  private val pW     = math.max(fmt.expW + 2, log2Ceil(fmt.bias + m + 1) + 1)
  private val tzW    = log2Ceil(2 * w + 1)
  private val lowW   = 2 * w - winW          // product bits below the window
  /** Trailing zeros of a significand, counted on its fraction field in two halves at classification and combined in
    * the first normalisation step (a count over all bits is too deep beside the operand register). The hidden bit
    * is left out, so that no exponent decode comes first: a zero fraction counts manW, the trailing zeros of a
    * normal significand, and a zero operand's count is never used (its product is a special zero, without flags). */
  private val loW = (m + 1) / 2
  private val hiW = m - loW
  class Tz extends Bundle {
    val loZero = Bool()                      // the low half is zero
    val lo     = UInt(log2Ceil(loW).W)       // its trailing zeros when not
    val hi     = UInt(log2Ceil(hiW + 1).W)   // the high half's (hiW when zero)
  }
  private def tzCount(frac: UInt): Tz = {
    val t = Wire(new Tz)
    t.loZero := frac(loW - 1, 0) === 0.U
    t.lo     := PriorityEncoder(frac(loW - 1, 0))
    t.hi     := (if (hiW == 0) 0.U else { val hi = frac(m - 1, loW); Mux(hi === 0.U, hiW.U, PriorityEncoder(hi)) })
    t
  }
  private def tzOf(t: Tz): UInt = Mux(t.loZero, loW.U +& t.hi, t.lo.pad(tzW))

  /** What decides the result besides the significand. */
  class Special extends Bundle {
    val sign    = Bool()
    val isNaN   = Bool()
    val isInf   = Bool()
    val isZero  = Bool()
    val invalid = Bool()
  }

  /** The exponent as the right shift of step 3 needs it. `beP` is the biased exponent of the product's MSB
    * weight (2^(2 manW + 1) of the significand product); the leading one is there or one below (`top`).
    * tiny = beP + top <= 1. shift = tiny ? 2 - beP : top (capped at winW); field - 1 = beP - 2 + top if not tiny.
    */
  class Expo extends Bundle {
    val low    = Bool()          // beP <= 0: tiny whatever top
    val edge   = Bool()          // beP == 1: tiny if top is clear
    val shTiny = UInt(shW.W)     // min(2 - beP, winW)
    val base   = UInt(fieldW.W)  // beP - 2 (mod 2^fieldW)
  }

  private var step = 0
  private def cut[T <: Data](x: T): T = { val r = stages.cut(step, x); step += 1; r }

  // ---- classify, pick the subnormal operand (a if subnormal, else b) to normalise, exponent fields
  class Norm extends Bundle {
    val x    = new Unpack.NormSig(fmt) // the operand being normalised
    val y    = UInt(w.W)
    val eSum = SInt(pW.W) // beP + lz; at classification the sum of the exponent fields, made beP + lz by the first
                          // normalisation step from eZero
    val eZero = Vec(2, Bool()) // a's and b's exponent field is zero (a subnormal or zero operand: field 1)
    val tzA  = new Tz      // the operands' trailing zeros, until the first normalisation step sums them into tz
    val tzB  = new Tz
    val tz   = UInt(tzW.W) // their sum (the normalisation adds lz)
    val spc  = new Special
  }
  private val ua   = Unpack(fmt, a)
  private val ub   = Unpack(fmt, b)
  private val aSub = !ua.sig(m)
  private def expBits(u: UInt) = u(fmt.width - 2, m)
  private val zeroTimesInf = (ua.isZero && ub.isInf) || (ua.isInf && ub.isZero)
  val s0 = Wire(new Norm)
  s0.x           := Unpack.startNormalise(fmt, Mux(aSub, ua.sig, ub.sig))
  s0.y           := Mux(aSub, ub.sig, ua.sig)
  s0.eSum        := (expBits(a) +& expBits(b)).pad(pW).asSInt
  s0.eZero(0)    := expBits(a) === 0.U
  s0.eZero(1)    := expBits(b) === 0.U
  s0.tzA         := tzCount(a(m - 1, 0))
  s0.tzB         := tzCount(b(m - 1, 0))
  s0.tz          := 0.U
  s0.spc.sign    := ua.sign ^ ub.sign
  s0.spc.isNaN   := ua.isNaN || ub.isNaN || zeroTimesInf
  s0.spc.isInf   := ua.isInf || ub.isInf
  s0.spc.isZero  := ua.isZero || ub.isZero
  s0.spc.invalid := ua.isSNaN || ub.isSNaN || zeroTimesInf
  require(Unpack.normaliseSteps(fmt).nonEmpty, s"FMul: ${fmt.name} has no normalisation step to sum the exponents in")
  private val norm = Unpack.normaliseSteps(fmt).zipWithIndex.foldLeft(cut(s0)) { case (r, (ks, i)) =>
    val s = Wire(new Norm)
    s   := r
    s.x := Unpack.normaliseStep(fmt, r.x, ks)
    if (i == 0) {
      s.tz    := tzOf(r.tzA) + tzOf(r.tzB)
      s.tzA   := 0.U.asTypeOf(new Tz)
      s.tzB   := 0.U.asTypeOf(new Tz)
      // a field of zero counts 1 (subnormal): beP + lz = field(a) + field(b) - (bias - 1), the constant chosen by
      // the two flags so that one adder follows their register
      val k = (c: Int) => ((BigInt(c - (fmt.bias - 1)) % (BigInt(1) << pW) + (BigInt(1) << pW)) % (BigInt(1) << pW)).U(pW.W)
      val z = r.eZero
      s.eSum  := (r.eSum.asUInt + Mux(z(0) && z(1), k(2), Mux(z(0) || z(1), k(1), k(0))))(pW - 1, 0).asSInt
      s.eZero := 0.U.asTypeOf(s.eZero)
    }
    cut(s)
  }

  // ---- the normalised operands and the product's exponent; the right shift's view of it (Expo) and the product's
  // trailing zeros are formed beside the multiplier, not after the normaliser's last levels
  val s1 = Wire(new Bundle {
    val x    = UInt(w.W)
    val y    = UInt(w.W)
    val eSum = SInt(pW.W) // beP + lz
    val tz   = UInt(tzW.W) // the operands' trailing zeros before normalisation
    val lz   = UInt(log2Ceil(w).W)
    val spc  = new Special
  })
  s1.x    := norm.x.sig
  s1.y    := norm.y
  s1.eSum := norm.eSum
  s1.tz   := norm.tz
  s1.lz   := norm.x.lz
  s1.spc  := norm.spc
  val r1 = cut(s1)
  private def expo(eSum: SInt, lz: UInt): Expo = {
    val beP = (eSum - lz.zext)(pW - 1, 0).asSInt
    val e   = Wire(new Expo)
    e.low    := beP <= 0.S
    e.edge   := beP === 1.S
    e.shTiny := Mux(beP <= (2 - winW).S, winW.U, (2.S - beP).asUInt(shW - 1, 0))
    e.base   := (beP - 2.S).asUInt(fieldW - 1, 0)
    e
  }
  /** the product's trailing zeros: the normalised operand's grow by its shift */
  private def tzOfProduct(t: UInt, lz: UInt): UInt = t + lz

  // ---- the product (2 w bits); wider than 18 x 18, as registered partial products of 18-bit high limbs, summed
  // in a step of their own
  class Prod extends Bundle {
    val prod = UInt((2 * w).W)
    val tz   = UInt(tzW.W) // the product's trailing zeros (2 w when zero), from the operands'
    val e    = new Expo
    val spc  = new Special
  }
  private val prod: Prod = if (onDsp) {
    // the DSP's input registers stand for r1's x and y, its output register for this step's; the pipeline
    // register between them is the cycle the other fields wait here
    val dsp = Module(new Ecp5Mult18(signed = false))
    dsp.io.clk := clock
    dsp.io.a   := s1.x.pad(18)
    dsp.io.b   := s1.y.pad(18)
    // the other fields wait here; their exponent and trailing-zero logic runs in the pipeline register's cycle
    val mid  = RegNext(r1) // its x and y are unused: the DSP holds them
    val wait = Wire(new Prod)
    wait.prod := 0.U
    wait.tz   := tzOfProduct(mid.tz, mid.lz)
    wait.e    := expo(mid.eSum, mid.lz)
    wait.spc  := mid.spc
    val late = cut(wait)
    val o = Wire(new Prod)
    o.prod := dsp.io.p(2 * w - 1, 0)
    o.tz   := late.tz
    o.e    := late.e
    o.spc  := late.spc
    o
  } else if (w <= FMul.dspW) {
    val s = Wire(new Prod)
    s.prod := r1.x * r1.y
    s.tz   := tzOfProduct(r1.tz, r1.lz)
    s.e    := expo(r1.eSum, r1.lz)
    s.spc  := r1.spc
    cut(s)
  } else {
    val l  = w - FMul.dspW // low limb bits
    class Parts extends Bundle {
      val hh  = UInt((2 * FMul.dspW).W)
      val tz  = UInt(tzW.W)
      val hl  = UInt((FMul.dspW + l).W)
      val lh  = UInt((FMul.dspW + l).W)
      val ll  = UInt((2 * l).W)
      val e   = new Expo
      val spc = new Special
    }
    val (xh, xl, yh, yl) = (r1.x(w - 1, l), r1.x(l - 1, 0), r1.y(w - 1, l), r1.y(l - 1, 0))
    val pp = Wire(new Parts)
    pp.hh  := xh * yh
    pp.hl  := xh * yl
    pp.lh  := xl * yh
    pp.ll  := xl * yl
    pp.tz  := tzOfProduct(r1.tz, r1.lz)
    pp.e   := expo(r1.eSum, r1.lz)
    pp.spc := r1.spc
    val rp = cut(pp)
    val s = Wire(new Prod)
    s.prod := ((rp.hh ## rp.ll) + ((rp.hl +& rp.lh) << l))(2 * w - 1, 0)
    s.tz   := rp.tz
    s.e    := rp.e
    s.spc  := rp.spc
    cut(s)
  }

  // ---- the product cut to its top winW bits. The sticky bit of the right shift below (shift 0 .. winW) is the OR
  // of the product's bits under lowW + shift, which are all zero exactly when the product has that many trailing
  // zeros: tz(x y) = tz(x) + tz(y), compared here for the three shifts it can take (shTiny, 0, 1), so that no OR of
  // the product's bits follows the multiplier
  val s2 = Wire(new Bundle {
    val win     = UInt(winW.W)
    val stTiny  = Bool() // sticky after a shift of shTiny
    val stShift = Vec(2, Bool()) // after a shift of 0, 1
    val e       = new Expo
    val spc     = new Special
  })
  s2.win        := prod.prod(2 * w - 1, 2 * w - winW)
  s2.stTiny     := prod.tz < (lowW.U +& prod.e.shTiny)
  s2.stShift(0) := prod.tz < lowW.U
  s2.stShift(1) := prod.tz < (lowW + 1).U
  s2.e          := prod.e
  s2.spc        := prod.spc
  val r2 = cut(s2)

  // ---- one right shift normalises by one bit or moves into the subnormal range: its wide levels, then the
  // narrow ones
  class Shifting extends Bundle {
    val v      = UInt(winW.W)
    val shift  = UInt(shW.W)
    val sticky = Bool()
    val tiny   = Bool()
    val fieldM = UInt(fieldW.W) // exponent field - 1 of a normal result, 0 for a tiny one
    val spc    = new Special
  }
  private val (wide, narrow) = (0 until shW).reverse.splitAt((shW + 1) / 2)
  private val top   = r2.win(winW - 1)
  private val tiny  = r2.e.low || (r2.e.edge && !top)
  private val shift = Mux(r2.e.low, r2.e.shTiny, (r2.e.edge || top).asUInt)
  private val (shA, _) = Shift.rightStickyLevels(r2.win, shift, wide, false.B)
  val sa = Wire(new Shifting)
  sa.v      := shA
  sa.shift  := shift
  sa.sticky := Mux(r2.e.low, r2.stTiny, r2.stShift((r2.e.edge || top).asUInt))
  sa.tiny   := tiny
  sa.fieldM := Mux(tiny, 0.U, r2.e.base + top)
  sa.spc    := r2.spc
  val ra = cut(sa)

  val s3 = Wire(new Bundle {
    val kept   = UInt(w.W)
    val guard  = Bool()
    val sticky = Bool()
    val tiny   = Bool()
    val fieldM = UInt(fieldW.W)
    val spc    = new Special
  })
  private val (sh, _) = Shift.rightStickyLevels(ra.v, ra.shift, narrow, false.B)
  s3.kept   := sh(w, 1)
  s3.guard  := sh(0)
  s3.sticky := ra.sticky
  s3.tiny   := ra.tiny
  s3.fieldM := ra.fieldM
  s3.spc    := ra.spc
  val r3 = cut(s3)

  // ---- round to nearest, ties to even
  val s4 = Wire(new Bundle {
    val rounded = UInt((w + 1).W)
    val inexact = Bool()
    val tiny    = Bool()
    val fieldM  = UInt(fieldW.W)
    val ovf     = Vec(3, Bool()) // field >= maxExpField if the significand's top bits add c to it
    val spc     = new Special
  })
  s4.rounded := r3.kept +& (r3.guard && (r3.sticky || r3.kept(0)))
  s4.inexact := r3.guard || r3.sticky
  s4.tiny    := r3.tiny
  s4.fieldM  := r3.fieldM
  for (c <- 0 until 3) s4.ovf(c) := r3.fieldM >= (fmt.maxExpField - c).U
  s4.spc     := r3.spc
  val r4 = cut(s4)

  // ---- exponent field (the significand's top bits, 0 to 2 with a rounding carry, add to it), overflow to
  // infinity from the compares made beside the rounding (no carry chain ahead of the special-case selects)
  val s5 = Wire(new Bundle {
    val mag      = UInt((fmt.width - 1).W)
    val overflow = Bool()
    val inexact  = Bool()
    val tiny     = Bool()
    val spc      = new Special
  })
  private val top2  = r4.rounded(w, m)
  private val field = r4.fieldM + top2
  s5.overflow := Mux(top2(1), r4.ovf(2), Mux(top2(0), r4.ovf(1), r4.ovf(0)))
  s5.mag      := Cat(field(fmt.expW - 1, 0), r4.rounded(m - 1, 0))
  s5.inexact  := r4.inexact
  s5.tiny     := r4.tiny
  s5.spc      := r4.spc
  val r5 = cut(s5)

  // ---- specials, sign and flags
  private val spc     = r5.spc
  private val special = spc.isNaN || spc.isInf || spc.isZero
  private val infMag  = (BigInt(fmt.maxExpField) << m).U((fmt.width - 1).W)
  private val mag = Mux(spc.isNaN, fmt.qNaN.U((fmt.width - 1).W),
    Mux(spc.isInf || (!spc.isZero && r5.overflow), infMag, Mux(spc.isZero, 0.U, r5.mag)))
  private val o = Wire(UInt(fmt.width.W))
  o := Cat(spc.sign && !spc.isNaN, mag)
  private val f = Wire(new FloatFlags)
  f.invalid   := spc.invalid
  f.divByZero := false.B
  f.overflow  := !special && r5.overflow
  f.underflow := !special && r5.tiny && r5.inexact
  f.inexact   := !special && (r5.inexact || r5.overflow)
  out       := stages.cut(step, o)
  flags     := stages.cut(step, f)
  require(step + 1 == stages.steps, s"FMul: ${step + 1} steps built, ${stages.steps} weighed")
  out_valid := Stages.delayValid(in_valid, latency)
}

object FMul {
  /** Operand width of one hard multiplier: wider significands are split into partial products. */
  val dspW = 18
  /** Step weights (Stages): classify, the normaliser's groups, the exponent, the product (partial products and
    * their sum when wider than dspW), the window, the two shift steps, rounding, the field, specials. */
  def weights(fmt: FloatFormat): Seq[Int] =
    Seq(4) ++ Unpack.normaliseSteps(fmt).map(_.length * 2) ++ Seq(4) ++
      (if (fmt.sigW <= dspW) Seq(6) else Seq(6, 4)) ++ Seq(3, 4, 4, 3, 3, 3)
  def steps(fmt: FloatFormat): Int = weights(fmt).length
  def defaultLatency(fmt: FloatFormat): Int = 3
  /** the product's step: after classify, the normaliser's steps and the exponent */
  def productStep(fmt: FloatFormat): Int = 2 + Unpack.normaliseSteps(fmt).length
  /** whether the product is a MULT18X18D with its registers (ecp5, a significand of one DSP's width) */
  def onDsp(fmt: FloatFormat, target: Target): Boolean = target == Target.Ecp5 && fmt.sigW <= dspW
  /** the fewest cycles: on the DSP, its three registers and the output's */
  def minLatency(fmt: FloatFormat, target: Target): Int = if (onDsp(fmt, target)) 4 else 0
  /** refuses a multiplier latency (`key`: its name where it is set) below minLatency */
  def checkLatency(fmt: FloatFormat, target: Target, latency: Int, key: String): Unit =
    require(latency >= minLatency(fmt, target), s"the ${target.name} multiplier in ${fmt.name} needs $key >= " +
      s"${minLatency(fmt, target)} (the MULT18X18D's input, pipeline and output registers and the output's): got " +
      s"$key=$latency")
}
