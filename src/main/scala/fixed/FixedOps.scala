package fixed

import chisel3._
import chisel3.util.ShiftRegister

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

  /** a * b after `lat` register stages. From two stages on, the first registers the operands, so that the
    * multiplier block sits between registers (memory outputs and multiplexers no longer share its path).
    */
  def mulPipelined(a: SInt, b: SInt, lat: Int): SInt =
    if (lat >= 2) {
      val ra = Reg(chiselTypeOf(a))
      val rb = Reg(chiselTypeOf(b))
      ra := a
      rb := b
      ShiftRegister(ra * rb, lat - 1)
    } else ShiftRegister(a * b, lat)

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
