package shell

import chisel3._
import chisel3.util._
import bus.StreamWord

/** The output queue of a one-problem core's answer: four words between the answer register and m_axis. A word
  * pushed on cycle t is offered from t + 1. `room` says whether a push decided now (for the next cycle) fits:
  * count + push <= 2, from registers; pops only add room, so the queue never holds more than four words. In a
  * steady stream (tready high) a word enters and one leaves every cycle, so the answer leaves at full rate. The
  * stream's tready meets only the queue's read side, not the answer register's enables nor the sequencer.
  * Not a bus.RegSlice: the producer here decides its push a cycle ahead, so it needs the room for the next cycle
  * (two words of slack), where a RegSlice's ready speaks for the current one.
  */
class AnswerQueue(w: Int) extends Module {
  val io = IO(new Bundle {
    val push = Input(Bool())
    val data = Input(UInt(w.W))
    val last = Input(Bool())
    val room = Output(Bool())
    val deq  = Decoupled(new StreamWord(w))
  })
  private val d        = Reg(Vec(4, new StreamWord(w)))
  private val wr       = RegInit(0.U(2.W))
  private val rd       = RegInit(0.U(2.W))
  private val count    = RegInit(0.U(3.W))
  private val nonEmpty = RegInit(false.B)
  assert(!(io.push && count === 4.U), "AnswerQueue: push into a full queue")
  when(io.push) {
    d(wr).data := io.data
    d(wr).last := io.last
    wr := wr + 1.U
  }
  private val pop = io.deq.ready && nonEmpty
  when(pop) { rd := rd + 1.U }
  private val next = count + io.push.asUInt - pop.asUInt
  // count <= 1 and count <= 2 in registers of their own, so that the room is one gate from registers
  private val le1 = RegInit(true.B)
  private val le2 = RegInit(true.B)
  count    := next
  nonEmpty := next =/= 0.U
  le1      := next <= 1.U
  le2      := next <= 2.U
  io.room      := Mux(io.push, le1, le2)
  assert(io.room === (count +& io.push.asUInt <= 2.U), "AnswerQueue: room flags out of step")
  io.deq.valid := nonEmpty
  io.deq.bits  := d(rd)
}
