package shell

import chisel3._
import chisel3.util._

/** A matrix row on its way down a core's pipeline (one per row unit and cycle). */
class RowToken(kW: Int, sW: Int = 0) extends Bundle {
  val valid = Bool()
  /** row of the first pass (the parameter pass: h = Phi w for FGM, G~ (w, 1) for ADMM) */
  val pass0 = Bool()
  /** row of the first iteration */
  val first = Bool()
  /** row index within the unit */
  val k = UInt(kW.W)
  /** the problem the row belongs to (interleaving cores, shell.TurnSequencer; zero width otherwise) */
  val slot = UInt(sW.W)
}

object RowToken {
  /** One write enable per row slot k < K, `cond && tok.k === k` a cycle ahead and registered: the enables of the
    * row registers come straight from flip-flops, not through a decoder on the token path. Pass the token (and
    * cond) of the stage before the one the writes belong to. */
  def enables(tok: RowToken, cond: Bool, K: Int): Vec[Bool] = RegNext(decode(tok, cond, K), VecInit(Seq.fill(K)(false.B)))
  /** `cond && tok.k === k` for k < K, not registered */
  def decode(tok: RowToken, cond: Bool, K: Int): Vec[Bool] = VecInit((0 until K).map(k => cond && tok.k === k.U))
}

/** Sequencer of a solve: idle -> run (the first pass, then Imax iterations) -> out (the result frame).
  *
  * The first pass issues rows 0..K-1 and lasts `firstLen` cycles; each iteration issues rows 0..K-1 and lasts `L`
  * cycles (row k at count k). `tokN` is the token of the next cycle, a register, so that the row memories are
  * addressed a cycle ahead from registers; `tokNN` is the token after it, also from registers (but for `valid`),
  * for memories that register their address in copies beside their blocks (mem.InitRam's raddrAhead). For that the
  * start is decided two cycles ahead: a frame's last word taken at t starts the solve at t + 2. `copyNow` marks the
  * cycle after an iteration's last write in which the core moves its next operand vector into place: after every
  * iteration but the last, and after the first pass when `copyAfterFirst`.
  *
  * Early exit: `stop`, read in the cycle the generator holds an iteration's last position (two cycles before the
  * cycle that ends the iteration), makes that iteration the solve's last; it must come from registers and describe
  * the iteration being ended (a core without the test ties it low). `iters` counts the iterations issued.
  */
class PassSequencer(K: Int, firstLen: Int, L: Int, copyAfterFirst: Boolean, maxOut: Int) extends Module {
  require(K >= 1 && firstLen >= K && L >= K, s"PassSequencer: need K <= firstLen and K <= L: K=$K, firstLen=$firstLen, L=$L")
  require(firstLen >= 2 || K >= 2, s"PassSequencer: the first pass needs two positions: K=$K, firstLen=$firstLen")
  val kW = math.max(1, log2Ceil(K))
  val io = IO(new Bundle {
    /** a complete input frame waits */
    val frameReady = Input(Bool())
    /** the input frame's last word is taken this cycle (frameReady rises in the next, unless it is high) */
    val frameFills = Input(Bool())
    /** iterations of the solve that starts (latched) */
    val imax = Input(UInt(16.W))
    /** imax === 1, from a register */
    val imaxOne = Input(Bool())
    /** words of the result frame minus one (latched at the start) */
    val outLast = Input(UInt(log2Ceil(maxOut + 1).W))
    /** the output queue takes a word in the next cycle (shell.AnswerQueue's room, from registers) */
    val outRoom = Input(Bool())
    /** the iteration the generator ends this cycle passed the core's exit test: it is the solve's last */
    val stop = Input(Bool())

    /** the solve starts this cycle (the core takes the frame) */
    val start    = Output(Bool())
    val tokN     = Output(new RowToken(kW))
    val tokNN    = Output(new RowToken(kW))
    val running  = Output(Bool())
    val copyNow  = Output(Bool())
    /** copyNow of the next cycle */
    val copyNext = Output(Bool())
    /** the result frame's words are being sent: from the answer register into the output queue */
    val outValid = Output(Bool())
    val outIndex = Output(UInt(log2Ceil(maxOut + 1).W))
    /** a word of the answer moves into the output queue this cycle (a register) */
    val outShift = Output(Bool())
    /** outShift of the next cycle */
    val outShiftAhead = Output(Bool())
    /** the cycle before the answer's first word */
    val outLoad  = Output(Bool())
    /** outLoad of the next cycle */
    val outLoadAhead = Output(Bool())
    /** the word moving into the queue is the answer's last */
    val outIsLast = Output(Bool())
    /** the last word of the result moves into the output queue: the solve is complete, after `runCycles` cycles */
    val done      = Output(Bool())
    val runCycles = Output(UInt(32.W))
    /** iterations issued since the start: the iterations of the solve while `done` */
    val iters = Output(UInt(16.W))
  })

  val sIdle :: sRun :: sOut :: Nil = Enum(3)
  val state  = RegInit(sIdle)
  val outCnt = RegInit(0.U(log2Ceil(maxOut + 1).W))
  val outCnt1 = RegInit(1.U(log2Ceil(maxOut + 1).W)) // outCnt + 1
  val outEnd = RegInit(0.U(log2Ceil(maxOut + 1).W))
  val outAtEnd = RegInit(false.B) // outCnt === outEnd, kept in a register: the output handshake is a gate from it
  val busyCyc = RegInit(0.U(32.W))
  // The start (idle and a whole frame waiting) is decided two cycles ahead, in `startA` and then `start`: the token
  // generator runs a cycle ahead of the tokens (from startA), and the frame buffer and the core's loads take the
  // start straight from a flip-flop. startA rises in the cycle after the frame's last word or the answer's last
  // word (the earlier of the two that finds the other done): idle next cycle is idle without a frame now, or the
  // answer's last word moving into the output queue; a frame waits next cycle when its last word comes now, or one
  // waits and the answer's last word moves out.
  // The answer's words move into the output queue (shell.AnswerQueue) at `shift`, a register decided a cycle ahead
  // from the state and the queue's room, so that the stream's tready reaches only the queue, not the answer
  // register's enables and the sequencer.
  val shift = RegInit(false.B)
  val outLastFire = state === sOut && shift && outAtEnd
  val startA = RegNext(state === sIdle && !io.frameReady && io.frameFills ||
    outLastFire && (io.frameReady || io.frameFills), false.B)
  val start = RegNext(startA, false.B)
  assert(start === (state === sIdle && io.frameReady && !startA), "PassSequencer: start registers out of step")

  // The token generator: registers describing the token of the next cycle (its position in the solve), advanced
  // by one position per cycle from startA, each next value a gate or two from registers (the comparisons it needs
  // are flags kept a cycle ahead). In idle it holds the first pass's row 0, not valid (the cycle of `startA` makes
  // it valid); after a solve's last position it returns there.
  val gV      = RegInit(false.B)           // the position is a row
  val gP0     = RegInit(true.B)            // of the first pass
  val gF      = RegInit(false.B)           // of the first iteration
  val gK      = RegInit(0.U(kW.W))
  val gKLast  = RegInit((K == 1).B)        // gK === K - 1
  val gGap    = RegInit(false.B)           // past the pass's rows
  val gapW    = log2Ceil(math.max(firstLen, L) + 1)
  val gGapCnt = RegInit(0.U(gapW.W))       // gap positions after this one
  val gGapEnd = RegInit(false.B)           // gGapCnt === 0
  val gRun    = RegInit(false.B)           // a solve's positions are being issued
  val gLast   = RegInit(false.B)           // the pass is the solve's last
  val gRem    = RegInit(0.U(16.W))         // iterations after this pass
  val gRemOne = RegInit(false.B)           // gRem === 1
  val gIt     = RegInit(0.U(16.W))         // iterations issued
  // A start loads the second position of the first pass (constants, and the iteration count): the input frame's
  // handshake selects at the registers and does not enter the advance logic.
  val rowEnd  = gV && gKLast
  val gapLen0 = firstLen - K
  val gapLen  = L - K
  val passEnd = rowEnd && Mux(gP0, (gapLen0 == 0).B, (gapLen == 0).B) || gGap && gGapEnd
  /** the pass ending is the solve's last: the IMAX-th iteration, or an iteration that passed the exit test */
  val endNow  = gLast || !gP0 && io.stop
  when(startA) {
    gIt     := 0.U
    gRun    := true.B
    gP0     := true.B
    gF      := false.B
    gLast   := false.B
    gRem    := io.imax
    gRemOne := io.imaxOne
    if (K > 1) { // row 1
      gV     := true.B
    } else {     // the first pass's gap (firstLen >= 2)
      gV      := false.B
      gGap    := true.B
      gGapCnt := (firstLen - 2).U
      gGapEnd := (firstLen == 2).B
    }
  }.elsewhen(gRun) {
    when(passEnd) {
      gGap := false.B
      when(!gP0) { gIt := gIt + 1.U }
      when(endNow) { // the solve's positions end: back to idle's token
        gRun := false.B
        gV   := false.B
        gP0  := true.B
        gF   := false.B
      }.otherwise { // the next iteration's row 0
        gV      := true.B
        gF      := gP0
        gP0     := false.B
        gLast   := gRemOne
        gRem    := gRem - 1.U
        gRemOne := gRem === 2.U
      }
    }.elsewhen(rowEnd) { // the pass's gap begins
      gV      := false.B
      gGap    := true.B
      gGapCnt := Mux(gP0, (math.max(gapLen0, 1) - 1).U, (math.max(gapLen, 1) - 1).U)
      gGapEnd := Mux(gP0, (gapLen0 == 1).B, (gapLen == 1).B)
    }.elsewhen(gGap) {
      gGapCnt := gGapCnt - 1.U
      gGapEnd := gGapCnt === 1.U
    }
  }
  // the row index and its last-row flag, each a selection of three: a start loads row 1, a pass's end row 0, a row
  // before the last the next (in the gap both are held or don't matter: the gap's end reloads them)
  gK     := Mux(startA, (if (K > 1) 1 else 0).U, Mux(passEnd, 0.U, Mux(gV && !gKLast, gK + 1.U, gK)))
  gKLast := Mux(startA, (K <= 2).B, Mux(passEnd, (K == 1).B, (if (K >= 2) gK === (K - 2).U else true.B)))
  val tokR = Wire(new RowToken(kW))
  tokR.valid := gV
  tokR.pass0 := gP0
  tokR.first := gF
  tokR.k     := gK
  tokR.slot  := 0.U
  val tokNN = WireDefault(tokR)
  when(startA) { tokNN.valid := true.B }
  io.tokNN := tokNN
  val idleTok = WireDefault(tokR)  // what the generator holds in idle and after reset
  idleTok.valid := false.B
  idleTok.pass0 := true.B
  idleTok.first := false.B
  idleTok.k     := 0.U
  io.tokN := RegNext(tokNN, idleTok)
  io.start := start
  io.running := state === sRun
  // The passes' ends come from the generator: it holds a pass's last position two cycles before the cycle that
  // ends the pass (the state's cycles count from the one after the start). The operand copy follows that cycle,
  // after every iteration but the last, and after the first pass when `copyAfterFirst`.
  val lastEndA = RegNext(gRun && passEnd && endNow, false.B) // lastEnd a cycle ahead
  val lastEnd  = RegNext(lastEndA, false.B)
  io.copyNext := ShiftRegister(gRun && passEnd && Mux(gP0, copyAfterFirst.B, !endNow), 2, false.B, true.B)
  io.copyNow  := RegNext(io.copyNext, false.B)

  switch(state) {
    is(sIdle) {
      when(start) {
        state   := sRun
        outEnd  := io.outLast
        busyCyc := 0.U
      }
    }
    is(sRun) {
      busyCyc := busyCyc + 1.U
      when(lastEnd) {
        state    := sOut
        outCnt   := 0.U
        outCnt1  := 1.U
        outAtEnd := outEnd === 0.U
      }
    }
    is(sOut) {
      when(shift) {
        outCnt   := outCnt1
        outCnt1  := outCnt1 + 1.U
        outAtEnd := outCnt1 === outEnd
        when(outAtEnd) { state := sIdle }
      }
    }
  }
  // state === sOut in a register of its own: the answer's handshake is a gate from it and the port
  val outV = RegInit(false.B)
  when(state === sRun && lastEnd) { outV := true.B }
  when(outLastFire) { outV := false.B }
  assert(outV === (state === sOut), "PassSequencer: answer valid out of step")
  // lastEnd comes in the run only, and outV is the state sOut (both asserted), so the next shift is a gate or two
  // from registers
  assert(!lastEnd || state === sRun, "PassSequencer: a last pass's end outside the run")
  val shiftA = (lastEnd || outV && !(shift && outAtEnd)) && io.outRoom
  shift := shiftA
  io.outShift      := shift
  io.outShiftAhead := shiftA
  io.outValid  := outV
  io.outIndex  := outCnt
  io.outLoad   := lastEnd
  io.outLoadAhead := lastEndA
  io.outIsLast := outAtEnd
  io.done      := outLastFire
  io.runCycles := busyCyc
  io.iters     := gIt
}
