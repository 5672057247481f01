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
  * the same values in four steps of one carry chain each (the chains of a step side by side), registered after each
  * step, the last followed by the remaining 2 l_A - 4 registers:
  *   1. t = x - c, -t, c + r, c - r, d + 1 (rounding to nearest; d when truncating)
  *   2. e = (t or -t) - r, -d
  *   3. s' = e + d + 1 (nearest; e + d when truncating), inside, flat, s <= 0 as e <= -d
  *   4. m = s' >> 1 (0 beyond the corner), x = (c - r) - m or (c + r) + m, d, saturation.
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
    // step 1
    val t1   = r(io.x -& io.c)
    val mt1  = r(io.c -& io.x)
    val cp1  = r(io.c +& io.r)
    val cm1  = r(io.c -& io.r)
    val dp1  = r(io.d +& one.S)
    val (x1, d1, r1) = (r(io.x), r(io.d), r(io.r))
    // step 2
    val neg  = t1 < 0.S
    val e2   = r(Mux(neg, mt1, t1) -& r1)
    val md2  = r(0.S -& d1)
    val (x2, d2, dp2, cp2, cm2, neg2) = (r(x1), r(d1), r(dp1), r(cp1), r(cm1), r(neg))
    // step 3
    val sp3     = r(e2 +& dp2)
    val inside3 = r(d2 >= 0.S && d2 >= e2)
    val flat3   = r(e2 <= 0.S)
    val sle3    = r(e2 <= md2) // s <= 0
    val (x3, d3, cp3, cm3, neg3) = (r(x2), r(d2), r(cp2), r(cm2), r(neg2))
    // step 4
    val inside = inside3
    val flat   = !inside && flat3
    val corner = !inside && !flat && sle3
    val half   = sp3 >> 1
    val m      = Mux(corner, 0.S, half)
    val xo     = Mux(inside || flat, x3, Mux(neg3, cm3 -& m, cp3 +& m))
    val dOut   = Mux(inside, d3, Mux(corner || flat, 0.S, half))
    output(xo, dOut, 2 * latAdd - 3)
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
