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
  *
  * The request is registered before the register file sees it (the access is the cycle after the handshake, the
  * response the cycle after that), so no port of the bus reaches an address decode or a read select: the ports
  * meet registers only.
  */
class AxiLiteSlave(addrW: Int) extends Module {
  val axi = IO(Flipped(new AxiLiteIO(addrW)))
  val wr  = IO(new RegWrite(addrW - 2))
  val rd  = IO(new RegRead(addrW - 2))

  val bValid = RegInit(false.B)
  val bResp  = RegInit(0.U(2.W))
  val wPend  = RegInit(false.B)
  val wAddr  = Reg(UInt((addrW - 2).W))
  val wData  = Reg(UInt(32.W))
  val wStrb  = Reg(UInt(4.W))
  val doWr   = axi.awvalid && axi.wvalid && !bValid && !wPend
  axi.awready := doWr
  axi.wready  := doWr
  when(doWr) {
    wPend := true.B
    wAddr := axi.awaddr >> 2
    wData := axi.wdata
    wStrb := axi.wstrb
  }
  wr.valid := wPend
  wr.addr  := wAddr
  wr.data  := wData
  wr.strb  := wStrb
  when(wPend) {
    wPend  := false.B
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
  val rPend  = RegInit(false.B)
  val rAddr  = Reg(UInt((addrW - 2).W))
  val doRd   = axi.arvalid && !rValid && !rPend
  axi.arready := doRd
  when(doRd) {
    rPend := true.B
    rAddr := axi.araddr >> 2
  }
  rd.valid := rPend
  rd.addr  := rAddr
  when(rPend) {
    rPend  := false.B
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
