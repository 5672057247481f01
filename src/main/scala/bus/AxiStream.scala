package bus

import chisel3._

/** AXI4-Stream with the signals the cores use. Declare as `val s_axis = IO(Flipped(new AxiStreamIO(w)))` or
  * `val m_axis = IO(new AxiStreamIO(w))` so the ports are s_axis_tdata, ... and cocotbext-axi binds by prefix.
  */
class AxiStreamIO(val dataW: Int) extends Bundle {
  require(dataW % 8 == 0, s"AXI4-Stream tdata width must be a multiple of 8, got $dataW")
  val tdata  = Output(UInt(dataW.W))
  val tvalid = Output(Bool())
  val tready = Input(Bool())
  val tlast  = Output(Bool())
  def fire: Bool = tvalid && tready
}
