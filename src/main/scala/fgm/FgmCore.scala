package fgm

import chisel3._
import chisel3.util._
import bus.{AxiLiteIO, AxiStreamIO}
import fixed.FixedOps
import linalg.{DotProductParams, DotProductTree}
import mem.{InitRam, KeepReg}
import proj.BoxProjection
import shell.{Field, FrameIn, RegMap, Region, Register, RowToken, SeqControl, SolverRegs}

/** Fixed-point fast gradient method (Algorithm 1 of 002) for input-constrained MPC, after Fig. 1/2 of 002.
  *
  * One solve: receive w = (x, r) on s_axis (saturated to the state box), compute h = Phi_n w once (first pass),
  * then Imax iterations of
  *   t = (I - H_n) y - h,  z+ = proj(t),  y+ = (1 + beta) z+ - beta z,
  * each in L_F = ceil(n/P) + l_A ceil(log2 n) + 2 l_M + 3 l_A + 1 cycles, and send u0 (or all of z) on m_axis.
  *
  * P row units share the operand vector y; unit p computes rows p, p+P, ... one per cycle. A row's dot product,
  * subtraction, projection and y update form a pipeline; new y components collect in yNext and move to the
  * operand register y when the iteration's last row is done (the +1 of eq. (23)).
  */
class FgmCore(val p: FgmParams) extends Module {
  override def desiredName = p.moduleName

  import p.{K, Kp, P, m, n, nu, nw}
  val b = p.fracBits
  /** the problem id's width (tuser): interleaving cores only */
  val sW = log2Ceil(Kp)

  /** w = (x, r), one signed word with frac_bits fraction bits per beat, tlast on the last; tuser: problem id */
  val s_axis = IO(Flipped(new AxiStreamIO(p.streamW, sW)))
  /** u0 (nu words) or z (n words), same word format, tlast on the last; tuser: problem id */
  val m_axis = IO(new AxiStreamIO(p.streamW, sW))
  /** configuration, status and the data memories */
  val s_axil = IO(Flipped(new AxiLiteIO(p.axiAddrW)))

  // ------------------------------------------------------------------ registers, input frame, sequencer
  // The early exit (p.earlyExit): EXIT_TOL, and the last solve's iterations and whether its test held
  val tolR   = RegInit(p.exitTol.U((p.tolW - 1).W))
  val itersR = RegInit(0.U(16.W))
  val metR   = RegInit(false.B)
  val regs = new SolverRegs(s_axil, FgmRegs.map(p), coreSources = if (!p.earlyExit) Map() else
    Map("EXIT_TOL.VALUE" -> tolR, "ITERATIONS.COUNT" -> itersR, "ITERATIONS.MET" -> metR.asUInt))
  /** w = (x, r), saturated to the state box */
  val frameIn = Module(new FrameIn(p.moduleName + "_x", nw, p.xW, p.streamW, p.xlo.zip(p.xhi), Kp))
  frameIn.io.s_axis <> s_axis
  frameIn.io.hold := regs.frameHold
  when(frameIn.io.sat) { regs.stSat := true.B }
  when(frameIn.io.tlastErr) { regs.stTlast := true.B }
  val outLast = Mux(regs.ctrlOutAll, (n - 1).U, (nu - 1).U)
  /** per problem: the warm start is valid (interleaving; one problem uses the shared WARM_VALID) */
  val warmOk = RegInit(VecInit(Seq.fill(Kp)(false.B)))
  /** the iteration the sequencer ends now passed the exit test (registers: see the test below) */
  val exitNow = WireDefault(false.B)
  val ctl = SeqControl(K, K + 1, p.cyclesPerIteration, copyAfterFirst = false, maxOut = n, Kp, frameIn, regs, outLast,
    m_axis.fire, warmOk, if (p.earlyExit) Some(exitNow) else None)
  regs.busy := ctl.running || ctl.outPending || frameIn.io.full || frameIn.io.partial || s_axis.fire

  // ------------------------------------------------------------------ memories
  val matRam = (0 until P).map { u =>
    Module(new InitRam(s"${p.moduleName}_mat$u", 2 * p.K2, m, p.coefW, p.matInit(u), outReg = true,
      ecp5 = p.target == dsp.Target.Ecp5, raddrAhead = ctl.tokNN.isDefined, broadcast = true))
  }
  val bndRam = (0 until P).map { u =>
    Module(new InitRam(s"${p.moduleName}_ubox$u", K, 2, p.zW, p.boundInit(u), outReg = true,
      ecp5 = p.target == dsp.Target.Ecp5, broadcast = true))
  }
  val betaRam = Module(new InitRam(s"${p.moduleName}_beta", 1, 2, p.betaW, Seq(Seq(p.beta, p.onePlusBeta))))
  for (r <- matRam ++ bndRam :+ betaRam) r.io.clock := clock
  // beta's write, registered on its way in: the register file's decode does not reach beta's registers
  val betaWen  = WireDefault(false.B)
  val betaMask = WireDefault(0.U(2.W))
  betaRam.io.wen   := RegNext(betaWen, false.B)
  betaRam.io.waddr := 0.U
  betaRam.io.wmask := RegNext(betaMask)
  betaRam.io.wdata := RegNext(Fill(2, regs.wD(p.betaW - 1, 0)))
  betaRam.io.raddr := 0.U
  val betaQ = betaRam.io.rdata(p.betaW - 1, 0).asSInt
  val opbQ  = betaRam.io.rdata(2 * p.betaW - 1, p.betaW).asSInt

  // ------------------------------------------------------------------ solver state
  // One problem: w and the operand y are registers; y moves from yNext when an iteration ends. Kp problems: per
  // problem w, yNext (y+ of its last pass) and z; the operand registers wCur and yReg load a problem's w or yNext
  // at the start of its turn (shell.TurnSequencer).
  val warmL = RegInit(false.B)
  val wReg  = Seq.fill(Kp)(Reg(Vec(nw, SInt(p.xW.W))))
  val wCur  = if (Kp == 1) wReg(0) else Reg(Vec(nw, SInt(p.xW.W)))
  val yReg  = Reg(Vec(n, SInt(p.yW.W)))
  val yNext = Seq.fill(Kp)(Reg(Vec(n, SInt(p.yW.W))))
  val zReg  = Seq.fill(Kp)(Reg(Vec(n, SInt(p.zW.W))))
  // Per problem and row unit, in the order the unit visits its rows: h = Phi_n w and the previous iterate z. Each
  // is a rotating FIFO (Fig. 1 of 002), read at its head, so no row needs a K-way multiplexer.
  val hFifo = Seq.fill(Kp, P)(Reg(Vec(K, SInt(p.sumW.W))))
  val zFifo = Seq.fill(Kp, P)(Reg(Vec(K, SInt(p.zW.W))))

  // Fetch: a token per matrix row follows the row down the pipeline. tokN is the token of the next cycle, from
  // the sequencer's next state: the row RAMs are addressed one cycle ahead and their outputs registered, so the
  // block RAM clock-to-output delay stays off the datapath without adding cycles.
  val tokN = ctl.tokN
  val tok0 = RegNext(tokN, 0.U.asTypeOf(tokN))
  def tokAt(stage: Int): RowToken =
    if (stage < 0) tokN else ShiftRegister(tok0, stage, 0.U.asTypeOf(tokN), true.B)
  import ctl.{mine, ofSlot}
  val tok1    = tokAt(1)
  val tokSum  = tokAt(p.stageSum)
  val tokT    = tokAt(p.stageT)
  val tokZ    = tokAt(p.stageZ)
  // The bounds reach the projection a cycle after the block RAM's output register, through a fabric register,
  // where the pipeline is deep enough to address them a cycle earlier: the DP16KD's clock-to-output delay then
  // stays off the projection's comparators.
  val bndRegd = p.stageT >= 2
  val tokBnd  = tokAt(p.stageT - (if (bndRegd) 3 else 2))
  // The FIFOs' controls, per problem, each the registered condition on the token a stage earlier: they fan out to
  // every register of the FIFOs, so they come straight from flip-flops (tok1 is tok0 registered; stageZ >= 1)
  //
  // Controls per row unit (an FPGA target, one problem, P > 1): each unit's registers take their enables, and its
  // multipliers y and w, from copies of their own, so that no register drives all units across the device. The
  // copies are kept (mem.KeepReg): synthesis would merge them back into one.
  val split = Kp == 1 && P > 1 && p.target != dsp.Target.Generic
  /** per row unit, `f(u)` registered: a kept copy each when split, else one register (reset to 0) for all */
  def unitRegsOf[T <: Data](f: Int => T): Seq[T] =
    if (split) (0 until P).map(u => KeepReg(f(u))) else { val r = RegNext(f(0), 0.U.asTypeOf(f(0))); Seq.fill(P)(r) }
  /** `d` registered per row unit (unitRegsOf) */
  def unitRegs[T <: Data](d: T): Seq[T] = unitRegsOf(_ => d)
  /** the token at `stage` (>= 0) per row unit: split, a kept copy each of the token a stage earlier, so that the
    * decodes from it are made beside the unit's registers and only registers cross to the unit */
  def unitTok(stage: Int): Seq[RowToken] = if (split) Seq.fill(P)(KeepReg(tokAt(stage - 1))) else Seq.fill(P)(tokAt(stage))
  val tok1U = unitTok(1)
  /** the y rows' writes a cycle ahead (stage Y - 1), the y subtraction's and t's saturation flags, per row unit */
  val tokYU    = unitTok(p.stageY - 1)
  val tokYsubU = if (p.stageZ + p.latMul == p.stageY - 1) tokYU else unitTok(p.stageZ + p.latMul)
  // t is registered before its saturation when the bounds fit its width (below): its flag then comes at stage T
  val rawT     = p.zW <= p.tW
  val tokOfTU  = unitTok(if (rawT) p.stageT else p.stageSum)
  val loadZ = (0 until Kp).map(j => unitRegs(tok0.valid && tok0.first && tok0.k === 0.U && mine(tok0, j)))
  val rotZs = { val t = tokAt(p.stageZ - 1); (0 until Kp).map(j => unitRegs(t.valid && !t.pass0 && mine(t, j))) }
  val rotHs = { val t = tokAt(p.stageSum - 1); (0 until Kp).map(j => unitRegs(t.valid && mine(t, j))) }

  for (u <- 0 until P) {
    // second block at K2 = 2^ceil(log2 K): no adder; one problem: a cycle ahead, registered beside the blocks
    val tokR = ctl.tokNN.getOrElse(tokN)
    matRam(u).io.raddr := Cat(tokR.pass0, tokR.k)
    // first pass: the next row's bounds (the cold start); else the row reaching the projection. Not gated by
    // tokN.valid (forced in the cycle of the start, from the input handshake): while the first pass has rows
    // to issue its token is valid, and in the other cycles of the first pass and in idle the read is unused
    // (no iteration row is in flight)
    // Several problems: always the row reaching the projection, for a first pass too (its cold start is then
    // formed at the projection stage): another problem's iteration rows may still be in flight when a first
    // pass's rows are fetched, and they need their own bounds.
    // One problem: the first pass reads a cycle earlier still (tokNN), so that its bounds are registered before
    // the cold start is formed from them; the iteration rows' reads (tokBnd) trail far behind the first pass's.
    bndRam(u).io.raddr := ctl.tokNN.map(t => Mux(t.pass0, t.k, tokBnd.k)).getOrElse(tokBnd.k)
  }

  // the operand y of each unit's multipliers (split: the unit's copy, written as yReg is)
  val yOf: Seq[Vec[SInt]] = if (split) Seq.fill(P)(Wire(Vec(n, SInt(p.yW.W)))) else Seq.fill(P)(yReg)
  def padded(v: Vec[SInt], len: Int) = VecInit((0 until m).map(j => if (j < len) v(j).pad(p.opW) else 0.S(p.opW.W)))
  val ovfNow = Wire(Vec(P, Bool()))

  val dp = Module(new DotProductTree(DotProductParams(m, p.coefW, p.opW, p.sumW, b, p.latMul, p.latAdd, p.rounding, p.target)))
  val unitY = Wire(Vec(P, SInt(p.yW.W)))
  val unitZ = Wire(Vec(P, SInt(p.zW.W)))
  val unitCold = Wire(Vec(P, SInt(p.zW.W)))
  /** the exit test, per row unit: the step z+ - z of the row two stages past Z is not below EXIT_TOL */
  val unitBig = Wire(Vec(P, Bool()))
  unitBig := DontCare
  // EXIT_TOL, latched at the start (as IMAX), and its negation, per row unit
  val (tolU, ntolU) = if (!p.earlyExit) (Nil, Nil) else {
    val tolS = RegEnable(tolR.zext, ctl.take)
    (unitRegs(tolS), unitRegs(0.S -& tolS))
  }
  val units = (0 until P).map { u =>
    val tree = if (u == 0) dp else Module(new DotProductTree(dp.p))
    tree.io.inValid := tok1.valid
    tree.io.coef    := matRam(u).io.rdata.asTypeOf(Vec(m, SInt(p.coefW.W)))
    // w is loaded at the start and first read two cycles later, so its copy may trail it by one
    // (split: the operand select per multiplier from a copy of its own, as it drives the multiplier's operand bits)
    val (pass0, wU) = if (split) (KeepReg.copies(tok0.pass0, m, keep = true), KeepReg(wCur))
      else (Seq.fill(m)(tok1.pass0), wCur)
    val (wOp, yOp)  = (padded(wU, nw), padded(yOf(u), n))
    tree.io.op      := VecInit((0 until m).map(j => Mux(pass0(j), wOp(j), yOp(j))))

    // First pass: h = Phi_n w enters the FIFO one row per cycle; each iteration row reads the head and rotates.
    val hHead = ofSlot((0 until Kp).map(j => hFifo(j)(u)(0)), tokSum.slot)
    for (j <- 0 until Kp) when(rotHs(j)(u)) {
      for (i <- 0 until K - 1) hFifo(j)(u)(i) := hFifo(j)(u)(i + 1)
      hFifo(j)(u)(K - 1) := Mux(tokSum.pass0, tree.io.sum, hFifo(j)(u)(0))
    }

    // The bounds of the row reaching the projection (stage T), and the cold start z0 = proj(0) from this row's
    // bounds during the first pass: with one problem from the memory's register, addressed by tokNN; with several
    // at the projection stage, as the iteration rows.
    val bndR = RegNext(bndRam(u).io.rdata)
    val bnd = if (bndRegd) bndR else bndRam(u).io.rdata
    val bndCold = if (Kp == 1) bndR else bnd
    val lo1 = bndCold(p.zW - 1, 0).asSInt
    val hi1 = bndCold(2 * p.zW - 1, p.zW).asSInt
    // registered: it fans out to the rows of the unit across the chip (written a cycle later, weCold)
    unitCold(u) := RegNext(Mux(!lo1(p.zW - 1) && lo1 =/= 0.S, lo1, Mux(hi1(p.zW - 1), hi1, 0.S)))

    // t = (I - H_n) y - h. When the bounds fit t's width (zW <= tW), projecting the difference itself gives the
    // same z as projecting it saturated (saturation is monotone and keeps [lo, hi]): the difference is registered
    // unsaturated and its saturation flag formed from the register, so the carry chain does not share a cycle with
    // the saturation. Else t saturates before its register.
    val diff     = tree.io.sum -& hHead
    val tD       = ShiftRegister(if (rawT) diff else FixedOps.saturate(diff, p.tW)._1, p.latAdd)
    val ofT      = if (rawT) FixedOps.saturate(tD, p.tW)._2 else FixedOps.saturate(diff, p.tW)._2
    // z+ = proj(t) on [lo, hi] of this row
    val proj = Module(new BoxProjection(tD.getWidth, p.zW, p.latAdd))
    proj.io.in := tD
    proj.io.lo := bnd(p.zW - 1, 0).asSInt
    proj.io.hi := bnd(2 * p.zW - 1, p.zW).asSInt
    val z = proj.io.out
    // y+ = (1 + beta) z+ - beta z, z the previous iterate of the same row: the head of the z FIFO, which the
    // first iteration loads from the z0 registers (rows u, u+P, ...) as it reads it.
    val zHeads = (0 until Kp).map { j =>
      val zSrc = VecInit((0 until K).map { i =>
        val r = i * P + u
        Mux(loadZ(j)(u), if (r < n) zReg(j)(r) else 0.S(p.zW.W), zFifo(j)(u)(i))
      })
      when(loadZ(j)(u) || rotZs(j)(u)) {
        for (i <- 0 until K) zFifo(j)(u)(i) := Mux(rotZs(j)(u), if (i < K - 1) zSrc(i + 1) else z, zSrc(i))
      }
      zSrc(0)
    }
    val zOld      = ofSlot(zHeads, tokZ.slot)
    if (p.earlyExit) {
      val step = RegNext(z -& zOld)
      unitBig(u) := RegNext(step >= tolU(u) || step <= ntolU(u))
    }
    val ra        = FixedOps.mulRoundPipelined(opbQ, z, p.latMul, b, p.rounding, p.target)
    val rb        = FixedOps.mulRoundPipelined(betaQ, zOld, p.latMul, b, p.rounding, p.target)
    val (y, ofY)  = FixedOps.satSub(ra, rb, p.yW)
    unitY(u) := ShiftRegister(y, p.latAdd)
    unitZ(u) := ShiftRegister(z, p.latMul + p.latAdd)

    // Saturation anywhere in a live row sets the sticky overflow flag.
    val ofTree = tree.io.outValid && tree.io.overflow
    val ofTs   = tokOfTU(u).valid && !tokOfTU(u).pass0 && ofT
    val ofYs   = tokYsubU(u).valid && !tokYsubU(u).pass0 && ofY
    ovfNow(u) := ofTree || ofTs || ofYs
  }
  when(RegNext(ovfNow.asUInt, 0.U).orR) { regs.stOvf := true.B } // the flags of a cycle registered first

  // The exit test. Stopping after iteration i when ||z_i - z_(i-1)||_inf < EXIT_TOL and the same held for
  // iteration i - 1 bounds the gradient map: y_(i-1) - z_i = (z_(i-1) - z_i) + beta (z_(i-1) - z_(i-2)), so
  // ||y_(i-1) - z_i||_inf < (1 + beta) EXIT_TOL (y_0 = z_0: the first iteration needs its own step only). `big`
  // collects an iteration's rows (stage Z + 2, the unit flags' stage); `prevOk` is the previous iteration's result,
  // taken as its first row comes. The sequencer reads `exitNow` as it ends the iteration, the last row's flag
  // then in `big` (p.exitExtra).
  if (p.earlyExit) {
    val tokB   = tokAt(p.stageZ + 2)
    val anyBig = unitBig.asUInt.orR
    val big    = RegInit(true.B)
    val prevOk = RegInit(false.B)
    when(tokB.valid && !tokB.pass0) {
      when(tokB.k === 0.U) {
        big    := anyBig
        prevOk := tokB.first || !big
      }.otherwise { big := big || anyBig }
    }
    exitNow := !big && prevOk
    when(ctl.done) {
      itersR := ctl.iters
      metR   := exitNow
    }
  }

  // Register writes: z0 = y0 at the start (warm: the previous solution shifted by one stage, the last stage
  // repeated, Fig. 2b) or in the first pass (cold), y+/z+ at the end of each row's pipeline, the operand copy.
  // All decided a cycle ahead and registered: they fan out to every row register.
  val tokY1 = tokAt(p.stageY - 1)
  def shifted(r: Int): Int = if (r < n - nu) r + nu else r
  // one problem: the value each z register has in the next cycle, for the answer (only a row's own write can
  // change z then: the warm copy and the cold start come at a solve's start and in its first pass)
  val zAhead = Wire(Vec(n, SInt(p.zW.W)))
  zAhead := zReg(0)
  if (Kp == 1) {
    val warmNow  = regs.ctrlWarm && regs.warmValid
    val warmCopy = unitRegs(ctl.take && warmNow)
    when(ctl.take) {
      wReg(0) := frameIn.io.frame
      warmL   := warmNow
    }
    // tok1 is a first-pass row and the solve starts cold, per row unit (split: kept copies, formed a cycle ahead
    // from tok0 and warmL's next value)
    val coldGo = if (split) Seq.fill(P)(KeepReg(tok0.valid && tok0.pass0 && !Mux(ctl.take, warmNow, warmL)))
      else Seq.fill(P)(tok1.valid && tok1.pass0 && !warmL)
    /** unit u's cold start writes row k in the next cycle */
    def coldAt(u: Int, k: Int): Bool = coldGo(u) && tok1U(u).k === k.U
    val weCold = unitRegsOf(u => VecInit((0 until K).map(coldAt(u, _))))
    val weY    = unitRegsOf(u => RowToken.decode(tokYU(u), tokYU(u).valid && !tokYU(u).pass0, K))
    for (r <- 0 until n) {
      val u = r % P
      val k = r / P
      when(warmCopy(u)) {
        yReg(r)    := zReg(0)(shifted(r)).pad(p.yW)
        zReg(0)(r) := zReg(0)(shifted(r))
      }.elsewhen(weCold(u)(k)) {
        yReg(r)    := unitCold(u).pad(p.yW)
        zReg(0)(r) := unitCold(u)
      }.elsewhen(ctl.copyNow) {
        yReg(r) := yNext(0)(r)
      }
      when(weY(u)(k)) {
        yNext(0)(r) := unitY(u)
        zReg(0)(r)  := unitZ(u)
        zAhead(r)   := unitZ(u)
      }
    }
    assert(!(ctl.outLoad && (warmCopy.head || weCold.head.asUInt.orR)), "FgmCore: a start's write before the answer")
    // the units' copies of y: written as yReg is, each word under copies of the write controls of its own (the
    // same registers as warmCopy, weCold and the copy, kept apart: each drives one word beside its multiplier)
    if (split) for (u <- 0 until P) {
      val d = Wire(Vec(n, SInt(p.yW.W)))
      val q = KeepReg(d)
      for (r <- 0 until n) {
        val warmR = KeepReg(ctl.take && warmNow)
        val coldR = KeepReg(coldAt(u, r / P))
        val copyR = KeepReg(ctl.copyNext)
        d(r) := Mux(warmR, zReg(0)(shifted(r)).pad(p.yW), Mux(coldR, unitCold(r % P).pad(p.yW),
          Mux(copyR, yNext(0)(r), q(r))))
      }
      yOf(u) := q
    }
  } else {
    for (j <- 0 until Kp) when(ctl.take && frameIn.io.id === j.U) { wReg(j) := frameIn.io.frame }
    // the operands of a turn, loaded as its row 0 reaches tok0 (in use from tok1 on)
    val turn0 = RegNext(tokN.valid && tokN.k === 0.U, false.B)
    for (i <- 0 until nw) when(turn0 && tok0.pass0) { wCur(i) := ofSlot(wReg.map(_(i)), tok0.slot) }
    for (r <- 0 until n) when(turn0 && !tok0.pass0) { yReg(r) := ofSlot(yNext.map(_(r)), tok0.slot) }
    for (j <- 0 until Kp) {
      val warmCopy = RegNext(turn0 && tok0.pass0 && mine(tok0, j) && ctl.warmOf(j), false.B)
      // the cold start of a first-pass row, from its bounds at the projection stage (bndRam read by tokBnd)
      val weCold   = RowToken.enables(tokT, tokT.valid && tokT.pass0 && mine(tokT, j) && !ctl.warmOf(j), K)
      val weY      = RowToken.enables(tokY1, tokY1.valid && !tokY1.pass0 && mine(tokY1, j), K)
      for (r <- 0 until n) {
        val u = r % P
        val k = r / P
        when(warmCopy) {
          yNext(j)(r) := zReg(j)(shifted(r)).pad(p.yW)
          zReg(j)(r)  := zReg(j)(shifted(r))
        }.elsewhen(weCold(k)) {
          yNext(j)(r) := unitCold(u).pad(p.yW)
          zReg(j)(r)  := unitCold(u)
        }.elsewhen(weY(k)) {
          yNext(j)(r) := unitY(u)
          zReg(j)(r)  := unitZ(u)
        }
      }
    }
  }

  // ------------------------------------------------------------------ output: u0 or all of z
  ctl.answer(m_axis, (s, i) => ofSlot(zReg.map(_(i)), s).pad(p.streamW).asUInt, i => zAhead(i).pad(p.streamW).asUInt,
    n, keep = p.target != dsp.Target.Generic)
  bus.Protocol.streamOut("m_axis", m_axis)

  // ------------------------------------------------------------------ AXI4-Lite data memories (write-only)
  import regs.{dataWrite, inRegion, offset, wD}
  // Default: no write this cycle.
  regs.frameBoxWrites(frameIn, "XBOX", p.xW, nw)
  /** a slot word's row unit (its low bits) and the unit's row k */
  def unitK(slot: UInt): (UInt, UInt) = (if (p.pBits == 0) 0.U else slot(p.pBits - 1, 0), slot >> p.pBits)
  /** rows of unit u: k P + u < n for k below ceil((n - u) / P) (a table, so no product k P is formed) */
  val unitRows = VecInit((0 until (1 << p.pBits)).map(u => (if (u < P) (n - u + P - 1) / P else 0).U(log2Ceil(K + 1).W)))
  /** the slot word `slot` names a row of the core */
  def slotOk(slot: UInt): Bool = {
    val (unit, k) = unitK(slot)
    k < unitRows(unit)
  }
  val tolWrite: Seq[(Bool, () => Unit)] = if (!p.earlyExit) Nil else Seq(regs.at(FgmRegs.EXIT_TOL) -> { () =>
    when(!regs.fitsS(p.tolW) || wD(31)) {
      regs.axil.wr.resp := bus.AxiLiteResp.SLVERR
    }.elsewhen(regs.axil.wr.valid) { tolR := wD(p.tolW - 2, 0) }
  })
  regs.writes(tolWrite ++ Seq(
    (regs.at(FgmRegs.BETA) || regs.at(FgmRegs.ONE_PLUS_BETA)) -> { () =>
      dataWrite(p.betaW, true.B) {
        betaWen  := true.B
        betaMask := Mux(regs.at(FgmRegs.BETA), 1.U, 2.U)
      }
    },
    inRegion("XBOX") -> { () => dataWrite(p.xW, regs.ahead("XBOX")(regs.boxOk(nw))) {} },
    inRegion("UBOX") -> { () =>
      dataWrite(p.zW, regs.ahead("UBOX")(o => slotOk(o >> 1))) {
        regs.warmValid := false.B
        warmOk.foreach(_ := false.B)
      }
    },
    (inRegion("MAT_A") || inRegion("MAT_F")) -> { () =>
      dataWrite(p.coefW, Mux(inRegion("MAT_F"), regs.ahead("MAT_F")(matOk(nw)), regs.ahead("MAT_A")(matOk(n)))) {}
    }
  ): _*)
  def matOk(cols: Int)(o: UInt): Bool = slotOk(o >> p.cBits) && (if (p.cBits == 0) true.B else o(p.cBits - 1, 0) < cols.U)

  // The row units' memory writes: enables, row and lanes decided a cycle ahead from the early request (the same
  // region, check and fit as the responses above), so that only registers drive the write ports across the die.
  {
    val off = regs.earlyOffset("UBOX")
    val (unit, k) = unitK(off >> 1)
    regs.unitWrites(bndRam, p.zW, u => regs.earlyIn("UBOX") && slotOk(off >> 1) && unit === u.U, k, off(0))
  }
  {
    // MAT_A and MAT_F have the same size, so one early offset serves both
    require(p.regionSizes.toMap.apply("MAT_A") == p.regionSizes.toMap.apply("MAT_F"), "MAT_A and MAT_F differ in size")
    val isF = regs.earlyIn("MAT_F")
    val off = regs.earlyOffset("MAT_A")
    val (unit, k) = unitK(off >> p.cBits)
    val ok  = regs.earlyIn("MAT_A") && matOk(n)(off) || isF && matOk(nw)(off)
    regs.unitWrites(matRam, p.coefW, u => ok && unit === u.U, Mux(isF, k +& p.K2.U, k),
      if (p.cBits == 0) 0.U else off(p.cBits - 1, 0))
  }
}

/** The register map of an FGM core: the shared registers of shell.SolverRegs, beta, and the data memories. */
object FgmRegs {
  val BETA          = SolverRegs.FirstCoreReg
  val ONE_PLUS_BETA = BETA + 1
  val ITERATIONS    = BETA + 2
  val EXIT_TOL      = BETA + 3

  def map(p: FgmParams): RegMap = {
    val shared = SolverRegs.registers("FGM1",
      config0 = Seq(Field.const("n", 0, 16, p.n, "decision variables n = N nu"),
        Field.const("P", 16, 16, p.P, "row units")),
      config1 = Seq(Field.const("nw", 0, 16, p.nw, "parameter words per solve, w = (x, r)"),
        Field.const("frac_bits", 16, 8, p.fracBits, "fraction bits of the data and stream words"),
        Field.const("nu", 24, 8, p.nu, "inputs per stage")),
      ctrl = SolverRegs.ctrlFields(p.warmDefault, p.outAllDefault, "u0 (nu words)"),
      status = SolverRegs.statusFields(),
      cyclesPerIteration = p.periodCycles, imaxDefault = p.imaxDefault)
    val word = s"signed, ${p.fracBits} fraction bits, sign-extended to 32 bits"
    def fits(w: Int) = s"$word; must fit $w bits, else SLVERR"
    val beta = Seq(
      Register("BETA", BETA, "beta of the y update", Seq(Field.data(s"beta, ${fits(p.betaW)}"))),
      Register("ONE_PLUS_BETA", ONE_PLUS_BETA, "1 + beta", Seq(Field.data(s"1 + beta, ${fits(p.betaW)}")))) ++
      (if (!p.earlyExit) Nil else Seq(
        Register("ITERATIONS", ITERATIONS, "the last solve's iterations and how it ended", Seq(
          Field.status("COUNT", 0, 16, "iterations run by the last solve"),
          Field.status("MET", 16, 1, "the last solve ended at the exit test (else at IMAX)"))),
        Register("EXIT_TOL", EXIT_TOL, "exit test: a solve ends after an iteration whose step " +
          "||z+ - z||_inf and the previous iteration's are below it; writing a negative value or one above " +
          s"${FixedOps.maxOf(p.tolW)}: SLVERR, ignored", Seq(Field.ctrl("VALUE", 0, p.tolW - 1, p.exitTol,
          s"a non-negative word with ${p.fracBits} fraction bits, latched at the start of each solve; 0: no exit before IMAX")))))
    val sizes = p.regionSizes.toMap
    def region(nm: String, dims: Seq[Int], desc: String, w: Int) =
      Region(nm, p.regionBase(nm), sizes(nm), dims, desc, Field.data(fits(w)))
    val (rows, units, cols) = (p.K, 1 << p.pBits, 1 << p.cBits)
    val row = "row k P + u (row unit u, slot k)"
    RegMap(p.moduleName, s"FGM core ${p.moduleName}: control, status and write-only data memories. ${SolverRegs.rules}",
      shared ++ beta, Seq(
        region("MAT_A", Seq(rows, units, cols), s"(I - H_n): element (k, u, j) is $row, column j; u from P on, rows from n on " +
          "and columns from n on: DECERR", p.coefW),
        region("MAT_F", Seq(rows, units, cols), s"Phi_n: element (k, u, j) is $row, column j of w = (x, r); u from P " +
          "on, rows from n on and columns from nw on: DECERR", p.coefW),
        region("UBOX", Seq(rows, units, 2), s"input bounds: element (k, u, 0) the lower, (k, u, 1) the upper bound " +
          s"of z at $row; u from P on, rows from n on: DECERR; a write drops the warm start", p.zW),
        region("XBOX", Seq(p.nw, 2), "parameter box: element (j, 0) the lower, (j, 1) the upper bound of word j of " +
          "w = (x, r); words outside saturate and set STATUS.SAT", p.xW)))
  }
}
