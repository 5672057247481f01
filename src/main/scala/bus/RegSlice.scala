package bus

import chisel3._
import chisel3.util.Decoupled

/** A register slice of a ready/valid stream: every output (deq's valid and bits, enq's ready) comes from a
  * register, so no combinational path crosses it. Full throughput, one cycle of latency: a word taken on cycle t
  * is offered from cycle t + 1. A skid register holds the word taken while the output stalls.
  */
class RegSlice[T <: Data](gen: T) extends Module {
  val io = IO(new Bundle {
    val enq = Flipped(Decoupled(gen))
    val deq = Decoupled(gen)
  })
  val outV  = RegInit(false.B)
  val outD  = Reg(gen)
  val skidV = RegInit(false.B)
  val skidD = Reg(gen)
  io.enq.ready := !skidV
  io.deq.valid := outV
  io.deq.bits  := outD
  // the skid register follows the input while it is empty, so its enable is a register (not the handshake)
  when(!skidV) { skidD := io.enq.bits }
  when(io.deq.ready || !outV) { // the output register takes a word (or empties)
    outV  := skidV || io.enq.valid
    outD  := Mux(skidV, skidD, io.enq.bits)
    skidV := false.B
  }.elsewhen(io.enq.fire) {     // the output stalls: the word waits in the skid register
    skidV := true.B
  }
}

/** A word of a stream with its tlast, for a RegSlice of an AXI4-Stream. */
class StreamWord(w: Int) extends Bundle {
  val data = UInt(w.W)
  val last = Bool()
}
