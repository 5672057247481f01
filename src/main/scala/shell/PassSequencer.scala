package shell

import chisel3._
import chisel3.util._

/** A matrix row on its way down a core's pipeline (one per row unit and cycle). */
class RowToken(kW: Int) extends Bundle {
  val valid = Bool()
  /** row of the first pass (the parameter pass: h = Phi w for FGM, G~ (w, 1) for ADMM) */
  val pass0 = Bool()
  /** row of the first iteration */
  val first = Bool()
  /** row index within the unit */
  val k = UInt(kW.W)
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
  val iter   = RegInit(0.U(16.W))
  val imaxL  = RegInit(1.U(16.W))
  val outCnt = RegInit(0.U(log2Ceil(maxOut + 1).W))
  val outEnd = RegInit(0.U(log2Ceil(maxOut + 1).W))
  val busyCyc = RegInit(0.U(32.W))

  // Next values of the state and the counters. The comparisons the tokens need are made on them and registered,
  // and so is the next token itself: the row memories are addressed straight from registers.
  val stateNext = WireDefault(state)
  val pass0Next = WireDefault(pass0)
  val cntNext   = WireDefault(cnt)
  val iterNext  = WireDefault(iter)
  val imaxNext  = WireDefault(imaxL)
  state := stateNext
  pass0 := pass0Next
  cnt   := cntNext
  iter  := iterNext
  imaxL := imaxNext
  val cntIncN   = cntNext +& 1.U
  val wrap0N    = cntNext === (firstLen - 1).U
  val wrapN     = cntNext === (L - 1).U
  val issueN    = cntIncN < K.U
  val lastIterN = iterNext === imaxNext - 1.U
  val iter0N    = iterNext === 0.U
  val wrap0    = RegNext(wrap0N, (firstLen == 1).B)
  val wrap     = RegNext(wrapN, (L == 1).B)
  val lastIter = RegNext(lastIterN, true.B)

  val start = state === sIdle && io.frameReady

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
  tokR := nextToken(stateNext, pass0Next, wrap0N, wrapN, issueN, lastIterN, iter0N, cntIncN)
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
        cntNext := 0.U
        iterNext := 0.U
        imaxNext := io.imax
        outEnd  := io.outLast
        busyCyc := 0.U
      }
    }
    is(sRun) {
      busyCyc := busyCyc + 1.U
      when(pass0) {
        when(wrap0) {
          pass0Next := false.B
          cntNext := 0.U
        }.otherwise { cntNext := cnt + 1.U }
      }.otherwise {
        when(wrap) {
          cntNext := 0.U
          iterNext := iter + 1.U
          when(lastIter) {
            stateNext := sOut
            outCnt := 0.U
          }
        }.otherwise { cntNext := cnt + 1.U }
      }
    }
    is(sOut) {
      when(io.outFire) {
        outCnt := outCnt + 1.U
        when(outCnt === outEnd) { stateNext := sIdle }
      }
    }
  }
  io.outValid  := state === sOut
  io.outIndex  := outCnt
  io.outIsLast := outCnt === outEnd
  io.done      := state === sOut && io.outFire && outCnt === outEnd
  io.runCycles := busyCyc
}
