package ipm

import chisel3._
import chisel3.util._
import bus.{AxiLiteIO, AxiStreamIO}
import minres.MinresCore
import shell.SolverRegs

/** The interior-point core of 001 (Algorithm 1, Fig. 2): the Stage 1 engine (linearisation, direction recovery,
  * line search, update; one instance, sequential) and the MINRES solver (Stage 2, P problems per batch), with
  * 2P problems in flight in two groups of P: while MINRES solves one group's Newton systems, Stage 1 updates
  * and linearises the other's.
  *
  * Streams. In, per problem: the id word (bits 29:24 the channel c, 23:0 a tag; bits 31:30 must be 0), x (n
  * words of the format), r (ny words, tracking only), tlast on the last. Out, per answer: the id word (bits 29:0
  * as received), u0 (m words), mu, ||r_0|| of the last Newton system, the status word (bit 0 non-finite, bit 1
  * not converged, bits 31:16 the Newton iterations run), tlast on it. Channel c (taken modulo 2P) is the problem
  * slot, in group c / P, so each channel keeps its own iterate for the warm start; a frame waits at the head of
  * the stream while its channel has a problem in flight, or while its group runs. Answers leave in the order
  * their groups finish, each tagged with its id.
  *
  * Sequencer. A group forms from the frames at the head of the input for its channels (up to P, in arrival
  * order) while the group is idle: per problem Stage 1 runs sample, cold or warm, and linearise, whose words go
  * to MINRES as a frame (id c, diag, d, bh, z); a partial batch is closed at once. When MINRES has a group's
  * batch, Stage 1 takes its solutions in batch order, all of them first (receive: IN x per problem, so that
  * MINRES's output ends and its next batch can start), then per problem update, and linearise again, or after
  * I_NW Newton iterations output, whose words become the answer frame. Stage 1 gives priority to forming the
  * idle group when its frames are waiting and MINRES holds only the other group, otherwise to the oldest batch.
  */
class IpmCore(val p: IpmParams) extends Module {
  override def desiredName = p.moduleName
  private val W = p.fmt.width
  import p.{P, N, n, m, ny, slots}

  val s_axis = IO(Flipped(new AxiStreamIO(32)))
  val m_axis = IO(new AxiStreamIO(32))
  val s_axil = IO(Flipped(new AxiLiteIO(p.axiAddrW)))

  private def finite(w: UInt): Bool = w(W - 2, p.fmt.manW) =/= p.fmt.maxExpField.U
  /** a non-negative word at most `tol` (both words of the format; -0 passes, NaN fails) */
  private def atMost(w: UInt, tol: UInt): Bool = w(W - 1) && w(W - 2, 0) === 0.U || !w(W - 1) && w <= tol

  // ---- registers
  val nonfinite = RegInit(false.B)
  val notConv   = RegInit(false.B)
  val chanErr   = RegInit(false.B)
  val inwReg    = RegInit(p.iNw.U(16.W))
  val muTol     = RegInit(p.muTol.U(32.W))
  val resTol    = RegInit(p.resTol.U(32.W))
  val regs = new SolverRegs(s_axil, IpmRegs.map(p),
    Seq("NONFINITE" -> nonfinite, "NOT_CONVERGED" -> notConv, "CHANNEL" -> chanErr),
    Map("INW.INW" -> inwReg, "MU_TOL.VALUE" -> muTol, "RES_TOL.VALUE" -> resTol))

  // ---- the two stages
  // each stage's reset through a register of its own (the stages leave reset a cycle after the registers here,
  // which take every input first)
  private val keep = p.mr.target != dsp.Target.Generic
  val st1 = withReset(LocalReset(keep)) { Module(new Stage1Engine(p.st1)) }
  val mr  = withReset(LocalReset(keep)) { Module(new MinresCore(p.mr)) }
  mr.s_axil.awvalid := false.B; mr.s_axil.awaddr := 0.U; mr.s_axil.awprot := 0.U
  mr.s_axil.wvalid := false.B; mr.s_axil.wdata := 0.U; mr.s_axil.wstrb := 0.U; mr.s_axil.bready := true.B
  mr.s_axil.arvalid := false.B; mr.s_axil.araddr := 0.U; mr.s_axil.arprot := 0.U; mr.s_axil.rready := true.B
  private val close = WireDefault(false.B)
  mr.ipm.get.imax  := regs.imaxReg
  // registered: MINRES takes the close once the batch's last word is in, a cycle after the slice's handshake
  // (MinresCore's closePend), so the register costs no cycle
  mr.ipm.get.close := RegNext(close, false.B)

  // ---- per channel (problem slot) and per group
  private val cw    = log2Ceil(slots + 1)
  val busyC   = RegInit(VecInit(Seq.fill(slots)(false.B)))   // a problem in flight
  val started = RegInit(VecInit(Seq.fill(slots)(false.B)))   // an iterate to warm-start from
  val tagC    = Reg(Vec(slots, UInt(30.W)))
  val badC    = Reg(Vec(slots, Bool()))
  val resC    = Reg(Vec(slots, UInt(W.W)))
  val t0C     = Reg(Vec(slots, UInt(32.W)))
  val gIter   = Reg(Vec(2, UInt(16.W)))
  val gInw    = Reg(Vec(2, UInt(16.W)))
  val gCnt    = Reg(Vec(2, UInt(log2Ceil(P + 1).W)))      // problems in the group
  val gOrd    = Reg(Vec(2 * P, UInt(cw.W)))               // their channels in MINRES batch order: group g at g P
  private def ord(g: UInt, i: UInt): UInt = gOrd(g * P.U +& i)
  // the groups whose batches MINRES holds, oldest first
  val fifoN   = RegInit(0.U(2.W))
  val fifoG   = Reg(Vec(2, UInt(1.W)))
  val now     = RegInit(0.U(32.W))
  now := now + 1.U

  // ---- the head of the input: an id word
  private val headChRaw = s_axis.tdata(29, 24)
  private val headCh    = if (slots == 64) headChRaw else (headChRaw % slots.U)(cw - 1, 0)
  private val headG     = if (P == 1) headCh(0) else (headCh >= P.U).asUInt

  // ---- sequencer
  val sIdle :: sTakeId :: sSample :: sStart :: sLin :: sLinDrain :: sRecv :: sRecvWait :: sUpd :: sOut :: sOutDrain :: Nil =
    Enum(11)
  val state   = RegInit(sIdle)
  val curG    = Reg(UInt(1.W))
  val curC    = Reg(UInt(cw.W))
  val forming = Reg(Bool())
  val k       = Reg(UInt(log2Ceil(P + 1).W)) // position of curC in its group's batch
  val inExt   = RegInit(false.B) // Stage 1 IN from s_axis (sample), else from MINRES (update)
  private val inExtNext = WireDefault(inExt)
  inExt := inExtNext
  val outExt  = RegInit(false.B) // Stage 1 OUT to m_axis (output), else to MINRES (linearise)

  st1.start := false.B
  st1.prog  := 0.U
  st1.slot  := curC
  private def run(prog: String, c: UInt): Unit = {
    st1.start := true.B
    st1.prog  := p.prog(prog).U
    st1.slot  := c
  }

  // adapters' progress (below)
  val toArmed  = RegInit(false.B)
  private val to = new bus.FrameCount(p.mr.frameWords) // the stream to MINRES selects from its flags
  private val toAt0 = to.at0
  val outArmed = RegInit(false.B)
  val outCnt   = RegInit(0.U(log2Ceil(p.outWordsAll + 1).W))
  val outAll   = RegInit(false.B) // the answer being sent carries z and the steady state (CTRL.OUT_ALL)
  private val toIdle  = !toArmed && toAt0
  private val outIdle = !outArmed && outCnt === 0.U

  // the head may be taken: the same word has waited a cycle (tvalid high and not taken), its channel is free and
  // CTRL.HOLD is clear, in one flag registered a cycle ahead (CTRL.HOLD acts a cycle after its write), with the
  // head's group beside it, so that no channel select or register read lies in the sequencer's decisions
  private val headWaits = RegNext(s_axis.tvalid && !s_axis.tready && !busyC(headCh) && !regs.ctrlHold, false.B)
  private val headOk    = s_axis.tvalid && headWaits
  private val headGR    = RegNext(headG)
  /** another problem of the current group follows curC in its batch */
  private val more    = k + 1.U < gCnt(curG)
  // What picks the next program and its slot, registered a cycle ahead: a program runs for several cycles, and
  // curC, k, the group and its counts hold while it runs and while its output drains, so on the cycle it is done and
  // after it these equal their combinational values (CTRL.WARM and CTRL.OUT_ALL act a cycle after their write). No table read or compare
  // then lies between the engine's done and its next start.
  private val moreR    = RegNext(more, false.B)
  private val curFull  = RegNext(gCnt(curG) === P.U, false.B)
  private val nextOrd  = RegNext(ord(curG, k + 1.U))
  private val firstOrd = RegNext(ord(curG, 0.U))
  private val warmSel  = RegNext(started(curC) && regs.ctrlWarm, false.B)
  private val linAgain = RegNext(gIter(curG) < gInw(curG), false.B)
  private val outAllR  = RegNext(regs.ctrlOutAll, false.B)
  private def next(): Unit = {
    k    := k + 1.U
    curC := nextOrd
  }
  private def form(g: UInt): Unit = {
    state := sTakeId; curG := g; forming := true.B
    gIter(g) := 0.U; gInw(g) := inwReg; gCnt(g) := 0.U
  }

  private def startGroupUpdate(g: UInt): Unit = {
    curG    := g
    forming := false.B
    gIter(g) := gIter(g) + 1.U
    fifoN   := fifoN - 1.U
    fifoG(0) := fifoG(1)
    k       := 0.U
    curC    := ord(g, 0.U)
    inExtNext := false.B
    state   := sRecv
  }
  private val pushed = WireDefault(false.B)
  private def pushBatch(g: UInt): Unit = {
    pushed := true.B
    when(gCnt(g) =/= P.U) { close := true.B }
    fifoG(fifoN(0)) := g // fifoN is 0 or 1 here
    fifoN := fifoN + 1.U
    state := sIdle
  }

  // the id word is taken in sTakeId
  private val takeId = state === sTakeId && s_axis.tvalid
  bus.Protocol.noOverflow("batch order", pushed, fifoN =/= 2.U)
  bus.Protocol.noOverflow("group", takeId, gCnt(curG) =/= P.U && !busyC(headCh))
  switch(state) {
    is(sIdle) {
      val other = ~fifoG(0)
      when(fifoN === 2.U) {
        startGroupUpdate(fifoG(0))
      }.elsewhen(fifoN === 1.U) {
        when(headOk && headGR === other) { form(other) }.otherwise { startGroupUpdate(fifoG(0)) }
      }.elsewhen(headOk) { form(headGR) }
    }
    is(sTakeId) {
      when(takeId) {
        curC := headCh
        busyC(headCh) := true.B
        when(headChRaw >= slots.U) { chanErr := true.B }
        k := gCnt(curG)
        gOrd(curG * P.U +& gCnt(curG)) := headCh
        gCnt(curG) := gCnt(curG) + 1.U
        inExtNext := true.B
        run("sample", headCh)
        state := sSample
      }
    }
    is(sSample) {
      when(st1.done) {
        run("cold", curC)
        when(warmSel) { st1.prog := p.prog("warm").U }
        started(curC) := true.B
        state := sStart
      }
    }
    is(sStart) {
      when(st1.done) {
        outExt  := false.B
        toArmed := true.B
        run("linearise", curC)
        state := sLin
      }
    }
    is(sLin) { when(st1.done) { state := sLinDrain } }
    is(sLinDrain) {
      when(toIdle) {
        when(forming) {
          val another = headOk && headGR === curG && !curFull
          when(another) { state := sTakeId }.otherwise { pushBatch(curG) }
        }.otherwise {
          when(moreR) {
            next(); state := sUpd
          }.otherwise { pushBatch(curG) }
        }
      }
    }
    is(sRecv) { // the batch's solutions, all before any update: MINRES is free for its next batch sooner
      when(!st1.busy) {
        run("receive", curC)
        state := sRecvWait
      }
    }
    is(sRecvWait) {
      when(st1.done) {
        when(moreR) {
          run("receive", nextOrd)
          next()
        }.otherwise {
          run("update", firstOrd)
          k     := 0.U
          curC  := firstOrd
          state := sOut
        }
      }
    }
    is(sUpd) {
      // update, then linearise again or output; the start is taken when the engine is idle
      when(!st1.busy) {
        run("update", curC)
        state := sOut // the next step is chosen when update is done
        inExtNext := false.B
      }
    }
    is(sOut) {
      when(st1.done) {
        when(linAgain) {
          outExt  := false.B
          toArmed := true.B
          run("linearise", curC)
          state := sLin
        }.otherwise {
          outExt   := true.B
          outArmed := true.B
          outAll   := outAllR
          run("output", curC)
          when(outAllR) { st1.prog := p.prog("output_all").U }
          state := sOutDrain
        }
      }
    }
    is(sOutDrain) {
      when(!st1.busy && !outArmed && outCnt === 0.U && !RegNext(st1.start)) {
        when(moreR) {
          next(); state := sUpd
        }.otherwise { state := sIdle }
      }
    }
  }

  // ---- Stage 1 input: s_axis during sample (after the id word), MINRES's x words during update
  val mrCnt  = RegInit(0.U(log2Ceil(p.mr.outWords + 1).W))
  val mrSlot = Reg(UInt(cw.W))
  val extCnt = RegInit(0.U(log2Ceil(p.inWords + 1).W))
  // MINRES's word mrCnt is one of x's (not the id, not ||r_0||): a flag set from the count's next value, so that
  // no compare of the count lies before MINRES's tready
  private val mrData = RegInit(false.B)
  // Stage 1's input words through a register slice per source (the frame's x words, MINRES's x words), so that
  // Stage 1's issue meets registers and each source's tready is a register; each slice takes its source's words
  // ahead of the IN that reads them, in order
  private val extIn = Module(new bus.RegSlice(UInt(32.W)))
  private val mrIn  = Module(new bus.RegSlice(UInt(32.W)))
  extIn.io.enq.valid := s_axis.tvalid && inExt && extCnt =/= 0.U
  extIn.io.enq.bits  := s_axis.tdata
  mrIn.io.enq.valid  := mr.m_axis.tvalid && mrData
  mrIn.io.enq.bits   := mr.m_axis.tdata
  // Stage 1's valid selected by a copy of inExt of its own (kept apart on an FPGA target), placed by the issue
  // logic it feeds rather than by the sequencer and the data select
  private val inExtV = if (!keep) inExt else mem.KeepReg(inExtNext && !reset.asBool)
  st1.s_axis.tvalid  := Mux(inExtV, extIn.io.deq.valid, mrIn.io.deq.valid)
  st1.s_axis.tdata   := Mux(inExt, extIn.io.deq.bits, mrIn.io.deq.bits)
  st1.s_axis.tlast   := false.B
  extIn.io.deq.ready := inExt && st1.s_axis.tready
  mrIn.io.deq.ready  := !inExt && st1.s_axis.tready
  s_axis.tready := takeId || inExt && extCnt =/= 0.U && extIn.io.enq.ready
  mr.m_axis.tready := !mrData || mrIn.io.enq.ready
  // the id word's tag, start cycle and cleared flag are written a cycle after its handshake, and an x word's
  // non-finite flag a cycle after its own (all read at the answer, long after): the handshake meets registers, not
  // the channel decode of every tag and start cycle
  private val idTaken = RegNext(takeId, false.B)
  private val idCh    = RegNext(headCh)
  private val idTag   = RegNext(s_axis.tdata(29, 0))
  private val idT0    = RegNext(now)
  when(idTaken) {
    tagC(idCh) := idTag
    badC(idCh) := false.B
    t0C(idCh)  := idT0
  }
  private val xBadSet = RegNext(s_axis.fire && extCnt =/= 0.U && !finite(s_axis.tdata(W - 1, 0)), false.B)
  when(xBadSet) { badC(curC) := true.B }
  when(s_axis.fire) {
    val lastWord = extCnt === (p.inWords - 1).U
    when(s_axis.tlast =/= lastWord) { regs.stTlast := true.B }
    extCnt := Mux(lastWord, 0.U, extCnt + 1.U)
  }
  when(mr.m_axis.fire) {
    val nxt = Mux(mrCnt === (p.mr.outWords - 1).U, 0.U, mrCnt + 1.U)
    mrCnt  := nxt
    mrData := nxt =/= 0.U && nxt =/= (N + 1).U
    when(mrCnt === 0.U) { mrSlot := mr.m_axis.tdata(cw - 1, 0) }
  }
  // an id word's bad flag and ||r_0|| are written a cycle after their handshake (read at the answer, long after),
  // so that the handshake meets registers, not the slot decode of the flags' and the norms' enables
  private val mrWord  = RegNext(mr.m_axis.tdata)
  private val mrIdSet = RegNext(mr.m_axis.fire && mrCnt === 0.U && mr.m_axis.tdata(31), false.B)
  private val mrResW  = RegNext(mr.m_axis.fire && mrCnt === (N + 1).U, false.B)
  when(mrIdSet) { badC(mrWord(cw - 1, 0)) := true.B }
  when(mrResW) { resC(mrSlot) := mrWord(W - 1, 0) }

  // ---- Stage 1 output: the MINRES frame (id c, then linearise's words) or the answer frame (id, output's words,
  // ||r_0||, status)
  // The MINRES frame reaches MINRES through a register slice (Stage 1's output queue and MINRES's load logic lie
  // apart on the device): MINRES takes each word a cycle after the slice does; the sequencer counts the slice's
  // handshakes, and MINRES holds a partial batch's close until that batch's last word is in.
  private val toLast = to.atLast
  private val toMr   = Module(new bus.RegSlice(new bus.StreamWord(32)))
  toMr.io.enq.valid     := Mux(toAt0, toArmed, !outExt && st1.m_axis.tvalid)
  toMr.io.enq.bits.data := Mux(toAt0, curC.pad(32), st1.m_axis.tdata)
  toMr.io.enq.bits.last := toLast
  mr.s_axis.tvalid      := toMr.io.deq.valid
  mr.s_axis.tdata       := toMr.io.deq.bits.data
  mr.s_axis.tlast       := toMr.io.deq.bits.last
  toMr.io.deq.ready     := mr.s_axis.tready
  when(toMr.io.enq.fire) {
    to.step()
    when(toAt0) { toArmed := false.B }
  }

  val outBad = Reg(Bool())
  val muOk   = Reg(Bool()) // the answer's mu at most MU_TOL
  private val oLen   = Mux(outAll, (p.outWordsAll - 3).U, (p.outWords - 3).U) // Stage 1's words of the answer
  // the answer's word kinds as flags of outCnt, set from compares of its value before a handshake (so that no
  // compare lies between the count and m_axis, nor between tready and what the handshake updates):
  // cnt0 outCnt = 0 (the tag), oPass 1 .. oLen (Stage 1's words), oRes oLen + 1 (the residual), oStat oLen + 2
  // (the status word; +&: oLen is as wide as its largest literal, and oLen + 2 may need a bit more)
  private val cnt0  = RegInit(true.B)
  private val oPass = RegInit(false.B)
  private val oRes  = RegInit(false.B)
  private val oStat = RegInit(false.B)
  // curC's residual, start cycle and flag, read through a copy of curC and registered: curC holds from the
  // output program's start to the answer's end, and these are read at its last words
  private val curCR  = RegNext(curC)
  private val resCur = RegNext(resC(curCR))
  private val t0Cur  = RegNext(t0C(curCR))
  // registered: mu's test is made the cycle after its word's handshake (word m + 1) and lands a cycle later, the
  // residual's long before the answer; the status word comes at least two handshakes after mu
  private val conv   = muOk && RegNext(atMost(resCur, resTol(W - 1, 0)))
  private val bad    = outBad || RegNext(badC(curCR)) // curC's flag settled long before its answer
  private val status = Cat(gIter(curG), 0.U(14.W), !conv, bad)
  m_axis.tvalid := Mux(cnt0, outArmed, Mux(oPass, outExt && st1.m_axis.tvalid, true.B))
  m_axis.tdata  := Mux(cnt0, tagC(curC).pad(32),
    Mux(oPass, st1.m_axis.tdata, Mux(oRes, resCur.pad(32), status)))
  m_axis.tlast  := oStat
  bus.Protocol.streamOut("m_axis", m_axis)
  st1.m_axis.tready := Mux(outExt, oPass && m_axis.tready, !toAt0 && toMr.io.enq.ready)
  when(m_axis.fire) {
    outCnt := Mux(oStat, 0.U, outCnt + 1.U)
    cnt0   := oStat
    oPass  := !oStat && outCnt < oLen
    oRes   := !oStat && outCnt === oLen
    oStat  := !oStat && outCnt === oLen +& 1.U
    when(cnt0) {
      outArmed := false.B
      outBad   := false.B
    }
  }
  // the answer's words tested a cycle after their handshake (from registers: Stage 1's output and the handshake
  // lie apart from these flags); a flag set lands before the status word, which comes two handshakes later
  private val oWord  = RegNext(st1.m_axis.tdata(W - 1, 0))
  private val oBadW  = RegNext(m_axis.fire && oPass, false.B)
  private val oMuW   = RegNext(m_axis.fire && outCnt === (m + 1).U, false.B)
  when(oBadW && !finite(oWord)) { outBad := true.B }
  when(oMuW) { muOk := atMost(oWord, muTol(W - 1, 0)) }
  // the status word's handshake: its tvalid is high, so it is its tready alone (not through Stage 1's output)
  when(oStat && m_axis.tready) {
    busyC(curC) := false.B
    when(bad) {
      nonfinite := true.B
      started(curC) := false.B // the next sample of this channel starts cold
    }
    when(!conv) { notConv := true.B }
    regs.solveDone(now - t0Cur)
  }

  // busy: a problem in flight, a frame half taken, or the sequencer between steps (not once the last answer has
  // left: its drain is bookkeeping)
  regs.busy := busyC.asUInt.orR || fifoN =/= 0.U || extCnt =/= 0.U ||
    state =/= sIdle && !(state === sOutDrain && outIdle)
  regs.writes(
    regs.at(IpmRegs.INW) -> (() => {
      when(regs.wD === 0.U || regs.wD > 65535.U) { regs.axil.wr.resp := bus.AxiLiteResp.SLVERR }
        .elsewhen(regs.axil.wr.valid) { inwReg := regs.wD }
    }),
    regs.at(IpmRegs.MU_TOL) -> (() => { when(regs.axil.wr.valid) { muTol := regs.wD } }),
    regs.at(IpmRegs.RES_TOL) -> (() => { when(regs.axil.wr.valid) { resTol := regs.wD } }))
}
