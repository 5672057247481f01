package bus

import chisel3._
import chisel3.util._

/** AXI4-Lite, 32-bit data, manager view (use Flipped for a subordinate port named s_axil). */
class AxiLiteIO(val addrW: Int) extends Bundle {
  val awaddr  = Output(UInt(addrW.W))
  val awprot  = Output(UInt(3.W))
  val awvalid = Output(Bool())
  val awready = Input(Bool())
  val wdata   = Output(UInt(32.W))
  val wstrb   = Output(UInt(4.W))
  val wvalid  = Output(Bool())
  val wready  = Input(Bool())
  val bresp   = Input(UInt(2.W))
  val bvalid  = Input(Bool())
  val bready  = Output(Bool())
  val araddr  = Output(UInt(addrW.W))
  val arprot  = Output(UInt(3.W))
  val arvalid = Output(Bool())
  val arready = Input(Bool())
  val rdata   = Input(UInt(32.W))
  val rresp   = Input(UInt(2.W))
  val rvalid  = Input(Bool())
  val rready  = Output(Bool())
}

object AxiLiteResp {
  val OKAY:   UInt = 0.U(2.W)
  val SLVERR: UInt = 2.U(2.W)
  val DECERR: UInt = 3.U(2.W)
}

/** Word-access request towards a register file: valid for exactly one cycle; the register file answers in the
  * same cycle (resp, and rdata for reads).
  */
class RegWrite(addrW: Int) extends Bundle {
  val valid = Output(Bool())
  val addr  = Output(UInt(addrW.W))
  val data  = Output(UInt(32.W))
  val strb  = Output(UInt(4.W))
  val resp  = Input(UInt(2.W))
}
class RegRead(addrW: Int) extends Bundle {
  val valid = Output(Bool())
  val addr  = Output(UInt(addrW.W))
  val data  = Input(UInt(32.W))
  val resp  = Input(UInt(2.W))
}

/** AXI4-Lite subordinate front end: takes one write (AW and W together) and one read at a time and turns each
  * into a single-cycle register access. Byte addresses; `addr` is the word address (byte address / 4).
  */
class AxiLiteSlave(addrW: Int) extends Module {
  val axi = IO(Flipped(new AxiLiteIO(addrW)))
  val wr  = IO(new RegWrite(addrW - 2))
  val rd  = IO(new RegRead(addrW - 2))

  val bValid = RegInit(false.B)
  val bResp  = RegInit(0.U(2.W))
  val doWr   = axi.awvalid && axi.wvalid && !bValid
  axi.awready := doWr
  axi.wready  := doWr
  wr.valid    := doWr
  wr.addr     := axi.awaddr >> 2
  wr.data     := axi.wdata
  wr.strb     := axi.wstrb
  when(doWr) {
    bValid := true.B
    bResp  := wr.resp
  }.elsewhen(axi.bready) {
    bValid := false.B
  }
  axi.bvalid := bValid
  axi.bresp  := bResp

  val rValid = RegInit(false.B)
  val rData  = RegInit(0.U(32.W))
  val rResp  = RegInit(0.U(2.W))
  val doRd   = axi.arvalid && !rValid
  axi.arready := doRd
  rd.valid    := doRd
  rd.addr     := axi.araddr >> 2
  when(doRd) {
    rValid := true.B
    rData  := rd.data
    rResp  := rd.resp
  }.elsewhen(axi.rready) {
    rValid := false.B
  }
  axi.rvalid := rValid
  axi.rdata  := rData
  axi.rresp  := rResp
  Protocol.axiLiteResponses("s_axil", axi)
}
