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
  * same cycle (resp, and rdata for reads). `earlyAddr` (and `earlyData`) carry the same request a cycle before
  * `valid`, so that the register file can decode it into registers ahead of the access.
  */
class RegWrite(addrW: Int) extends Bundle {
  val valid     = Output(Bool())
  val addr      = Output(UInt(addrW.W))
  val data      = Output(UInt(32.W))
  val strb      = Output(UInt(4.W))
  /** the request of the next cycle's access (high the cycle before `valid`) */
  val earlyValid = Output(Bool())
  val earlyAddr = Output(UInt(addrW.W))
  val earlyData = Output(UInt(32.W))
  val resp      = Input(UInt(2.W))
}
class RegRead(addrW: Int) extends Bundle {
  val valid     = Output(Bool())
  val addr      = Output(UInt(addrW.W))
  val earlyAddr = Output(UInt(addrW.W))
  val data      = Input(UInt(32.W))
  val resp      = Input(UInt(2.W))
}

/** A write request in a register: word address, data, strobes. */
class AxiLiteWord(addrW: Int) extends Bundle {
  val addr = UInt(addrW.W)
  val data = UInt(32.W)
  val strb = UInt(4.W)
}

object AxiLiteSlave {
  /** cycles from a write's AW/W handshake to its B valid, and from a read's AR handshake to its R valid */
  val WriteResponseCycles = 3
  val ReadResponseCycles  = 3
}

/** AXI4-Lite subordinate front end: takes one write (AW and W together) and one read at a time and turns each
  * into a single-cycle register access. Byte addresses; `addr` is the word address (byte address / 4).
  *
  * The request passes two registers before the register file's access: the first holds it as the handshake left
  * it (offered as `earlyAddr` / `earlyData`, for the register file's decode), the second is the access. The access
  * is two cycles after the handshake and the response (B or R) three. No port of the bus reaches logic, and the
  * register file's address compares and range checks end in registers of their own.
  */
class AxiLiteSlave(addrW: Int) extends Module {
  val axi = IO(Flipped(new AxiLiteIO(addrW)))
  val wr  = IO(new RegWrite(addrW - 2))
  val rd  = IO(new RegRead(addrW - 2))

  val bValid = RegInit(false.B)
  val bResp  = RegInit(0.U(2.W))
  val wHeld  = RegInit(false.B)
  val wAcc   = RegInit(false.B)
  private val w0 = Reg(new AxiLiteWord(addrW - 2))  // held: the decode's input
  private val w1 = Reg(new AxiLiteWord(addrW - 2))  // the access
  // !bValid && !wHeld && !wAcc kept in a register: the write handshake is one gate from the bus and it
  val wFree  = RegInit(true.B)
  val doWr   = axi.awvalid && axi.wvalid && wFree
  axi.awready := doWr
  axi.wready  := doWr
  when(doWr) {
    w0.addr := axi.awaddr >> 2
    w0.data := axi.wdata
    w0.strb := axi.wstrb
  }
  wHeld := doWr
  wAcc  := wHeld
  when(wHeld) { w1 := w0 }
  wr.valid     := wAcc
  wr.addr      := w1.addr
  wr.data      := w1.data
  wr.strb      := w1.strb
  wr.earlyValid := wHeld
  wr.earlyAddr := w0.addr
  wr.earlyData := w0.data
  when(wAcc) {
    bValid := true.B
    bResp  := wr.resp
  }.elsewhen(axi.bready) {
    bValid := false.B
  }
  wFree := !doWr && !wHeld && !(bValid && !axi.bready) && !wAcc
  axi.bvalid := bValid
  axi.bresp  := bResp

  val rValid = RegInit(false.B)
  val rData  = RegInit(0.U(32.W))
  val rResp  = RegInit(0.U(2.W))
  val rHeld  = RegInit(false.B)
  val rAcc   = RegInit(false.B)
  val rAddr0 = Reg(UInt((addrW - 2).W))
  val rAddr1 = Reg(UInt((addrW - 2).W))
  val doRd   = axi.arvalid && !rValid && !rHeld && !rAcc
  axi.arready := doRd
  when(doRd) { rAddr0 := axi.araddr >> 2 }
  rHeld := doRd
  rAcc  := rHeld
  when(rHeld) { rAddr1 := rAddr0 }
  rd.valid     := rAcc
  rd.addr      := rAddr1
  rd.earlyAddr := rAddr0
  when(rAcc) {
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
