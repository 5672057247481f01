package shell

import chisel3._
import chisel3.util._

/** What a core's datapath takes from its sequencer (PassSequencer for one problem, TurnSequencer for several):
  * the token, the frame taken, the operand copy (one problem; copyNext is it a cycle ahead), the answer's word and
  * the solve's end, and per problem whether the solve taken starts warm (several problems). `tokNN`, the token
  * after tokN from registers, for one problem (PassSequencer): row memories can register their address beside
  * their blocks from it; `outLoad`, for one problem: the cycle before the answer's first word (and the cycle
  * before that, from which copies of it are registered). */
case class SeqControl(tokN: RowToken, tokNN: Option[RowToken], take: Bool, copyNow: Bool, copyNext: Bool,
    running: Bool, outValid: Bool, outSlot: UInt, outIndex: UInt, outIsLast: Bool, done: Bool, runCycles: UInt,
    warmOf: Vec[Bool], outLoad: Option[(Bool, Bool)] = None) {
  val problems: Int = warmOf.length

  /** The answer's word on the stream: `word(slot, index)`, the word `index` of problem `slot`. One problem: from a
    * shift register of the `count` words instead, loaded in the cycle before the answer with `next(i)`, the value
    * word i has in the next cycle (the last rows' writes of that cycle included), and shifted by the stream's
    * handshake `fire`; so no wide selection by index runs into the port. With `keep` (an FPGA target) each word
    * takes the load from a kept copy of its own (mem.KeepReg), not one register driving every word's bits. */
  def answerWord(word: (UInt, UInt) => UInt, next: Int => UInt, count: Int, fire: Bool, keep: Boolean): UInt =
    outLoad match {
      case Some((load, ahead)) =>
        val ans   = Reg(Vec(count, UInt(next(0).getWidth.W))).suggestName("answer")
        val loads = if (keep) mem.KeepReg.copies(ahead, count, keep = true) else Seq.fill(count)(load)
        if (keep) assert(loads.head === load, "SeqControl: answer load copies out of step")
        for (i <- 0 until count)
          when(loads(i)) { ans(i) := next(i) }.elsewhen(fire) { ans(i) := (if (i + 1 < count) ans(i + 1) else ans(i)) }
        ans(0)
      case None => word(outSlot, outIndex)
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
    * answer leaves, the core clears it). */
  def apply(K: Int, firstLen: Int, L: Int, copyAfterFirst: Boolean, maxOut: Int, Kp: Int, frameIn: FrameIn,
      regs: SolverRegs, outLast: UInt, outFire: Bool, warmOk: Vec[Bool]): SeqControl = {
    val ctl = if (Kp == 1) {
      val seq = Module(new PassSequencer(K, firstLen, L, copyAfterFirst, maxOut))
      seq.io.frameReady := frameIn.io.full
      seq.io.frameFills := frameIn.io.fills
      seq.io.imax       := regs.imaxReg
      seq.io.imaxOne    := regs.imaxOne
      seq.io.outLast    := outLast
      seq.io.outFire    := outFire
      SeqControl(seq.io.tokN, Some(seq.io.tokNN), seq.io.start, seq.io.copyNow, seq.io.copyNext, seq.io.running,
        seq.io.outValid, 0.U, seq.io.outIndex, seq.io.outIsLast, seq.io.done, seq.io.runCycles, VecInit(Seq.fill(1)(false.B)),
        Some((seq.io.outLoad, seq.io.outLoadAhead)))
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
        seq.io.outIndex, seq.io.outIsLast, seq.io.done, seq.io.runCycles, seq.io.warmOf)
    }
    frameIn.io.take := ctl.take
    when(ctl.done) { regs.solveDone(ctl.runCycles) }
    ctl
  }
}
