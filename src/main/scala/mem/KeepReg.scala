package mem

import chisel3._
import chisel3.util._

/** A register that synthesis keeps apart: Yosys merges flip-flops with the same input into one, which defeats
  * copies of a register made so that each drives the loads beside it (a fan-out across the device split into
  * short routes). The inline Verilog marks its process (* keep *), which Yosys carries to its flip-flops and
  * opt_merge respects; simulators ignore the attribute. No reset.
  */
class KeepRegBox(w: Int) extends BlackBox(Map("W" -> w)) with HasBlackBoxInline {
  require(w >= 1, s"KeepReg: width $w")
  val io = IO(new Bundle {
    val clock = Input(Clock())
    val d     = Input(UInt(w.W))
    val q     = Output(UInt(w.W))
  })
  override def desiredName = "KeepReg"
  setInline("KeepReg.sv",
    """// A register that synthesis keeps apart: not merged with registers of the same input, so that each copy
      |// drives the loads beside it. (* keep *) on the process carries to its flip-flops.
      |module KeepReg #(parameter W = 1) (
      |  input              clock,
      |  input      [W-1:0] d,
      |  output reg [W-1:0] q
      |);
      |  (* keep *) always @(posedge clock) q <= d;
      |endmodule
      |""".stripMargin)
}

object KeepReg {
  /** `n` copies of `d` registered: kept apart (`keep`, an FPGA target) so that each drives its own loads, else one
    * register (RegNext) for all */
  def copies[T <: Data](d: T, n: Int, keep: Boolean): Seq[T] =
    if (keep) Seq.fill(n)(apply(d)) else { val r = RegNext(d); Seq.fill(n)(r) }

  /** `d` registered in a kept register (RegNext that synthesis does not merge with its equals) */
  def apply[T <: Data](d: T): T = {
    val r = Module(new KeepRegBox(d.getWidth))
    r.io.clock := Module.clock
    r.io.d     := d.asUInt
    r.io.q.asTypeOf(d)
  }
}
