package bus

import chisel3._

/** AXI4-Stream with the signals the cores use. Declare as `val s_axis = IO(Flipped(new AxiStreamIO(w)))` or
  * `val m_axis = IO(new AxiStreamIO(w))` so the ports are s_axis_tdata, ... and cocotbext-axi binds by prefix.
  * `userW` > 0 adds tuser (the problem id of a core that interleaves several problems).
  */
class AxiStreamIO(val dataW: Int, val userW: Int = 0) extends Bundle {
  require(dataW % 8 == 0, s"AXI4-Stream tdata width must be a multiple of 8, got $dataW")
  require(userW >= 0, s"AXI4-Stream tuser width must be >= 0, got $userW")
  val tdata  = Output(UInt(dataW.W))
  val tvalid = Output(Bool())
  val tready = Input(Bool())
  val tlast  = Output(Bool())
  /** the problem id of an interleaving core (absent when userW = 0) */
  val tuser  = if (userW > 0) Some(Output(UInt(userW.W))) else None
  def fire: Bool = tvalid && tready
}
