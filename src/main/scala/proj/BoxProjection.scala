package proj

import chisel3._
import chisel3.util._
import fixed.FixedOps

/** Projection of one component onto [lo, hi] (Fig. 3a of 002): compare, select, then l_A registers. */
class BoxProjection(inW: Int, outW: Int, latAdd: Int) extends Module {
  override def desiredName = s"BoxProjection_i${inW}_o${outW}_la$latAdd"
  val io = IO(new Bundle {
    val in  = Input(SInt(inW.W))
    val lo  = Input(SInt(outW.W))
    val hi  = Input(SInt(outW.W))
    val out = Output(SInt(outW.W))
  })
  // lo <= hi fit outW bits, so the clamped value does too.
  val (c, _) = FixedOps.clamp(io.in, io.lo, io.hi)
  io.out := ShiftRegister(c(outW - 1, 0).asSInt, latAdd)
}
