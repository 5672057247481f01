package bus

import chisel3._
import chisel3.util.Decoupled

/** A register slice of a ready/valid stream: a two-word FIFO whose flags are registers, so no combinational path
  * crosses it (enq's ready, deq's valid and the select of deq's bits are registers). Full throughput, one cycle of
  * latency: a word taken on cycle t is offered from cycle t + 1. The words are written from the enq side alone
  * (the free place follows the input), so deq's ready meets only the read pointer and the flags, not the data.
  */
class RegSlice[T <: Data](gen: T) extends Module {
  val io = IO(new Bundle {
    val enq = Flipped(Decoupled(gen))
    val deq = Decoupled(gen)
  })
  private val d        = Reg(Vec(2, gen))
  private val wr       = RegInit(0.U(1.W))
  private val rd       = RegInit(0.U(1.W))
  private val count    = RegInit(0.U(2.W))
  private val nonEmpty = RegInit(false.B)
  private val full     = RegInit(false.B)
  io.enq.ready := !full
  io.deq.valid := nonEmpty
  io.deq.bits  := d(rd)
  private val push = io.enq.valid && !full
  private val pop  = io.deq.ready && nonEmpty
  when(!full) { d(wr) := io.enq.bits } // the free place follows the input; a push keeps it
  when(push) { wr := ~wr }
  when(pop) { rd := ~rd }
  private val next = count + push.asUInt - pop.asUInt
  count    := next
  nonEmpty := next =/= 0.U
  full     := next === 2.U
}

/** A word of a stream with its tlast, for a RegSlice of an AXI4-Stream. */
class StreamWord(w: Int) extends Bundle {
  val data = UInt(w.W)
  val last = Bool()
}
