package fixed

import chisel3._
import chisel3.util.{Cat, ShiftRegister}
import dsp.{Ecp5Mult18, Target}

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

  /** The limbs of x for `dspW`-bit signed multiplier inputs: (dspW - 1)-bit unsigned limbs from the bottom,
    * zero-extended to dspW signed bits, and a signed top limb of at most dspW bits; x = sum_i limb_i 2^((dspW-1) i).
    */
  private def limbs(x: SInt, dspW: Int): Seq[SInt] = {
    val w = x.getWidth
    if (w <= dspW) Seq(x)
    else {
      val k = dspW - 1
      val n = Target.limbCount(w, dspW) // low limbs of k bits, then a signed top limb of 1..dspW bits
      (0 until n - 1).map(i => Cat(0.U(1.W), x.asUInt(k * i + k - 1, k * i)).asSInt) :+
        x.asUInt(w - 1, k * (n - 1)).asSInt
    }
  }

  private def reg[T <: Data](x: T): T = { val r = Reg(chiselTypeOf(x)); r := x; r }

  /** One signed product of limbs (at most 18 x 18 bits) on an ECP5 MULT18X18D, three cycles later. */
  private def ecp5Product(a: SInt, b: SInt): SInt = {
    val m = Module(new Ecp5Mult18)
    m.io.clk := Module.clock
    m.io.a   := a.pad(18).asUInt
    m.io.b   := b.pad(18).asUInt
    m.io.p(a.getWidth + b.getWidth - 1, 0).asSInt
  }

  /** a * b (+ addend) after `lat` register stages (the value is exact; only the structure differs with lat and the
    * target, so every target gives the same words at the same cycle).
    *
    * generic and xilinx7: lat 0, 1: the product, then lat registers. lat 2: the operands are registered first, so
    * that the multiplier sits between registers. lat >= 3: operands wider than the DSP inputs (18 x 18; xilinx7
    * 25 x 18, the wider operand on the 25-bit port) are split into limbs, each partial product (one DSP each) is
    * registered, and the next stage sums them with the addend; so no carry chain follows a DSP in the same cycle
    * (xilinx7: the operand, product and sum registers are the DSP48E1's AREG/BREG, MREG and PREG).
    *
    * ecp5 (lat >= target.minLatency): each partial product on a MULT18X18D with its three registers (its input
    * registers take the operands); one product without addend is the DSP's output, otherwise a fourth stage sums
    * the partial products and the addend. Stages more than that: a trailing register, then (with a sum) fabric
    * registers that land the DSP outputs before the sum, then registers of the operands in fabric before the DSP.
    */
  def mulPipelined(a: SInt, b: SInt, lat: Int, addend: BigInt = 0, target: Target = Target.Generic): SInt = {
    val (v, n) = mulStages(a, b, lat, addend, target)
    ShiftRegister(v, n)
  }

  /** mulPipelined as (the product before its trailing plain registers, their number): a caller may put logic of
    * its own before them (the same words at the same cycle, with the logic on the earlier side of a register). */
  def mulStages(a: SInt, b: SInt, lat: Int, addend: BigInt = 0, target: Target = Target.Generic): (SInt, Int) = {
    val prodW = a.getWidth + b.getWidth
    // ecp5: the addend is summed in the fourth stage, with the partial products if there are several
    val need = target.minLatency(a.getWidth, b.getWidth).max(if (target == Target.Ecp5 && addend != 0) 4 else 0)
    require(lat >= need && (need == 0 || lat >= 3),
      s"the ${target.name} multiplier of ${a.getWidth} x ${b.getWidth} bits needs lat_mul >= $need: got $lat")
    def summed(parts: Seq[(SInt, Int)]): SInt = {
      val terms = parts.map { case (pp, sh) => (pp << sh).asSInt } :+ addend.S((addend.bitLength + 1).W)
      terms.reduce(_ +& _)(prodW, 0).asSInt
    }
    if (target == Target.Ecp5) {
      // Stages beyond the DSP's needs: the first is a trailing register (a caller may put its logic before it); the
      // second, where partial products are summed, lands the DSP outputs in fabric registers before the sum; the
      // next registers the operands in fabric first, so that the DSP's input registers take a register's output
      // over the routing to the DSP column, with no logic before it.
      val extra    = lat - need
      val sumStage = need >= 4
      val land     = sumStage && extra >= 2
      val front    = extra >= (if (land) 3 else 2)
      val (fa, fb) = if (front) (reg(a), reg(b)) else (a, b)
      val k        = DspWidth - 1
      val (limbsA, limbsB) = (limbs(fa, DspWidth), limbs(fb, DspWidth))
      val parts = for ((la, i) <- limbsA.zipWithIndex; (lb, j) <- limbsB.zipWithIndex)
        yield (ecp5Product(la, lb), k * (i + j))
      // The product of the two unsigned low limbs is below 2^(2k), where the product of the next two starts: the
      // two are one word side by side, and the sum has a term fewer.
      def joined(ps: Seq[(SInt, Int)]): Seq[(SInt, Int)] =
        if (limbsA.length < 2 || limbsB.length < 2) ps
        else {
          val i11 = limbsB.length + 1
          (Cat(ps(i11)._1, ps.head._1.asUInt(2 * k - 1, 0)).asSInt, 0) +: ps.patch(i11, Nil, 1).tail
        }
      val rest = lat - (if (front) 1 else 0)
      if (!sumStage) (parts.head._1, rest - 3)
      else if (land) (reg(summed(joined(parts.map { case (pp, sh) => (reg(pp), sh) }))), rest - 5)
      else (reg(summed(joined(parts))), rest - 4)
    } else if (lat >= 3) {
      // the operand that fits the wider port goes there (xilinx7: A is 25 bits)
      val (x, y) = if (b.getWidth > a.getWidth && b.getWidth <= target.dspA) (b, a) else (a, b)
      val (rx, ry) = (reg(x), reg(y))
      val parts = for ((lx, i) <- limbs(rx, target.dspA).zipWithIndex; (ly, j) <- limbs(ry, target.dspB).zipWithIndex)
        yield (reg(lx * ly), (target.dspA - 1) * i + (target.dspB - 1) * j)
      (reg(summed(parts)), lat - 3)
    } else {
      val p = if (lat == 2) reg(a) * reg(b) else a * b
      (if (addend == 0) p else p +& addend.S, if (lat == 2) 1 else lat)
    }
  }

  /** (a * b) / 2^shift rounded (shiftRound) after `lat` register stages; where the structure has a stage that sums
    * partial products (lat >= 3, ecp5 lat >= 4), the rounding offset is added there, so only wiring follows the
    * last register. */
  def mulRoundPipelined(a: SInt, b: SInt, lat: Int, shift: Int, mode: Rounding,
                        target: Target = Target.Generic): SInt = {
    val fold = lat >= (if (target == Target.Ecp5) 4 else 3) && shift > 0 && mode == Rounding.Nearest
    if (fold) mulPipelined(a, b, lat, BigInt(1) << (shift - 1), target) >> shift
    else shiftRound(mulPipelined(a, b, lat, 0, target), shift, mode)
  }

  /** mulRoundPipelined saturated to `width` bits, with the overflow flag. Where the multiplier's words come from a
    * register (a DSP target, or l_M >= 3) and plain registers follow, the rounding and the saturation go before
    * them: the adder that takes the product then starts at a register. */
  def mulRoundSatPipelined(a: SInt, b: SInt, lat: Int, shift: Int, mode: Rounding, target: Target,
                           width: Int): (SInt, Bool) = {
    val fold = lat >= (if (target == Target.Ecp5) 4 else 3) && shift > 0 && mode == Rounding.Nearest
    val (v, n) = mulStages(a, b, lat, if (fold) BigInt(1) << (shift - 1) else 0, target)
    def rounded(x: SInt): SInt = if (fold) x >> shift else shiftRound(x, shift, mode)
    if (n >= 1 && (target != Target.Generic || lat >= 3)) {
      val (sv, of) = saturate(rounded(v), width)
      (ShiftRegister(sv, n), ShiftRegister(of, n))
    } else saturate(rounded(ShiftRegister(v, n)), width)
  }

  /** a + b saturated to `width` bits. */
  def satAdd(a: SInt, b: SInt, width: Int): (SInt, Bool) = saturate(a +& b, width)

  /** satAdd whose result and flag come after `lat` register stages (0 and no flag where `zero`, a Bool of the
    * operands' cycle); with lat >= 2 the first register sits between the adder's carry chain and the saturation,
    * so neither shares a cycle with what follows. */
  def satAddPipelined(a: SInt, b: SInt, width: Int, lat: Int, zero: Bool = false.B): (SInt, Bool) =
    if (lat >= 2) {
      val s = a +& b
      val r = Reg(SInt(s.getWidth.W))
      r := Mux(zero, 0.S, s)
      val (v, of) = saturate(r, width)
      (ShiftRegister(v, lat - 1), ShiftRegister(of, lat - 1))
    } else {
      val (v, of) = satAdd(a, b, width)
      (ShiftRegister(Mux(zero, 0.S(width.W), v), lat), ShiftRegister(of && !zero, lat))
    }

  /** a - b saturated to `width` bits. */
  def satSub(a: SInt, b: SInt, width: Int): (SInt, Bool) = saturate(a -& b, width)

  /** (a * b) / 2^shift, rounded, saturated to `width` bits. */
  def mulRound(a: SInt, b: SInt, shift: Int, mode: Rounding, width: Int): (SInt, Bool) =
    saturate(shiftRound(a * b, shift, mode), width)

  /** a < b as the sign of a - b: a carry chain (synthesis may build a comparison as a chain of LUTs instead) */
  def lt(a: SInt, b: SInt): Bool = { val d = a -& b; d(d.getWidth - 1) }

  /** min(max(x, lo), hi), in the width of x; the flag is high when x was outside [lo, hi]. */
  def clamp(x: SInt, lo: SInt, hi: SInt): (SInt, Bool) = {
    val below = lt(x, lo)
    val above = lt(hi, x)
    (clampSelect(below, above, x, lo, hi), below || above)
  }

  /** The select of `clamp` from its two comparisons (a pipeline may register them in between). */
  def clampSelect(below: Bool, above: Bool, x: SInt, lo: SInt, hi: SInt): SInt = Mux(below, lo, Mux(above, hi, x))
}
