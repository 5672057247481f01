package proj

import chisel3._
import chisel3.util._
import fixed.{FixedOps, Rounding}

/** Projection of a state component and its slack (x, d) onto {|x - c| <= r + d, d >= 0} (Fig. 3b of 002), in
  * integer words, in closed form:
  *
  *   t = x - c, e = |t| - r, s = e + d
  *   d >= 0 and d >= e  -> (x, d)                      inside
  *   e <= 0             -> (x, 0)                      below the flat edge
  *   s <= 0             -> (c +- r, 0)                 beyond the corner (sign of t)
  *   else m = s / 2 (rounded) -> (c +- (r + m), m)     onto the slanted edge
  *
  * The result is saturated to outW bits (the flags report it); it lies in the set exactly whenever it fits. The
  * latency is 2 l_A. With l_A <= 1: two steps, (t, e, s), then the case selection and the outputs. With l_A >= 2
  * the same values in three steps of one carry chain each (the chains of a step side by side) and a fourth of
  * selections only, registered after each step, the last followed by the remaining 2 l_A - 4 registers:
  *   1. t = x - c, -t, c + r, c - r, s0 = d + 1 (rounding to nearest; d when truncating)
  *   2. e = (t or -t) - r, -d, 2 (c + r) + s0, 2 (c - r) + 1 - s0; x, c + r, c - r and d saturated
  *   3. s' = e + s0, m = s' >> 1 and the slanted edge's c + r + m = (2 (c + r) + s0 + e) >> 1 and
  *      c - r - m = (2 (c - r) + 1 - s0 - e) >> 1, each saturated; the case (inside, x kept, beyond the corner)
  *   4. the selection of the saturated words and their flags.
  */
class SoftProjection(inW: Int, outW: Int, latAdd: Int, rounding: Rounding) extends Module {
  override def desiredName = s"SoftProjection_i${inW}_o${outW}_la${latAdd}_${rounding.name}"
  val io = IO(new Bundle {
    val x    = Input(SInt(inW.W))
    val d    = Input(SInt(inW.W))
    val c    = Input(SInt(outW.W))
    val r    = Input(SInt(outW.W))
    val xOut = Output(SInt(outW.W))
    val dOut = Output(SInt(outW.W))
    val xOvf = Output(Bool())
    val dOvf = Output(Bool())
  })
  private def r[T <: Data](v: T, k: Int = 1): T = ShiftRegister(v, k)

  if (latAdd <= 1) {
    // step 1
    val t   = io.x -& io.c
    val neg = t < 0.S
    val e   = Mux(neg, 0.S -& t, t) -& io.r
    val s   = e +& io.d
    val l   = latAdd
    val (x1, dv1, c1, r1, neg1, e1, s1) = (r(io.x, l), r(io.d, l), r(io.c, l), r(io.r, l), r(neg, l), r(e, l), r(s, l))

    // step 2
    val inside = dv1 >= 0.S && dv1 >= e1
    val flat   = !inside && e1 <= 0.S
    val corner = !inside && !flat && s1 <= 0.S
    val half   = FixedOps.shiftRound(s1, 1, rounding)
    val mag    = r1 +& Mux(corner, 0.S, half)
    val xo     = Mux(inside || flat, x1, Mux(neg1, c1 -& mag, c1 +& mag))
    val dOut   = Mux(inside, dv1, Mux(corner || flat, 0.S, half))
    output(xo, dOut, l)
  } else {
    val one = if (rounding == Rounding.Nearest) 1 else 0
    def rs(v: SInt): (SInt, Bool) = { val (w, f) = FixedOps.saturate(v, outW); (r(w), r(f)) }
    // step 1
    val t1   = r(io.x -& io.c)
    val mt1  = r(io.c -& io.x)
    val cp1  = r(io.c +& io.r)
    val cm1  = r(io.c -& io.r)
    val dp1  = r(io.d +& one.S)
    val (x1, d1, r1) = (r(io.x), r(io.d), r(io.r))
    // step 2: e, -d, and the slanted edge's sums less e: 2 (c + r) + d + one and 2 (c - r) + 1 - d - one
    val neg  = t1 < 0.S
    val e2   = r(Mux(neg, mt1, t1) -& r1)
    val md2  = r(0.S -& d1)
    val up2  = r((cp1 << 1) +& dp1)
    val dn2  = r(((cm1 << 1).asUInt | 1.U).asSInt -& dp1)
    val Seq(xs2, cps2, cms2, ds2) = Seq(x1, cp1, cm1, d1).map(rs)
    val (d2, dp2, neg2) = (r(d1), r(dp1), r(neg))
    // step 3: s' = e + d + one; c + r + (s' >> 1) = (up + e) >> 1; c - r - (s' >> 1) = (dn - e) >> 1; the case
    val hs3   = rs((e2 +& dp2) >> 1)
    val ups3  = rs((up2 +& e2) >> 1)
    val dns3  = rs((dn2 -& e2) >> 1)
    // comparisons as the signs of subtractions (FixedOps.lt): carry chains
    val in2   = !d2(d2.getWidth - 1) && !FixedOps.lt(d2, e2)
    val le2   = !FixedOps.lt(0.S, e2)
    val sle2  = !FixedOps.lt(md2, e2) // s <= 0 as e <= -d
    // the case, decoded into registers: step 4 only selects
    val in3   = r(in2)
    val keep3 = r(in2 || le2)                 // inside, or below the flat edge: x unchanged
    val cor3  = r(!(in2 || le2) && sle2)      // beyond the corner
    val zero3 = r(!in2 && (le2 || sle2))      // d is 0: beyond the corner or below the flat edge
    val Seq(xs3, cps3, cms3, ds3) = Seq(xs2, cps2, cms2, ds2).map { case (w, f) => (r(w), r(f)) }
    val neg3  = r(neg2)
    // step 4: selections of saturated words
    def pick[T <: Data](x: T, cm: T, cp: T, dn: T, up: T): T =
      Mux(keep3, x, Mux(cor3, Mux(neg3, cm, cp), Mux(neg3, dn, up)))
    val l = 2 * latAdd - 3
    io.xOut := r(pick(xs3._1, cms3._1, cps3._1, dns3._1, ups3._1), l)
    io.xOvf := r(pick(xs3._2, cms3._2, cps3._2, dns3._2, ups3._2), l)
    io.dOut := r(Mux(in3, ds3._1, Mux(zero3, 0.S(outW.W), hs3._1)), l)
    io.dOvf := r(Mux(in3, ds3._2, !zero3 && hs3._2), l)
  }

  private def output(xo: SInt, dOut: SInt, l: Int): Unit = {
    val (xs, xf) = FixedOps.saturate(xo, outW)
    val (ds, df) = FixedOps.saturate(dOut, outW)
    io.xOut := r(xs, l)
    io.dOut := r(ds, l)
    io.xOvf := r(xf, l)
    io.dOvf := r(df, l)
  }
}
