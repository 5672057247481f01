package admm

import chisel3._
import chisel3.util._
import bus.{AxiLiteIO, AxiStreamIO}
import fixed.FixedOps
import linalg.{DotProductParams, DotProductTree}
import mem.{InitRam, KeepReg}
import proj.{BoxProjection, SoftProjection}
import shell.{FrameIn, OneHotSelect, RowToken, SeqControl, SolverRegs}

/** Fixed-point ADMM (Algorithm 2 of 002) for MPC with input, input-rate and soft state constraints, after Fig. 1
  * and 3 of 002. mpc_cores/admm/model.py (AdmmFixed) is its bit-exact model.
  *
  * One solve: receive w = (x, u_prev, r) on s_axis (saturated to its box); a first pass computes G~ (w, 1) and
  * the start iterate (cold: z = proj(0), nu = 0; warm: the previous (z, nu) shifted by one stage); then Imax
  * iterations, each in L = K + 1 + l_M + l_A ceil(log2 max(n_A, nw + 1)) + 6 l_A cycles (5 l_A without soft
  * constraints) of
  *   y = M11 v + G~ (w, 1),  z+ = proj(y + nu / rho),  nu+ = nu + rho (y - z+),  v+ = rho z+ - nu+,
  * every multiplication by rho_j = 2^k_j a shift; then send du_0 (or all of z) on m_axis.
  *
  * P row units share the operand vector v; each works through its K rows, one per cycle. A row's dot product, the
  * y, q, projection, d = y - z and nu updates form a pipeline; z and nu go to their registers at its end, and in
  * the cycle after an iteration's last row the whole of v = rho z - nu is formed at once (n_A subtractors, the
  * shifts are wiring). A soft pair's state row runs one slot ahead of its slack row on the same unit; the soft
  * projection waits for the slack and the state's d and nu updates run beside the slack's ("partner" lane).
  */
class AdmmCore(val p: AdmmParams) extends Module {
  override def desiredName = p.moduleName

  /** the problem id's width (tuser): interleaving cores only */
  val sW = log2Ceil(p.Kp)
  /** w = (x, u_prev, r), one signed word with frac_bits fraction bits per beat, tlast on the last; tuser: problem id */
  val s_axis = IO(Flipped(new AxiStreamIO(p.streamW, sW)))
  /** du_0 (nu words) or z (n_A words), same word format, tlast on the last; tuser: problem id */
  val m_axis = IO(new AxiStreamIO(p.streamW, sW))
  /** configuration, status and the data memories */
  val s_axil = IO(Flipped(new AxiLiteIO(p.axiAddrW)))

  import AdmmParams._
  import p.{K, Kp, P, lanes, n, nu, nw}
  /** the operand vectors' length: every chunk of a row full */
  val mPad = lanes * p.chunks
  val b = p.fracBits
  val L = p.cyclesPerIteration

  // ------------------------------------------------------------------ registers, input frame, sequencer
  val regs = new SolverRegs(s_axil, AdmmRegs.map(p))
  val frameIn = Module(new FrameIn(p.moduleName + "_w", nw, p.wW, p.streamW, p.wlo.zip(p.whi), Kp))
  frameIn.io.s_axis <> s_axis
  frameIn.io.hold := regs.frameHold
  when(frameIn.io.sat) { regs.stSat := true.B }
  when(frameIn.io.tlastErr) { regs.stTlast := true.B }
  /** per problem: the warm start is valid (interleaving; one problem uses the shared WARM_VALID) */
  val warmOk = RegInit(VecInit(Seq.fill(Kp)(false.B)))
  val ctl = SeqControl(p.slots, L, L, copyAfterFirst = true, maxOut = n, Kp, frameIn, regs,
    Mux(regs.ctrlOutAll, (n - 1).U, (nu - 1).U), m_axis.fire, warmOk)
  import ctl.{mine, ofSlot}
  regs.busy := ctl.running || ctl.outPending || frameIn.io.full || frameIn.io.partial || s_axis.fire

  // ------------------------------------------------------------------ memories
  val matRam = (0 until P).map(u => Module(new InitRam(s"${p.moduleName}_mat$u", 2 * p.K2, lanes, p.coefW, p.matInit(u), outReg = true,
    ecp5 = p.target == dsp.Target.Ecp5, raddrAhead = ctl.tokNN.isDefined, broadcast = true)))
  val bndRam = (0 until P).map(u => Module(new InitRam(s"${p.moduleName}_bnd$u", K, 2, p.zW, p.boundInit(u), outReg = true,
    ecp5 = p.target == dsp.Target.Ecp5, broadcast = true)))
  // G~ (w, 1) per row, of each problem (rows of problem j from j 2^ceil(log2 K) on)
  val gwKW   = math.max(1, log2Ceil(K))
  val gwRam  = (0 until P).map(u => Module(new InitRam(s"${p.moduleName}_gw$u", if (Kp == 1) K else (1 << sW) << gwKW,
    1, p.sumW, Seq(), outReg = true)))
  for (r <- matRam ++ bndRam ++ gwRam) r.io.clock := clock
  for (r <- gwRam) {
    r.io.wen   := false.B
    r.io.waddr := 0.U
    r.io.wmask := 0.U
    r.io.wdata := 0.U
  }

  // ------------------------------------------------------------------ solver state
  // One problem: w and the operand v are registers. Kp problems: per problem w, z and nu; the operand registers
  // wCur and vReg load a problem's w or v = rho z - nu at the start of its turn (shell.TurnSequencer).
  val warmL = RegInit(false.B)
  val wReg  = Seq.fill(Kp)(Reg(Vec(nw, SInt(p.wW.W))))
  val wCur  = if (Kp == 1) wReg(0) else Reg(Vec(nw, SInt(p.wW.W)))
  val zReg  = Seq.fill(Kp)(Reg(Vec(n, SInt(p.zW.W))))
  val nuReg = Seq.fill(Kp)(Reg(Vec(n, SInt(p.nuW.W))))
  val vReg  = Reg(Vec(n, SInt(p.vW.W)))
  /** vucondat: the last y of each component (the primal iterate), for v = sigma (y + z) - nu */
  val vc    = p.method == "vucondat"
  /** (the cold start puts z there, which may be wider than y) */
  val yRegW = math.max(p.yW, p.zW)
  val yReg  = if (vc) Seq.fill(Kp)(Reg(Vec(n, SInt(yRegW.W)))) else Nil

  /** a 2^k, right shifts rounded like products (the model's shift_by) */
  def shiftBy(a: SInt, k: Int): SInt = if (k >= 0) (a << k).asSInt else FixedOps.shiftRound(a, -k, p.rounding)
  /** a 2^k_c for the shift code c of the row: a multiplexer over the few distinct shifts */
  def shiftByCode(a: SInt, code: UInt, neg: Boolean): SInt = {
    val opts = p.shifts.map(k => shiftBy(a, if (neg) -k else k))
    val w    = opts.map(_.getWidth).max
    WireInit(SInt(w.W), VecInit(opts.map(_.pad(w)))(code))
  }

  // Row tokens: tokN is the next cycle's, so the row memories are addressed a cycle ahead (outputs registered).
  // With chunks > 1 the sequencer's tokens are slots (row k chunk c at k chunks + c); from the tree's output on a
  // stage sees row tokens, valid with a row's last chunk.
  val tokN = ctl.tokN
  val tok0 = RegNext(tokN, 0.U.asTypeOf(tokN))
  val cB   = p.chunkBits
  val kW   = math.max(1, log2Ceil(K))
  /** the row of a slot token */
  def rowK(t: RowToken): UInt = if (cB == 0) t.k else (t.k >> cB).asUInt.pad(kW)(kW - 1, 0)
  def chunkOf(t: RowToken): UInt = t.k(math.max(cB, 1) - 1, 0)
  def rowTok(t: RowToken): RowToken = if (cB == 0) t else {
    val r = Wire(new RowToken(kW, sW))
    r.valid := t.valid && chunkOf(t) === (p.chunks - 1).U
    r.pass0 := t.pass0
    r.first := t.first
    r.k     := rowK(t)
    r.slot  := t.slot
    r
  }
  def slotAt(stage: Int): RowToken = if (stage < 0) tokN else ShiftRegister(tok0, stage, 0.U.asTypeOf(tokN), true.B)
  def tokAt(stage: Int): RowToken = if (stage >= p.stageTree) rowTok(slotAt(stage)) else slotAt(stage)
  val tok1   = slotAt(1)
  val tokSum = tokAt(p.stageSum)
  val tokQ   = tokAt(p.stageQ)
  val tokZ   = tokAt(p.stageZ)
  val tokNu  = tokAt(p.stageN)

  val wPad = VecInit((0 until mPad).map { j =>
    if (j < nw) wCur(j).pad(p.opW) else if (j == nw) (BigInt(1) << b).S(p.opW.W) else 0.S(p.opW.W)
  })
  val vPad = VecInit((0 until mPad).map(j => if (j < n) vReg(j).pad(p.opW) else 0.S(p.opW.W)))

  // accelerated (fast AMA, fast ADMM, fast Vu-Condat): per extrapolated state x the last iteration's x and the
  // candidates x + mom (x - prev), the momentum index and word, the restart test's sum (MomentumLane; one problem)
  val acc      = p.accelerated
  val keys     = if (acc) p.accStates else Seq()
  val prevReg  = keys.map(k => k -> Reg(Vec(n, SInt(p.accCurW(k).W)))).toMap
  val candReg  = keys.map(k => k -> Reg(Vec(n, SInt(p.accW0(k).W)))).toMap
  val momIdx   = RegInit(0.U(log2Ceil(p.momentum.length.max(2)).W))
  val momReg   = RegInit(0.S(p.momW.W))
  val testSum  = RegInit(0.S(p.accW.W))
  val tokM1    = tokAt(p.stageW + p.momLat - 1)
  val enM      = RowToken.enables(tokM1, tokM1.valid && !tokM1.pass0, K)
  val termsNow = Wire(Vec(P, SInt(p.accW.W)))
  val ovfMom   = Wire(Vec(P, Bool()))
  /** per unit, the candidates of lane A (the row) and lane B (a soft pair's state, in its slack's slot) */
  val candA    = keys.map(k => k -> Wire(Vec(P, SInt(p.accW0(k).W)))).toMap
  val candB    = keys.map(k => k -> Wire(Vec(P, SInt(p.accW0(k).W)))).toMap
  val ovfNow = Wire(Vec(P, Bool()))
  val codeW  = math.max(1, log2Ceil(p.shifts.length))
  class Lane extends Bundle {
    val z  = SInt(p.zW.W)
    val nu = SInt(p.nuW.W)
    /** vucondat: the row's y (the cold start: z) */
    val y  = SInt(yRegW.W)
  }
  val laneA = Wire(Vec(P, new Lane)) // the row in the slot
  val laneB = Wire(Vec(P, new Lane)) // the soft state before a slack row
  val dp = Module(new DotProductTree(DotProductParams(lanes, p.coefW, p.opW, p.sumW, b, p.latMul, p.latAdd, p.rounding, p.target)))

  for (u <- 0 until P) {
    val tree = if (u == 0) dp else Module(new DotProductTree(dp.p))
    // second block at K2 = 2^ceil(log2 K): no adder; one problem: a cycle ahead, registered beside the blocks
    val tokR = ctl.tokNN.getOrElse(tokN)
    matRam(u).io.raddr := Cat(tokR.pass0, tokR.k)
    tree.io.inValid := tok1.valid
    tree.io.coef    := matRam(u).io.rdata.asTypeOf(Vec(lanes, SInt(p.coefW.W)))
    // the operand select per multiplier from a copy of tok1.pass0 of its own (an FPGA target): one register would
    // drive every multiplier's operand bits across the device; with chunks, the chunk's operands likewise
    val keep  = p.target != dsp.Target.Generic
    val opSel = KeepReg.copies(tok0.pass0, lanes, keep)
    if (cB == 0) tree.io.op := VecInit((0 until lanes).map(j => Mux(opSel(j), wPad(j), vPad(j))))
    else {
      val chSel = KeepReg.copies(chunkOf(tok0), lanes, keep)
      tree.io.op := VecInit((0 until lanes).map { j =>
        val c = chSel(j)
        Mux(opSel(j), VecInit((0 until p.chunks).map(q => wPad(q * lanes + j)))(c),
          VecInit((0 until p.chunks).map(q => vPad(q * lanes + j)))(c))
      })
    }
    // chunks > 1: the chunks' tree sums accumulate exactly (a word log2(chunks) + 1 bits wider), the row's total
    // saturates to the sum width a cycle later (mpc_cores.admm.model: the same)
    val (rowSum, rowOvf) = if (cB == 0) (tree.io.sum, tree.io.outValid && tree.io.overflow) else {
      val tokT  = slotAt(p.stageTree)
      val accW  = p.sumW + cB + 1
      val accR  = Reg(SInt(accW.W))
      val accOf = Reg(Bool())
      val c0    = chunkOf(tokT) === 0.U
      when(tokT.valid) {
        accR  := Mux(c0, tree.io.sum.pad(accW), accR + tree.io.sum.pad(accW))
        accOf := Mux(c0, tree.io.overflow, accOf || tree.io.overflow)
      }
      val (sat, satOf) = FixedOps.saturate(accR, p.sumW)
      val sumR = Reg(SInt(p.sumW.W))
      sumR := sat
      (sumR, RegNext(accOf || satOf) && tokAt(p.stageSum).valid)
    }

    // Per-row constants and nu, picked at the fetch and carried to the q step.
    val kindRom = VecInit((0 until K).map(k => p.kindAt(u, k).U(2.W)))
    val codeRom = VecInit((0 until K).map(k => p.codeAt(u, k).U(codeW.W)))
    // nu of each slot's row, of the token's problem (an empty slot: 0)
    def nuRow(t: RowToken) = (0 until K).map(k => p.rows(u)(k).map(j => ofSlot(nuReg.map(_(j)), t.slot))
      .getOrElse(0.S(p.nuW.W)))
    val toQ     = p.stageQ - 1
    // The slot's nu (at tok1) through a one-hot select whose decode is registered a stage ahead. Without momentum
    // the select is split: groups of four slots at tok0 into registers, their OR at tok1. A row's nu changes only
    // with its own write, an iteration earlier (and the warm copy, before the first pass, which reads no nu); the
    // momentum's copy into nu comes in the cycle of the next iteration's row 0 at tok0, so with it one stage reads.
    val nuSel =
      if (acc) {
        val hot1 = RegNext(VecInit(UIntToOH(rowK(tok0), K).asBools))
        WireInit(SInt(p.nuW.W), Mux1H(hot1, nuRow(tok1)))
      } else {
        OneHotSelect.registered(RegNext(VecInit(UIntToOH(rowK(tokN), K).asBools)), nuRow(tok0), p.nuW)
      }
    val kindQ   = ShiftRegister(kindRom(rowK(tok1)), toQ)
    val codeQ   = ShiftRegister(codeRom(rowK(tok1)), toQ)
    val nuQ     = ShiftRegister(nuSel, toQ)
    // nu / rho (a rounded shift: a carry chain with nearest rounding), formed a stage after the fetch so that the
    // q step below has one carry chain
    val nuRhoQ  =
      if (toQ >= 1) {
        val nu1   = Reg(SInt(p.nuW.W))
        val code1 = Reg(UInt(codeW.W))
        nu1   := nuSel
        code1 := codeRom(rowK(tok1))
        ShiftRegister(shiftByCode(nu1, code1, neg = true), toQ - 1)
      }
      else shiftByCode(nuQ, codeQ, neg = true)

    // y = M11 v + G~ (w, 1); the first pass stores G~ (w, 1) row by row.
    def gwAddr(t: RowToken): UInt = if (Kp == 1) t.k else Cat(t.slot, t.k.pad(gwKW))
    gwRam(u).io.raddr := gwAddr(tokAt(p.stageSum - 2))
    val gw = gwRam(u).io.rdata.asSInt
    when(tokSum.valid && tokSum.pass0) {
      gwRam(u).io.wen   := true.B
      gwRam(u).io.waddr := gwAddr(tokSum)
      gwRam(u).io.wmask := 1.U
      gwRam(u).io.wdata := rowSum.asUInt
    }
    val (yQ, ofY) = FixedOps.satAddPipelined(rowSum, gw, p.yW, p.latAdd)
    // q = y + nu / rho (0 in the first pass: the cold start projects 0)
    val (qP, ofQ) = FixedOps.satAddPipelined(yQ, nuRhoQ, p.qW, p.latAdd, zero = tokQ.pass0)
    val yP    = ShiftRegister(yQ, p.latAdd)
    val nuP   = ShiftRegister(nuQ, p.latAdd)
    val kindP = ShiftRegister(kindQ, p.latAdd)
    val codeP = ShiftRegister(codeQ, p.latAdd)

    // z = proj(q): box (a free row's box is the z word range) or, on a slack row, the soft pair with the state
    // row of the previous slot.
    bndRam(u).io.raddr := tokAt(p.stageP - 2).k
    val bLo = bndRam(u).io.rdata(p.zW - 1, 0).asSInt
    val bHi = bndRam(u).io.rdata(2 * p.zW - 1, p.zW).asSInt
    val box = Module(new BoxProjection(p.qW, p.zW, p.latAdd))
    box.io.in := qP
    box.io.lo := bLo
    box.io.hi := bHi
    val ofFree = kindP === Free.U && (qP < FixedOps.minOf(p.zW).S || qP > FixedOps.maxOf(p.zW).S)
    val zBox   = ShiftRegister(box.io.out, p.projLat - p.latAdd)
    // the previous slot's row (a soft pair's state when this is its slack)
    def prev[T <: Data](x: T): T = { val r = Reg(chiselTypeOf(x)); r := x; r }
    // (chunks > 1: rows come every chunks cycles, so the previous row's values are held from its own cycle)
    val tokPv = tokAt(p.stageP).valid
    def prevRow[T <: Data](x: T): T = if (cB == 0) prev(x) else RegEnable(x, tokPv)
    val prevQ  = prevRow(qP)
    val prevY  = prevRow(yP)
    val prevNu = prevRow(nuP)
    val kindZ  = ShiftRegister(kindP, p.projLat)
    val codeZ  = ShiftRegister(codeP, p.projLat)
    val (zA, zB, ofZ) = if (p.hasSoft) {
      val softProj = Module(new SoftProjection(p.qW, p.zW, p.latAdd, p.rounding))
      softProj.io.x := prevQ
      softProj.io.d := qP
      softProj.io.c := bLo
      softProj.io.r := bHi
      val isD = ShiftRegister(kindP === SoftD.U, p.projLat) // kindZ === SoftD, decoded before its registers
      (Mux(isD, softProj.io.dOut, zBox), softProj.io.xOut, ShiftRegister(ofFree, p.projLat) || isD && (softProj.io.xOvf || softProj.io.dOvf))
    } else (zBox, zBox, ShiftRegister(ofFree, p.projLat))
    val yZ  = ShiftRegister(yP, p.projLat)
    val nuZ = ShiftRegister(nuP, p.projLat)
    val yZB = ShiftRegister(prevY, p.projLat)
    val nuZB = ShiftRegister(prevNu, p.projLat)

    // nu+ = nu + rho (y - z+), for the row and its partner
    // (from l_A = 2 the difference is registered before its saturation: d and its flag come dLag = 1 stage later)
    val dLag = if (p.latAdd >= 2) 1 else 0
    def dOf(y: SInt, z: SInt): (SInt, Bool) =
      if (dLag == 1) FixedOps.saturate(prev(y -& z), p.dW) else FixedOps.satSub(y, z, p.dW)
    val (dA, ofDA) = dOf(yZ, zA)
    val (dB, ofDB) = dOf(yZB, zB)
    val dAN  = ShiftRegister(dA, p.latAdd - dLag)
    val dBN  = ShiftRegister(dB, p.latAdd - dLag)
    val nuAN = ShiftRegister(nuZ, p.latAdd)
    val nuBN = ShiftRegister(nuZB, p.latAdd)
    val codeN = ShiftRegister(codeZ, p.latAdd)
    val kindN = ShiftRegister(kindZ, p.latAdd)
    val first = tokNu.pass0 // the first pass writes the cold start: z = proj(0), nu = 0
    // nu+ and its flag, l_A stages after tokNu. From l_A = 2 the shift by the row's code is made before the last
    // register of d, and the sum registered before its saturation (FixedOps.satAddPipelined), so that neither the
    // shift's selection nor the saturation shares a cycle with the carry chain.
    val (nuA, nuB, ofNA, ofNB) = if (p.latAdd >= 2) {
      def shifted(d: SInt) = prev(shiftByCode(ShiftRegister(d, p.latAdd - 1 - dLag), ShiftRegister(codeZ, p.latAdd - 1),
        neg = false))
      val (a, fa) = FixedOps.satAddPipelined(nuAN, shifted(dA), p.nuW, p.latAdd, zero = first)
      val (b, fb) = FixedOps.satAddPipelined(nuBN, shifted(dB), p.nuW, p.latAdd, zero = first)
      (a, b, fa, fb)
    } else {
      val (a, fa) = FixedOps.satAdd(nuAN, shiftByCode(dAN, codeN, neg = false), p.nuW)
      val (b, fb) = FixedOps.satAdd(nuBN, shiftByCode(dBN, codeN, neg = false), p.nuW)
      (ShiftRegister(Mux(first, 0.S, a), p.latAdd), ShiftRegister(Mux(first, 0.S, b), p.latAdd),
        ShiftRegister(fa, p.latAdd), ShiftRegister(fb, p.latAdd))
    }
    laneA(u).z  := ShiftRegister(ShiftRegister(zA, p.latAdd), p.latAdd)
    laneA(u).nu := nuA
    laneB(u).z  := ShiftRegister(ShiftRegister(zB, p.latAdd), p.latAdd)
    laneB(u).nu := nuB
    laneA(u).y  := ShiftRegister(ShiftRegister(Mux(tokZ.pass0, zA.pad(yRegW), yZ.pad(yRegW)), p.latAdd), p.latAdd)
    laneB(u).y  := ShiftRegister(ShiftRegister(Mux(tokZ.pass0, zB.pad(yRegW), yZB.pad(yRegW)), p.latAdd), p.latAdd)

    // Accelerated: the momentum lanes take the row's (and its soft partner's) new x at the write stage, with the
    // x the iteration read (the register, before the write) and the last iteration's.
    if (acc) {
      // read at the write stage itself: the row's own write lands at its end, and the operand copy of the last
      // iteration has landed even when the pipeline is a single stage (W = 1)
      val tokWu = tokAt(p.stageW)
      def stateReg(k: String, j: Int): SInt = k match {
        case "y" => yReg(0)(j)
        case "z" => zReg(0)(j)
        case _   => nuReg(0)(j)
      }
      def atSlot(sel: Int => Option[Int], k: String, regOf: Int => SInt) =
        VecInit((0 until K).map(kk => sel(kk).map(regOf).getOrElse(0.S(p.accCurW(k).W))))(tokWu.k)
      val compA = (k: Int) => p.rows(u)(k).filter(j => p.kind(j) != SoftX)
      val compB = (k: Int) => p.rows(u)(k).filter(j => p.kind(j) == SoftD).map(p.partnerOf)
      def curOf(l: Lane, k: String): SInt = k match { case "y" => l.y; case "z" => l.z; case _ => l.nu }
      val lanes = Seq((laneA(u), ShiftRegister(dAN, p.latAdd), compA), (laneB(u), ShiftRegister(dBN, p.latAdd), compB))
      val codeW1 = ShiftRegister(codeN, p.latAdd)
      val tokMv  = tokAt(p.stageW + p.momLat)
      val outs = lanes.take(if (p.hasSoft) 2 else 1).map { case (lane, d, comp) =>
        val m = Module(new MomentumLane(p))
        for ((k, i) <- keys.zipWithIndex) {
          m.io.cur(i)  := curOf(lane, k)
          m.io.prev(i) := atSlot(comp, k, j => prevReg(k)(j))
          m.io.hat(i)  := atSlot(comp, k, j => stateReg(k, j))
        }
        m.io.d    := d
        m.io.code := codeW1
        m.io.mom  := momReg
        val live = VecInit((0 until K).map(kk => comp(kk).nonEmpty.B))(tokMv.k)
        (m.io.cand, Mux(live, m.io.term, 0.S), live && m.io.candOvf)
      }
      val on = tokMv.valid && !tokMv.pass0
      for ((k, i) <- keys.zipWithIndex) {
        candA(k)(u) := outs.head._1(i)
        candB(k)(u) := outs.last._1(i)
      }
      termsNow(u) := Mux(on, outs.map(_._2.pad(p.accW)).reduce(_ +& _)(p.accW - 1, 0).asSInt, 0.S)
      ovfMom(u)   := on && outs.map(_._3).reduce(_ || _)
    } else {
      termsNow(u) := 0.S
      ovfMom(u) := false.B
    }

    // Saturation in a live row of an iteration sets the sticky overflow flag (the first pass: the tree only).
    val kindZs = kindZ
    val liveA  = kindZs =/= SoftX.U // a state row of a soft pair finishes in its slack's slot
    val ofTree = rowOvf
    val tokP   = tokAt(p.stageP)
    val ofYQ   = tokQ.valid && !tokQ.pass0 && ofY || tokP.valid && ofQ
    val liveZ  = tokZ.valid && !tokZ.pass0
    val ofZD   = liveZ && ofZ || ShiftRegister(liveZ && liveA, dLag) && ofDA ||
      ShiftRegister(liveZ && kindZs === SoftD.U, dLag) && ofDB
    // (nu+'s flags come l_A stages after tokNu)
    val ofN    = ShiftRegister(tokNu.valid && !tokNu.pass0 && kindN =/= SoftX.U, p.latAdd) && ofNA ||
      ShiftRegister(tokNu.valid && !tokNu.pass0 && kindN === SoftD.U, p.latAdd) && ofNB
    ovfNow(u) := Seq(ofTree, ofYQ, ofZD, ofN, ovfMom(u)).map(RegNext(_, false.B)).reduce(_ || _)
  }

  // ------------------------------------------------------------------ register writes
  val tokW1 = tokAt(p.stageW - 1)
  /** the method's operand v of component j, and whether it saturated: admm rho z - nu, ama -nu, vucondat
    * sigma (y + z) - nu */
  def vOf(z: SInt, nu: SInt, y: Option[SInt], j: Int): (SInt, Bool) = p.method match {
    case "ama"      => FixedOps.satSub(0.S, nu, p.vW)
    case "vucondat" => FixedOps.satSub(shiftBy(y.get +& z, p.shift(j)), nu, p.vW)
    case _          => FixedOps.satSub(shiftBy(z, p.shift(j)), nu, p.vW)
  }
  // one problem: the value each z register has in the next cycle, for the answer (only a row's own write can
  // change z then: the warm copy comes at a solve's start, the operand copy after an iteration but the last)
  val zAhead = Wire(Vec(n, SInt(p.zW.W)))
  zAhead := zReg(0)
  /** problem q's writes of z and nu: the warm copy, or the lanes of its rows' pipelines */
  def writes(q: Int, warmCopy: Bool, weW: Vec[Bool]): Unit = for (j <- 0 until n) {
    val u = p.unitOf(j)
    val k = p.slotOf(j)
    // the row's own slot, or (soft state) the slot of its slack, one later on the same unit
    val (slot, lane) = if (p.kind(j) == SoftX) (k + 1, laneB(u)) else (k, laneA(u))
    val src = p.warmSource(j)
    when(warmCopy) {
      zReg(q)(j)  := zReg(q)(src)
      nuReg(q)(j) := nuReg(q)(src)
      if (vc) yReg(q)(j) := yReg(q)(src)
    }.elsewhen(weW(slot)) {
      zReg(q)(j)  := lane.z
      if (q == 0) zAhead(j) := lane.z
      nuReg(q)(j) := lane.nu
      if (vc) yReg(q)(j) := lane.y
    }
  }
  val ofV = Wire(Vec(n, Bool()))
  val vNow = if (Kp == 1) {
    val warmNow  = regs.ctrlWarm && regs.warmValid
    when(ctl.take) {
      wReg(0) := frameIn.io.frame
      warmL   := warmNow
    }
    val warmCopy = RegNext(ctl.take && warmNow, false.B)
    writes(0, warmCopy, RowToken.enables(tokW1, tokW1.valid && !(tokW1.pass0 && warmL), K))
    assert(!(ctl.outLoad && (warmCopy || ctl.copyNow)), "AdmmCore: a copy in the cycle before the answer")
    // v for the whole vector in the cycle after an iteration's last write
    ctl.copyNow
  } else {
    for (q <- 0 until Kp) when(ctl.take && frameIn.io.id === q.U) { wReg(q) := frameIn.io.frame }
    // the operands of a turn, loaded as its row 0 reaches tok0 (in use from tok1 on)
    val turn0 = RegNext(tokN.valid && tokN.k === 0.U, false.B)
    for (i <- 0 until nw) when(turn0 && tok0.pass0) { wCur(i) := ofSlot(wReg.map(_(i)), tok0.slot) }
    for (q <- 0 until Kp) writes(q, RegNext(turn0 && tok0.pass0 && mine(tok0, q) && ctl.warmOf(q), false.B),
      RowToken.enables(tokW1, tokW1.valid && mine(tokW1, q) && !(tokW1.pass0 && ctl.warmOf(q)), K))
    turn0 && !tok0.pass0
  }
  // Accelerated: the candidates land at their rows' momentum stage. At the operand copy after an iteration the
  // next x^ is the candidate (the test held) or x itself (restart), prev takes x, the momentum index advances or
  // returns to 0 (the copy after the first pass starts the sequence: x^ = x, index 0). The test: AMA the gradient
  // sum >= 0; ADMM, Vu-Condat the residual below the threshold, which then becomes c - c / 2^10 (restart: the
  // threshold grows by 1 / 2^10; none before the first test of a solve).
  val firstCopy = RegInit(false.B)
  val thr       = RegInit(0.S((p.accW + 1).W))  // below 2^(accW - 1) (1 + 2^-10): one bit more than the sum
  val thrValid  = RegInit(false.B)
  val testOk    = if (p.method == "ama") !testSum(p.accW - 1) else !thrValid || testSum < thr
  val useCand   = !firstCopy && testOk
  def next(k: String, j: Int, now: SInt): SInt = if (keys.contains(k)) Mux(useCand, candReg(k)(j), now) else now
  def nuNext(j: Int): SInt = next("nu", j, ofSlot(nuReg.map(_(j)), tok0.slot))
  def zNext(j: Int): SInt  = next("z", j, ofSlot(zReg.map(_(j)), tok0.slot))
  def yNext(j: Int): SInt  = next("y", j, ofSlot(yReg.map(_(j)), tok0.slot))
  if (acc) {
    for (k <- keys; j <- 0 until n) {
      val u = p.unitOf(j)
      val (slot, c) = if (p.kind(j) == SoftX) (p.slotOf(j) + 1, candB(k)(u)) else (p.slotOf(j), candA(k)(u))
      when(enM(slot)) { candReg(k)(j) := c }
    }
    val momRom = VecInit(p.momentum.map(_.S(p.momW.W)))
    val last   = (p.momentum.length - 1).U
    testSum := testSum + termsNow.reduce(_ +& _)(p.accW - 1, 0).asSInt
    when(ctl.take) {
      firstCopy := true.B
      testSum   := 0.S
      thrValid  := false.B
    }
    when(vNow) {
      for (j <- 0 until n) {
        if (keys.contains("nu")) { nuReg(0)(j) := nuNext(j); prevReg("nu")(j) := nuReg(0)(j) }
        if (keys.contains("z")) { zReg(0)(j) := zNext(j); prevReg("z")(j) := zReg(0)(j) }
        if (keys.contains("y")) { yReg(0)(j) := yNext(j); prevReg("y")(j) := yReg(0)(j) }
      }
      val nextIdx = Mux(firstCopy || !testOk, 0.U, Mux(momIdx === last, momIdx, momIdx + 1.U))
      momIdx    := nextIdx
      momReg    := momRom(nextIdx)
      testSum   := 0.S
      firstCopy := false.B
      if (p.method != "ama") when(!firstCopy) {
        thr      := Mux(testOk, (testSum - (testSum >> EtaShift)).pad(p.accW + 1), thr + (thr >> EtaShift))
        thrValid := true.B
      }
    }
  }
  for (j <- 0 until n) {
    val (v, of) = vOf(zNext(j), nuNext(j),
      if (vc) Some(yNext(j)) else None, j)
    ofV(j) := of
    when(vNow) { vReg(j) := v }
  }
  // the flags of a cycle, registered before they are gathered into the sticky bit
  when(RegNext(ovfNow.asUInt, 0.U).orR || RegNext(Mux(vNow, ofV.asUInt, 0.U), 0.U).orR) { regs.stOvf := true.B }

  // ------------------------------------------------------------------ output: du_0 or all of z
  ctl.answer(m_axis, (s, i) => ofSlot(zReg.map(_(i)), s).pad(p.streamW).asUInt, i => zAhead(i).pad(p.streamW).asUInt,
    n, keep = p.target != dsp.Target.Generic)
  bus.Protocol.streamOut("m_axis", m_axis)

  // ------------------------------------------------------------------ AXI4-Lite data memories (write-only)
  import regs.{dataWrite, wD}
  def region(nm: String): Bool = regs.inRegion(nm)
  val rowW   = math.max(1, log2Ceil(n))
  val unitRom = VecInit((0 until n).map(j => p.unitOf(j).U(math.max(1, log2Ceil(P)).W)))
  val slotRom = VecInit((0 until n).map(j => p.slotOf(j).U(math.max(1, log2Ceil(K)).W)))
  // bounds live in the slot of a box row or of a soft pair's slack
  val bndOkRom = VecInit((0 until n).map(j => (p.kind(j) == Box || p.kind(j) == SoftD).B))
  regs.frameBoxWrites(frameIn, "WBOX", p.wW, nw)
  regs.writes(
    region("WBOX") -> { () => dataWrite(p.wW, regs.ahead("WBOX")(regs.boxOk(nw))) {} },
    region("BND") -> { () =>
      dataWrite(p.zW, regs.ahead("BND")(bndOk)) {
        regs.warmValid := false.B
        warmOk.foreach(_ := false.B)
      }
    },
    (region("MAT_M") || region("MAT_G")) -> { () =>
      dataWrite(p.coefW, Mux(region("MAT_G"), regs.ahead("MAT_G")(matOk(nw + 1)), regs.ahead("MAT_M")(matOk(n)))) {}
    }
  )
  def rowOfBnd(o: UInt): UInt = (o >> 1)(rowW - 1, 0)
  def bndOk(o: UInt): Bool = (o >> 1) < n.U && bndOkRom(rowOfBnd(o))
  def colOf(o: UInt): UInt = if (p.cBits == 0) 0.U else o(p.cBits - 1, 0)
  def rowOfMat(o: UInt): UInt = (o >> p.cBits)(rowW - 1, 0)
  def matOk(cols: Int)(o: UInt): Bool = (o >> p.cBits) < n.U && colOf(o) < cols.U

  // The row units' memory writes: enables, slot and lanes decided a cycle ahead from the early request (the same
  // region, check and fit as the responses above), so that only registers drive the write ports.
  {
    val off = regs.earlyOffset("BND")
    val j   = rowOfBnd(off)
    regs.unitWrites(bndRam, p.zW, u => regs.earlyIn("BND") && bndOk(off) && unitRom(j) === u.U, slotRom(j), off(0))
  }
  {
    require(p.regionSizes.toMap.apply("MAT_M") == p.regionSizes.toMap.apply("MAT_G"), "MAT_M and MAT_G differ in size")
    val isG = regs.earlyIn("MAT_G")
    val off = regs.earlyOffset("MAT_M")
    val j   = rowOfMat(off)
    val ok  = regs.earlyIn("MAT_M") && matOk(n)(off) || isG && matOk(nw + 1)(off)
    // a column's chunk and lane (chunks > 1: the chunk in the slot's low bits)
    val col = colOf(off)
    val (slot, lane) = if (cB == 0) (slotRom(j), col) else {
      val cols = 1 << p.cBits
      val chunkRom = VecInit((0 until cols).map(c => math.min(c / lanes, p.chunks - 1).U(cB.W)))
      val laneRom  = VecInit((0 until cols).map(c => (c % lanes).U(math.max(1, log2Ceil(lanes)).W)))
      (Cat(slotRom(j), chunkRom(col)), laneRom(col))
    }
    regs.unitWrites(matRam, p.coefW, u => ok && unitRom(j) === u.U, Mux(isG, slot +& p.K2.U, slot), lane)
  }
}
