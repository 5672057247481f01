package shell

import chisel3._
import chisel3.util._

/** Sequencer of a core that interleaves `Kp` independent problems on its row units.
  *
  * Time runs in rounds of R = max(L, Kp K) cycles from reset. Problem slot j owns a turn of K cycles at round cycle
  * j K, in which the row units issue rows 0..K-1 of its next pass; round cycles from Kp K on (when L > Kp K) issue
  * nothing. A slot's passes are thus R >= L cycles apart: its pipeline has drained, and its next operand vector is
  * complete, when its next turn begins, while the other slots' rows fill the drain cycles.
  *
  * A slot is free, loaded (its input frame taken), running, or waiting for its answer to be sent. At the start of
  * its turn a loaded slot runs the first pass (the parameter pass) and a running one an iteration; a turn of a free
  * or waiting slot issues nothing. The last iteration's results are complete L cycles after its turn began: the
  * slot's id then enters the answer queue, and the answer (words 0..outLast of the slot) streams from the cycle
  * after the queue hands it out, after the answer before it. A slot is free again after its answer's last word.
  *
  * A complete input frame for a free slot is taken at once (`take`), so a frame for a busy slot waits in the frame
  * buffer, behind which later frames wait: one answer per frame, each tagged with its problem id.
  *
  * `tokN` is the token of the next cycle, a register, as in PassSequencer; `slot` says whose row it is.
  */
class TurnSequencer(K: Int, Kp: Int, L: Int, maxOut: Int) extends Module {
  require(Kp >= 2, s"TurnSequencer: interleaving needs at least 2 problems, got $Kp")
  require(K >= 1 && L >= K, s"TurnSequencer: need 1 <= K <= L: K=$K, L=$L")
  val R   = math.max(L, Kp * K)
  val pad = R - Kp * K
  val kW  = math.max(1, log2Ceil(K))
  val sW  = log2Ceil(Kp)
  val oW  = log2Ceil(maxOut + 1)
  val io = IO(new Bundle {
    /** a complete input frame waits, for problem `frameSlot` */
    val frameReady = Input(Bool())
    val frameSlot  = Input(UInt(sW.W))
    /** latched per problem when its frame is taken: iterations, words of the answer minus one, warm start */
    val imax    = Input(UInt(16.W))
    val outLast = Input(UInt(oW.W))
    val warm    = Input(Vec(Kp, Bool()))
    /** the answer's word handshake */
    val outFire = Input(Bool())

    /** the frame is taken this cycle (by slot frameSlot) */
    val take     = Output(Bool())
    val tokN     = Output(new RowToken(kW, sW))
    /** per slot: the solve taken starts warm */
    val warmOf   = Output(Vec(Kp, Bool()))
    /** some slot is not free */
    val running  = Output(Bool())
    val outValid = Output(Bool())
    val outSlot  = Output(UInt(sW.W))
    val outIndex = Output(UInt(oW.W))
    val outIsLast = Output(Bool())
    /** the answer's last word left: cycles since its first pass's turn began */
    val done      = Output(Bool())
    val runCycles = Output(UInt(32.W))
  })

  val sFree :: sLoaded :: sRun :: sWait :: Nil = Enum(4)
  val phase    = RegInit(VecInit(Seq.fill(Kp)(sFree)))
  val left     = Reg(Vec(Kp, UInt(16.W)))  // iterations still to issue
  val lastIt   = Reg(Vec(Kp, Bool()))      // left === 1
  val iter0    = Reg(Vec(Kp, Bool()))      // the next iteration is the first
  val imaxS    = Reg(Vec(Kp, UInt(16.W)))
  val outLastS = Reg(Vec(Kp, UInt(oW.W)))
  val warmS    = Reg(Vec(Kp, Bool()))
  val stamp    = Reg(Vec(Kp, UInt(32.W)))
  val now      = RegInit(0.U(32.W))
  now := now + 1.U
  io.warmOf := warmS

  // ---- take: a complete frame for a free slot
  val take = io.frameReady && phase(io.frameSlot) === sFree
  io.take := take
  when(take) {
    phase(io.frameSlot)    := sLoaded
    imaxS(io.frameSlot)    := io.imax
    outLastS(io.frameSlot) := io.outLast
    warmS(io.frameSlot)    := io.warm(io.frameSlot)
  }

  // ---- position of the token register: row k of slot s's turn, or pad cycle pc (s === Kp)
  val k    = RegInit((K - 1).U(kW.W))
  val s    = RegInit((if (pad > 0) Kp else Kp - 1).U(log2Ceil(Kp + 1).W))
  val kEnd = RegInit(true.B)
  val sEnd = RegInit((pad == 0).B)                 // s === Kp - 1 (or the pad, when there is none)
  val inPad = RegInit((pad > 0).B)
  val pc    = RegInit((math.max(pad, 1) - 1).U(log2Ceil(pad + 1).max(1).W))
  val pcEnd = RegInit(true.B)
  // the position after this one starts a turn (of slot sNext)
  val turnNext = Mux(inPad, pcEnd, kEnd && !(sEnd && (pad > 0).B))
  val sNext    = Mux(inPad || sEnd, 0.U, s + 1.U)
  when(inPad) {
    pc    := pc + 1.U
    pcEnd := (if (pad >= 2) pc === (pad - 2).U else false.B)
    when(pcEnd) { inPad := false.B; s := 0.U; k := 0.U; kEnd := (K == 1).B; sEnd := (Kp == 1).B }
  }.otherwise {
    when(kEnd) {
      k    := 0.U
      kEnd := (K == 1).B
      when(sEnd && (pad > 0).B) {
        inPad := true.B
        s     := Kp.U
        pc    := 0.U
        pcEnd := (pad == 1).B
      }.otherwise {
        s    := sNext
        sEnd := sNext === (Kp - 1).U
      }
    }.otherwise {
      k    := k + 1.U
      kEnd := (if (K >= 2) k === (K - 2).U else true.B)
    }
  }

  // ---- the turn a position starts: what the slot does, decided from its phase in the cycle before
  val live  = RegInit(false.B)
  val p0    = RegInit(false.B)
  val first = RegInit(false.B)
  val lastTurnStart = WireDefault(false.B) // the turn starting next is its slot's last iteration
  val j = sNext(math.max(sW, 1) - 1, 0)
  when(turnNext) {
    val ph = phase(j)
    live  := ph === sLoaded || ph === sRun
    p0    := ph === sLoaded
    first := ph === sRun && iter0(j)
    when(ph === sLoaded) {
      phase(j)  := sRun
      left(j)   := imaxS(j)
      lastIt(j) := imaxS(j) === 1.U
      iter0(j)  := true.B
      stamp(j)  := now + 1.U
    }.elsewhen(ph === sRun) {
      left(j)   := left(j) - 1.U
      lastIt(j) := left(j) === 2.U
      iter0(j)  := false.B
      when(lastIt(j)) {
        phase(j) := sWait
        lastTurnStart := true.B
      }
    }
  }.elsewhen(kEnd && !inPad) {
    live := false.B
  }
  val tok = Wire(new RowToken(kW, sW))
  tok.valid := live && !inPad
  tok.pass0 := p0
  tok.first := first
  tok.k     := k
  tok.slot  := s(math.max(sW, 1) - 1, 0)
  io.tokN := tok

  // ---- the answers: a slot's results are complete L cycles after its last turn began (the token register holds
  // that turn's row 0 a cycle after lastTurnStart)
  val readyIn = Wire(Valid(UInt(sW.W)))
  readyIn.valid := lastTurnStart
  readyIn.bits  := j
  val ready = ShiftRegister(readyIn, L + 1, 0.U.asTypeOf(readyIn), true.B)
  val queue = Module(new Queue(UInt(sW.W), Kp))
  queue.io.enq.valid := ready.valid
  queue.io.enq.bits  := ready.bits
  bus.Protocol.noOverflow("answer queue", ready.valid, queue.io.enq.ready)

  val oBusy  = RegInit(false.B)
  val oSlot  = RegInit(0.U(sW.W))
  val oCnt   = RegInit(0.U(oW.W))
  val oEnd   = RegInit(0.U(oW.W))
  val oAtEnd = RegInit(false.B)
  val lastFire = oBusy && io.outFire && oAtEnd
  queue.io.deq.ready := !oBusy || lastFire
  when(io.outFire) {
    oCnt   := oCnt + 1.U
    oAtEnd := oCnt + 1.U === oEnd
  }
  when(lastFire) {
    oBusy := false.B
    phase(oSlot) := sFree
  }
  when(queue.io.deq.fire) {
    oBusy  := true.B
    oSlot  := queue.io.deq.bits
    oCnt   := 0.U
    oEnd   := outLastS(queue.io.deq.bits)
    oAtEnd := outLastS(queue.io.deq.bits) === 0.U
  }
  io.outValid  := oBusy
  io.outSlot   := oSlot
  io.outIndex  := oCnt
  io.outIsLast := oAtEnd
  io.done      := lastFire
  io.runCycles := now - stamp(oSlot)
  io.running   := phase.map(_ =/= sFree).reduce(_ || _)
}
