package fixed

import chisel3._
import chisel3.util.{Cat, ShiftRegister}

/** Named fixed-point operations on SInt. Every narrowing saturates and reports it: nothing wraps. */
object FixedOps {
  def maxOf(width: Int): BigInt = (BigInt(1) << (width - 1)) - 1
  def minOf(width: Int): BigInt = -(BigInt(1) << (width - 1))

  /** Signed bits needed to hold every integer in [-bound, bound]. */
  def bitsFor(bound: BigInt): Int = bound.abs.bitLength + 1

  /** x / 2^shift back to fewer fraction bits, by the given rounding. */
  def shiftRound(x: SInt, shift: Int, mode: Rounding): SInt =
    if (shift == 0) x
    else
      mode match {
        case Rounding.Truncate => x >> shift
        case Rounding.Nearest  => (x +& (BigInt(1) << (shift - 1)).S) >> shift
      }

  /** Clamp x into a `width`-bit signed word; the flag is high when the value had to be clamped.
    * x fits iff its bits above width-1 all equal bit width-1: a wide AND/OR, no comparator carry chain.
    */
  def saturate(x: SInt, width: Int): (SInt, Bool) =
    if (x.getWidth <= width) (x.pad(width), false.B)
    else {
      val top  = x.asUInt(x.getWidth - 1, width - 1)
      val fits = top.andR || !top.orR
      val neg  = x.asUInt(x.getWidth - 1)
      val lim  = Mux(neg, minOf(width).S(width.W), maxOf(width).S(width.W))
      (Mux(fits, x.asUInt(width - 1, 0).asSInt, lim), !fits)
    }

  /** DSP multiplier inputs: 18 x 18 signed (ECP5 MULT18X18D; DSP48E1 takes 25 x 18). */
  val DspWidth = 18

  /** The limbs of x for DSP multipliers: 17-bit unsigned limbs from the bottom, zero-extended to 18 signed bits,
    * and a signed top limb of at most 18 bits; x = sum_i limb_i 2^(17 i). */
  private def limbs(x: SInt): Seq[SInt] = {
    val w = x.getWidth
    if (w <= DspWidth) Seq(x)
    else {
      val k = DspWidth - 1
      val n = (w - 2) / k + 1 // low limbs of k bits, then a signed top limb of 1..18 bits
      (0 until n - 1).map(i => Cat(0.U(1.W), x.asUInt(k * i + k - 1, k * i)).asSInt) :+
        x.asUInt(w - 1, k * (n - 1)).asSInt
    }
  }

  /** a * b (+ addend) after `lat` register stages (the value is exact; only the timing differs with lat).
    * lat 0, 1: the product, then lat registers. lat 2: the operands are registered first, so that the multiplier
    * sits between registers. lat >= 3: operands wider than the DSP inputs are split into limbs, each partial
    * product (one DSP each) is registered, and the next stage sums them with the addend; so no carry chain
    * follows a DSP in the same cycle.
    */
  def mulPipelined(a: SInt, b: SInt, lat: Int, addend: BigInt = 0): SInt = {
    def reg[T <: Data](x: T): T = { val r = Reg(chiselTypeOf(x)); r := x; r }
    val prodW = a.getWidth + b.getWidth
    if (lat >= 3) {
      val (ra, rb) = (reg(a), reg(b))
      val k        = DspWidth - 1
      val parts = for ((la, i) <- limbs(ra).zipWithIndex; (lb, j) <- limbs(rb).zipWithIndex)
        yield (reg(la * lb), k * (i + j))
      val terms = parts.map { case (pp, sh) => (pp << sh).asSInt } :+ addend.S((addend.bitLength + 1).W)
      val sum   = terms.reduce(_ +& _)
      ShiftRegister(reg(sum(prodW, 0).asSInt), lat - 3)
    } else {
      val p = if (lat == 2) reg(a) * reg(b) else a * b
      ShiftRegister(if (addend == 0) p else p +& addend.S, if (lat == 2) 1 else lat)
    }
  }

  /** (a * b) / 2^shift rounded (shiftRound) after `lat` register stages; from lat = 3 on, the rounding offset is
    * added with the partial products, so only wiring follows the last register. */
  def mulRoundPipelined(a: SInt, b: SInt, lat: Int, shift: Int, mode: Rounding): SInt =
    if (lat >= 3 && shift > 0 && mode == Rounding.Nearest)
      mulPipelined(a, b, lat, BigInt(1) << (shift - 1)) >> shift
    else shiftRound(mulPipelined(a, b, lat), shift, mode)

  /** a + b saturated to `width` bits. */
  def satAdd(a: SInt, b: SInt, width: Int): (SInt, Bool) = saturate(a +& b, width)

  /** a - b saturated to `width` bits. */
  def satSub(a: SInt, b: SInt, width: Int): (SInt, Bool) = saturate(a -& b, width)

  /** (a * b) / 2^shift, rounded, saturated to `width` bits. */
  def mulRound(a: SInt, b: SInt, shift: Int, mode: Rounding, width: Int): (SInt, Bool) =
    saturate(shiftRound(a * b, shift, mode), width)

  /** min(max(x, lo), hi), in the width of x; the flag is high when x was outside [lo, hi]. */
  def clamp(x: SInt, lo: SInt, hi: SInt): (SInt, Bool) = {
    val below = x < lo
    val above = x > hi
    (Mux(below, lo, Mux(above, hi, x)), below || above)
  }
}
