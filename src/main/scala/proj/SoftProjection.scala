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
  * Two steps of l_A registers each: (t, e, s), then the case selection and the outputs, saturated to outW bits
  * (the flags report it). The result lies in the set exactly whenever it fits.
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
  private def d1[T <: Data](v: T): T = ShiftRegister(v, latAdd)

  // step 1
  val t   = io.x -& io.c
  val neg = t < 0.S
  val e   = Mux(neg, 0.S -& t, t) -& io.r
  val s   = e +& io.d
  val (x1, dv1, c1, r1, neg1, e1, s1) = (d1(io.x), d1(io.d), d1(io.c), d1(io.r), d1(neg), d1(e), d1(s))

  // step 2
  val inside = dv1 >= 0.S && dv1 >= e1
  val flat   = !inside && e1 <= 0.S
  val corner = !inside && !flat && s1 <= 0.S
  val half   = FixedOps.shiftRound(s1, 1, rounding)
  val mag    = r1 +& Mux(corner, 0.S, half)
  val xo     = Mux(inside || flat, x1, Mux(neg1, c1 -& mag, c1 +& mag))
  val dOut   = Mux(inside, dv1, Mux(corner || flat, 0.S, half))
  val (xs, xf) = FixedOps.saturate(xo, outW)
  val (ds, df) = FixedOps.saturate(dOut, outW)
  io.xOut := d1(xs)
  io.dOut := d1(ds)
  io.xOvf := d1(xf)
  io.dOvf := d1(df)
}
