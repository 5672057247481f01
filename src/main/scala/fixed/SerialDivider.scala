package fixed

import chisel3._
import chisel3.util._

/** floor(x / d) of a signed x by a positive d, one quotient bit per cycle (restoring division on |x|, the
  * negative case as -ceil(|x| / d) = -(floor((|x| - 1) / d) + 1), the complement of floor((|x| - 1) / d), so that
  * no intermediate leaves xW bits whatever dW). `start` samples x and d; `done` is high for one cycle, xW + 1 cycles
  * after `start`, and `q` holds the quotient from then until the next start.
  */
class SerialDivider(xW: Int, dW: Int) extends Module {
  val io = IO(new Bundle {
    val start = Input(Bool())
    val x     = Input(SInt(xW.W))
    val d     = Input(UInt(dW.W))
    val busy  = Output(Bool())
    val done  = Output(Bool())
    val q     = Output(SInt(xW.W))
  })
  val a    = Reg(UInt(xW.W))
  val d    = Reg(UInt(dW.W))
  val rem  = Reg(UInt((dW + 1).W))
  val quo  = Reg(UInt(xW.W))
  val neg  = Reg(Bool())
  val cnt  = RegInit(0.U(log2Ceil(xW + 1).W))
  val busy = RegInit(false.B)
  val done = RegInit(false.B)
  done := false.B
  when(io.start) {
    val isNeg = io.x < 0.S
    // |x| for x >= 0; |x| - 1 = -x - 1 = ~x for x < 0 (then floor(x / d) = ~floor((|x| - 1) / d))
    a    := Mux(isNeg, (~io.x).asUInt, io.x.asUInt)
    d    := io.d
    rem  := 0.U
    quo  := 0.U
    neg  := isNeg
    cnt  := xW.U
    busy := true.B
  }.elsewhen(busy) {
    val shifted = Cat(rem(dW - 1, 0), a(xW - 1))
    val ge      = shifted >= d
    rem  := Mux(ge, shifted - d, shifted)
    quo  := Cat(quo(xW - 2, 0), ge)
    a    := a << 1
    cnt  := cnt - 1.U
    when(cnt === 1.U) { busy := false.B; done := true.B }
  }
  io.busy := busy
  io.done := done
  io.q    := Mux(neg, (~quo).asSInt, quo.asSInt)
}
