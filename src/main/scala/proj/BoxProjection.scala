package proj

import chisel3._
import chisel3.util._
import fixed.FixedOps

/** Projection of one component onto [lo, hi] (Fig. 3a of 002): compare, select, l_A registers (from l_A = 2 one
  * of them between the comparisons and the selection). */
class BoxProjection(inW: Int, outW: Int, latAdd: Int) extends Module {
  override def desiredName = s"BoxProjection_i${inW}_o${outW}_la$latAdd"
  val io = IO(new Bundle {
    val in  = Input(SInt(inW.W))
    val lo  = Input(SInt(outW.W))
    val hi  = Input(SInt(outW.W))
    val out = Output(SInt(outW.W))
  })
  // lo <= hi fit outW bits, so the clamped value does too. With l_A >= 2 the comparisons end in registers and the
  // selection follows in the next cycle.
  if (latAdd >= 2) {
    def r[T <: Data](v: T): T = RegNext(v)
    val (below, above) = (r(FixedOps.lt(io.in, io.lo)), r(FixedOps.lt(io.hi, io.in)))
    val c = FixedOps.clampSelect(below, above, r(io.in), r(io.lo), r(io.hi))
    io.out := ShiftRegister(c(outW - 1, 0).asSInt, latAdd - 1)
  } else {
    val (c, _) = FixedOps.clamp(io.in, io.lo, io.hi)
    io.out := ShiftRegister(c(outW - 1, 0).asSInt, latAdd)
  }
}
