package shell

import chisel3._
import chisel3.util._

/** What a core's datapath takes from its sequencer (PassSequencer for one problem, TurnSequencer for several):
  * the token, the frame taken, the operand copy (one problem; copyNext is it a cycle ahead), the answer's word and
  * the solve's end, and per problem whether the solve taken starts warm (several problems). `tokNN`, the token
  * after tokN from registers, for one problem (PassSequencer): row memories can register their address beside
  * their blocks from it; `pass`, for one problem: the sequencer, whose answer leaves through `answer`'s register
  * and output queue. `iters`: the iterations of the solve while `done` (one problem; several: IMAX). */
case class SeqControl(tokN: RowToken, tokNN: Option[RowToken], take: Bool, copyNow: Bool, copyNext: Bool,
    running: Bool, outValid: Bool, outSlot: UInt, outIndex: UInt, outIsLast: Bool, done: Bool, runCycles: UInt,
    warmOf: Vec[Bool], iters: UInt, pass: Option[PassSequencer]) {
  val problems: Int = warmOf.length

  /** the cycle before the answer's first word moves out (one problem) */
  def outLoad: Bool = pass.get.io.outLoad

  /** an answer is on its way out: words being sent or waiting in the output queue (set by `answer`) */
  val outPending: Bool = Wire(Bool())

  /** Drives the answer's stream `port`: `word(slot, index)` is the word `index` of problem `slot`. One problem:
    * the `count` words are loaded into a shift register in the cycle before the answer, with `next(i)`, the value
    * word i has in the next cycle (the last rows' writes of that cycle included), and move into a four-word output
    * queue (AnswerQueue) at the sequencer's shift; so no wide selection by index runs into the port, and the
    * port's tready meets only the queue. With `keep` (an FPGA target) each word takes its load and shift from kept
    * copies of its own (mem.KeepReg), not one register driving every word's bits. Several problems: the word by
    * index, on the sequencer's handshake. */
  def answer(port: bus.AxiStreamIO, word: (UInt, UInt) => UInt, next: Int => UInt, count: Int, keep: Boolean): Unit =
    pass match {
      case Some(seq) =>
        val ans    = Reg(Vec(count, UInt(next(0).getWidth.W))).suggestName("answer")
        val loads  = if (keep) mem.KeepReg.copies(seq.io.outLoadAhead, count, keep = true) else Seq.fill(count)(seq.io.outLoad)
        val shifts = if (keep) mem.KeepReg.copies(seq.io.outShiftAhead, count, keep = true) else Seq.fill(count)(seq.io.outShift)
        if (keep) assert(loads.head === seq.io.outLoad && shifts.head === seq.io.outShift,
          "SeqControl: answer load or shift copies out of step")
        for (i <- 0 until count)
          when(loads(i)) { ans(i) := next(i) }.elsewhen(shifts(i)) { ans(i) := (if (i + 1 < count) ans(i + 1) else ans(i)) }
        val q = Module(new AnswerQueue(port.dataW)).suggestName("ansQ")
        q.io.push        := seq.io.outShift
        q.io.data        := ans(0)
        q.io.last        := seq.io.outIsLast
        seq.io.outRoom   := q.io.room
        port.tvalid      := q.io.deq.valid
        port.tdata       := q.io.deq.bits.data
        port.tlast       := q.io.deq.bits.last
        q.io.deq.ready   := port.tready
        port.tuser.foreach(_ := 0.U)
        outPending       := outValid || q.io.deq.valid
      case None =>
        port.tvalid := outValid
        port.tdata  := word(outSlot, outIndex)
        port.tlast  := outIsLast
        port.tuser.foreach(_ := outSlot)
        outPending  := outValid
    }

  /** the token is problem j's (always, for one problem) */
  def mine(t: RowToken, j: Int): Bool = if (problems == 1) true.B else t.slot === j.U

  /** problem `slot`'s element of `xs` (the element itself for one problem); an AND-OR multiplexer on the decoded
    * slot, not an index into a vector (firtool turns some of those into multiplexers of whole arrays, which the
    * Verilog emission refuses) */
  def ofSlot[T <: Data](xs: Seq[T], slot: UInt): T =
    if (problems == 1) xs.head else Mux1H(UIntToOH(slot, problems), xs)
}

object SeqControl {
  /** The sequencer of a core with K rows per unit and pass, `firstLen` cycles of its first pass and L of an
    * iteration (one problem), answers of up to maxOut words, `Kp` problems: wired to the input frame, the
    * registers and the answer's handshake. `warmOk(j)`: problem j's warm start is valid (Kp > 1; set here when its
    * answer leaves, the core clears it). `stop`: the early exit of one problem (PassSequencer's), None without. */
  def apply(K: Int, firstLen: Int, L: Int, copyAfterFirst: Boolean, maxOut: Int, Kp: Int, frameIn: FrameIn,
      regs: SolverRegs, outLast: UInt, outFire: Bool, warmOk: Vec[Bool], stop: Option[Bool] = None): SeqControl = {
    require(Kp == 1 || stop.isEmpty, s"SeqControl: the early exit needs one problem, got $Kp")
    // outFire: the stream's handshake, which drives a several-problem sequencer (one problem: the output queue)
    val ctl = if (Kp == 1) {
      val seq = Module(new PassSequencer(K, firstLen, L, copyAfterFirst, maxOut))
      seq.io.frameReady := frameIn.io.full
      seq.io.frameFills := frameIn.io.fills
      seq.io.imax       := regs.imaxReg
      seq.io.imaxOne    := regs.imaxOne
      seq.io.outLast    := outLast
      seq.io.stop       := stop.getOrElse(false.B)
      SeqControl(seq.io.tokN, Some(seq.io.tokNN), seq.io.start, seq.io.copyNow, seq.io.copyNext, seq.io.running,
        seq.io.outValid, 0.U, seq.io.outIndex, seq.io.outIsLast, seq.io.done, seq.io.runCycles, VecInit(Seq.fill(1)(false.B)),
        seq.io.iters, Some(seq))
    } else {
      val seq = Module(new TurnSequencer(K, Kp, L, maxOut))
      seq.io.frameReady := frameIn.io.full
      seq.io.frameSlot  := frameIn.io.id
      seq.io.imax       := regs.imaxReg
      seq.io.outLast    := outLast
      seq.io.warm       := VecInit(warmOk.map(_ && regs.ctrlWarm))
      seq.io.outFire    := outFire
      when(seq.io.done) { warmOk(seq.io.outSlot) := true.B }
      SeqControl(seq.io.tokN, None, seq.io.take, false.B, false.B, seq.io.running, seq.io.outValid, seq.io.outSlot,
        seq.io.outIndex, seq.io.outIsLast, seq.io.done, seq.io.runCycles, seq.io.warmOf, regs.imaxReg, None)
    }
    frameIn.io.take := ctl.take
    when(ctl.done) { regs.solveDone(ctl.runCycles) }
    ctl
  }
}
