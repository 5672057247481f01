package bus

import chisel3._
import chisel3.util._

/** A FIFO of `depth` words that an empty queue passes straight through, as `chisel3.util.Queue(flow = true)` does
  * (the same words on the same cycles), with its flags in registers: deq's valid is the registered non-empty flag
  * or enq's valid, and enq's ready the registered not-full flag, so no pointer compare lies on either. The words
  * sit in a memory of asynchronous read (distributed RAM), as in Queue.
  */
class FlowQueue[T <: Data](gen: T, depth: Int) extends Module {
  require(depth >= 2, "flow queue depth")
  val io = IO(new Bundle {
    val enq = Flipped(Decoupled(gen))
    val deq = Decoupled(gen)
  })
  private val ram      = Mem(depth, gen)
  private val wp       = RegInit(0.U(log2Ceil(depth).W))
  private val rp       = RegInit(0.U(log2Ceil(depth).W))
  private val count    = RegInit(0.U(log2Ceil(depth + 1).W))
  private val nonEmpty = RegInit(false.B)
  private val notFull  = RegInit(true.B)
  private def inc(p: UInt): UInt = Mux(p === (depth - 1).U, 0.U, p + 1.U)
  io.enq.ready := notFull
  io.deq.valid := nonEmpty || io.enq.valid
  io.deq.bits  := Mux(nonEmpty, ram(rp), io.enq.bits)
  private val push = io.enq.valid && notFull && !(!nonEmpty && io.deq.ready) // empty and taken: passes through
  private val pop  = io.deq.ready && nonEmpty
  when(push) { ram(wp) := io.enq.bits; wp := inc(wp) }
  when(pop) { rp := inc(rp) }
  private val next = count + push.asUInt - pop.asUInt
  count    := next
  nonEmpty := next =/= 0.U
  notFull  := next =/= depth.U
}
