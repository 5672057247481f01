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

/** Sequencer of a solve: idle -> run (the first pass, then Imax iterations) -> out (the result frame).
  *
  * The first pass issues rows 0..K-1 and lasts `firstLen` cycles; each iteration issues rows 0..K-1 and lasts `L`
  * cycles (row k at count k). `tokN` is the token of the next cycle, from the next state, so that the row memories
  * can be addressed a cycle ahead. `copyNow` marks the cycle after an iteration's last write in which the core
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

  // Next values of the counters; the comparisons the tokens need are made on them and registered, so the next
  // token (which addresses the row memories) comes from registers through a few multiplexers.
  val cntNext  = WireDefault(cnt)
  val iterNext = WireDefault(iter)
  val imaxNext = WireDefault(imaxL)
  cnt   := cntNext
  iter  := iterNext
  imaxL := imaxNext
  val cntInc   = RegNext(cntNext +& 1.U, 1.U)
  val wrap0    = RegNext(cntNext === (firstLen - 1).U, (firstLen == 1).B)
  val wrap     = RegNext(cntNext === (L - 1).U, (L == 1).B)
  val issue    = RegNext(cntNext +& 1.U < K.U, (K > 1).B)
  val lastIter = RegNext(iterNext === imaxNext - 1.U, true.B)
  val iter0    = RegNext(iterNext === 0.U, true.B)

  val start = state === sIdle && io.frameReady

  val tokN = Wire(new RowToken(kW))
  tokN := 0.U.asTypeOf(tokN)
  when(start) {
    tokN.valid := true.B
    tokN.pass0 := true.B
  }.elsewhen(state === sRun && pass0) {
    tokN.valid := wrap0 || issue
    tokN.pass0 := !wrap0
    tokN.first := wrap0
    tokN.k     := Mux(wrap0, 0.U, cntInc(kW - 1, 0))
  }.elsewhen(state === sRun) {
    tokN.valid := Mux(wrap, !lastIter, issue)
    tokN.first := iter0 && !wrap
    tokN.k     := Mux(wrap, 0.U, cntInc(kW - 1, 0))
  }
  io.tokN := tokN
  io.start := start
  io.running := state === sRun
  val copyCond = state === sRun && Mux(pass0, wrap0 && copyAfterFirst.B, wrap && !lastIter)
  io.copyNow := RegNext(copyCond, false.B)

  switch(state) {
    is(sIdle) {
      when(io.frameReady) {
        state   := sRun
        pass0   := true.B
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
          pass0 := false.B
          cntNext := 0.U
        }.otherwise { cntNext := cnt + 1.U }
      }.otherwise {
        when(wrap) {
          cntNext := 0.U
          iterNext := iter + 1.U
          when(lastIter) {
            state  := sOut
            outCnt := 0.U
          }
        }.otherwise { cntNext := cnt + 1.U }
      }
    }
    is(sOut) {
      when(io.outFire) {
        outCnt := outCnt + 1.U
        when(outCnt === outEnd) { state := sIdle }
      }
    }
  }
  io.outValid  := state === sOut
  io.outIndex  := outCnt
  io.outIsLast := outCnt === outEnd
  io.done      := state === sOut && io.outFire && outCnt === outEnd
  io.runCycles := busyCyc
}
