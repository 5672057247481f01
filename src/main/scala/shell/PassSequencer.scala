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
  def enables(tok: RowToken, cond: Bool, K: Int): Vec[Bool] =
    RegNext(VecInit((0 until K).map(k => cond && tok.k === k.U)), VecInit(Seq.fill(K)(false.B)))
}

/** Sequencer of a solve: idle -> run (the first pass, then Imax iterations) -> out (the result frame).
  *
  * The first pass issues rows 0..K-1 and lasts `firstLen` cycles; each iteration issues rows 0..K-1 and lasts `L`
  * cycles (row k at count k). `tokN` is the token of the next cycle, a register (but for `valid` in the cycle of
  * `start`), so that the row memories are addressed a cycle ahead from registers. `copyNow` marks the cycle after an iteration's last write in which the core
  * moves its next operand vector into place: after every iteration but the last, and after the first pass when
  * `copyAfterFirst`.
  */
class PassSequencer(K: Int, firstLen: Int, L: Int, copyAfterFirst: Boolean, maxOut: Int) extends Module {
  require(K >= 1 && firstLen >= K && L >= K, s"PassSequencer: need K <= firstLen and K <= L: K=$K, firstLen=$firstLen, L=$L")
  val kW = math.max(1, log2Ceil(K))
  val io = IO(new Bundle {
    /** a complete input frame waits */
    val frameReady = Input(Bool())
    /** iterations of the solve that starts (latched) */
    val imax = Input(UInt(16.W))
    /** words of the result frame minus one (latched at the start) */
    val outLast = Input(UInt(log2Ceil(maxOut + 1).W))
    /** the result frame's word handshake */
    val outFire = Input(Bool())

    /** the solve starts this cycle (the core takes the frame) */
    val start    = Output(Bool())
    val tokN     = Output(new RowToken(kW))
    val running  = Output(Bool())
    val copyNow  = Output(Bool())
    val outValid = Output(Bool())
    val outIndex = Output(UInt(log2Ceil(maxOut + 1).W))
    val outIsLast = Output(Bool())
    /** the last word of the result left: the solve is complete, after `runCycles` cycles */
    val done      = Output(Bool())
    val runCycles = Output(UInt(32.W))
  })

  val sIdle :: sRun :: sOut :: Nil = Enum(3)
  val state  = RegInit(sIdle)
  val pass0  = RegInit(false.B)
  val cnt    = RegInit(0.U(log2Ceil(math.max(firstLen, L) + 1).W))
  // iterations after the current one (Imax - 1 - iteration), and whether the current one is the first
  val left   = RegInit(0.U(16.W))
  val iter0  = RegInit(true.B)
  val outCnt = RegInit(0.U(log2Ceil(maxOut + 1).W))
  val outEnd = RegInit(0.U(log2Ceil(maxOut + 1).W))
  val outAtEnd = RegInit(false.B) // outCnt === outEnd, kept in a register: the output handshake is a gate from it
  val busyCyc = RegInit(0.U(32.W))
  val wrap0    = RegInit((firstLen == 1).B) // cnt === firstLen - 1
  val wrap     = RegInit((L == 1).B)        // cnt === L - 1
  val lastIter = RegInit(true.B)            // left === 0

  // Next values of the state and the counters. The comparisons the tokens need are made for the next cycle and
  // registered, and so is the next token itself: the row memories are addressed straight from registers. They
  // are taken per case of the counters' update (cleared, incremented, held), each a comparison of a register with
  // a constant, so that no adder or subtracter lies between the state and the token registers.
  val stateNext = WireDefault(state)
  val pass0Next = WireDefault(pass0)
  val leftNext  = WireDefault(left)
  state := stateNext
  pass0 := pass0Next
  left  := leftNext

  val start  = state === sIdle && io.frameReady
  val run    = state === sRun
  val wrapIt = run && Mux(pass0, wrap0, wrap)   // the pass ends: the counter restarts
  val cntClr = start || wrapIt
  val cntInc = run && !wrapIt
  val cntNext = Mux(cntClr, 0.U, Mux(cntInc, cnt + 1.U, cnt))
  cnt := cntNext
  // the next counter's comparisons and successor, the counter cleared when `clr`
  def eqAfter(clr: Bool, c: Int): Bool = // cntNext === c
    Mux(clr, (c == 0).B, Mux(cntInc, if (c >= 1) cnt === (c - 1).U else false.B, cnt === c.U))
  def incAfter(clr: Bool): UInt = Mux(clr, 1.U, Mux(cntInc, cnt +& 2.U, cnt +& 1.U)) // cntNext + 1
  def issueAfter(clr: Bool): Bool = // cntNext + 1 < K
    Mux(clr, (K > 1).B, Mux(cntInc, if (K >= 3) cnt < (K - 2).U else false.B, cnt < (K - 1).U))
  val wrap0N  = eqAfter(cntClr, firstLen - 1)
  val wrapN   = eqAfter(cntClr, L - 1)
  val cntIncN = incAfter(cntClr)
  val issueN  = issueAfter(cntClr)
  // an iteration ends (not the first pass): one iteration fewer left
  val iterEnd = run && !pass0 && wrap
  val lastIterN = Mux(start, io.imax === 1.U, Mux(iterEnd, left === 1.U, lastIter))
  val iter0N    = Mux(start, true.B, Mux(iterEnd, false.B, iter0))
  wrap0    := wrap0N
  wrap     := wrapN
  lastIter := lastIterN
  iter0    := iter0N


  /** The token issued in the cycle after one in state `st` (pass0 `p0`, comparisons of its counters `w0` ... `i0`).
    * Idle: the first row of the first pass, not valid (the cycle of `start` makes it valid). */
  def nextToken(st: UInt, p0: Bool, w0: Bool, w: Bool, is: Bool, li: Bool, i0: Bool, inc: UInt): RowToken = {
    val t = Wire(new RowToken(kW))
    t := 0.U.asTypeOf(t)
    when(st === sIdle) {
      t.pass0 := true.B
    }.elsewhen(st === sRun && p0) {
      t.valid := w0 || is
      t.pass0 := !w0
      t.first := w0
      t.k     := Mux(w0, 0.U, inc(kW - 1, 0))
    }.elsewhen(st === sRun) {
      t.valid := Mux(w, !li, is)
      t.first := i0 && !w
      t.k     := Mux(w, 0.U, inc(kW - 1, 0))
    }
    t
  }
  val idleTok = nextToken(sIdle, false.B, false.B, false.B, false.B, false.B, false.B, 0.U)
  val tokR = RegInit(idleTok)
  // The token after a start is a constant (the first pass's row 0, counters cleared); every other one is taken
  // from the next state as if no start happened, so the start (the input frame's handshake) only selects between
  // the two at the token register.
  val startTok = nextToken(sRun, true.B, (firstLen == 1).B, (L == 1).B, (K > 1).B, false.B, true.B, 1.U)
  val idle     = state === sIdle
  val runTok = nextToken(Mux(idle, sIdle, stateNext), Mux(idle, pass0, pass0Next), eqAfter(wrapIt, firstLen - 1),
    eqAfter(wrapIt, L - 1), issueAfter(wrapIt), Mux(iterEnd, left === 1.U, lastIter), Mux(iterEnd, false.B, iter0),
    incAfter(wrapIt))
  tokR := Mux(start, startTok, runTok)
  val tokN = WireDefault(tokR)
  when(start) { tokN.valid := true.B }
  io.tokN := tokN
  io.start := start
  io.running := state === sRun
  val copyCond = state === sRun && Mux(pass0, wrap0 && copyAfterFirst.B, wrap && !lastIter)
  io.copyNow := RegNext(copyCond, false.B)

  switch(state) {
    is(sIdle) {
      when(io.frameReady) {
        stateNext := sRun
        pass0Next := true.B
        leftNext := io.imax - 1.U
        outEnd  := io.outLast
        busyCyc := 0.U
      }
    }
    is(sRun) {
      busyCyc := busyCyc + 1.U
      when(pass0) {
        when(wrap0) { pass0Next := false.B }
      }.elsewhen(wrap) {
        leftNext := left - 1.U
        when(lastIter) {
          stateNext := sOut
          outCnt := 0.U
          outAtEnd := outEnd === 0.U
        }
      }
    }
    is(sOut) {
      when(io.outFire) {
        outCnt := outCnt + 1.U
        outAtEnd := outCnt + 1.U === outEnd
        when(outAtEnd) { stateNext := sIdle }
      }
    }
  }
  io.outValid  := state === sOut
  io.outIndex  := outCnt
  io.outIsLast := outAtEnd
  io.done      := state === sOut && io.outFire && outAtEnd
  io.runCycles := busyCyc
}
