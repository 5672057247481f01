package dgp

import chisel3._
import chisel3.util._
import bus.{AxiLiteIO, AxiStreamIO}
import fixed.{FixedOps, Rounding, SerialDivider}
import linalg.{DotProductParams, DotProductTree}
import mem.InitRam
import shell.{Field, FrameIn, RegMap, Register, SolverRegs}

/** Fixed-point dual gradient projection (iteration (35) of 003) for MPC with input and state constraints; the
  * arithmetic is that of mpc_cores/dgp/model.py, word for word.
  *
  * One row unit of `lanes` multipliers computes a row's dot product chunk by chunk (a row of c columns takes
  * ceil(c / lanes) cycles) from one matrix memory holding the rows of Fe, Lw, K and G. A solve: the first pass
  * (e = Fe w, the bounds lo, hi = lo0, hi0 + Lw w), then per iteration pass K (z = K v + e, v = wy+ - wy-) and pass
  * G (s = G z), whose rows feed the element stage (g, the projected dual step, the sums of the stopping test);
  * the iteration ends in a decision cycle (stop when the test holds or at IMAX). Output: the averaged primal
  * (plain form; a serial divider forms Sz / I) or the last z (accelerated), u0 or all of z, each word clamped to
  * the quantised input box on its way out (the iteration's state unclamped), then a status word
  * (iterations run in bits 15:0, test met 16, input saturated 17, datapath overflow 18) with tlast.
  */
class DgpCore(val p: DgpParams) extends Module {
  override def desiredName = p.moduleName
  import p.{mc, n, nu, nw}
  val W = p.dataW
  val b = p.fracBits
  val acc = p.accelerated

  val s_axis = IO(Flipped(new AxiStreamIO(p.streamW)))
  val m_axis = IO(new AxiStreamIO(p.streamW))
  val s_axil = IO(Flipped(new AxiLiteIO(p.axiAddrW)))

  val itersR = RegInit(0.U(16.W))
  val metR   = RegInit(false.B)
  val regs = new SolverRegs(s_axil, DgpRegs.map(p),
    coreSources = Map("ITERATIONS.COUNT" -> itersR, "ITERATIONS.MET" -> metR.asUInt))
  val frameIn = Module(new FrameIn(p.moduleName + "_x", nw, p.xW, p.streamW, p.xlo.zip(p.xhi)))
  frameIn.io.s_axis <> s_axis
  frameIn.io.hold    := regs.frameHold
  frameIn.io.boxWen  := false.B
  frameIn.io.boxWord := 0.U
  frameIn.io.boxHi   := false.B
  frameIn.io.boxData := 0.S
  when(frameIn.io.sat) { regs.stSat := true.B }
  when(frameIn.io.tlastErr) { regs.stTlast := true.B }
  regs.writes()

  def sat(x: SInt): (SInt, Bool) = FixedOps.saturate(x, W)

  // ------------------------------------------------------------------ state
  // The rows of a pass come in order, so the vectors read row by row are rotating FIFOs read at their head (as the
  // FGM's, Fig. 1 of 002): e, lo, hi, Sz (one step per row of their pass), and the element stage's y, its copy of
  // the operand dual and Sg (one step per row of pass G, the new value entering at the tail). A pass rotates each
  // exactly once round, so between passes element i sits at index i. No row needs a wide multiplexer.
  val wReg = Reg(Vec(nw, SInt(p.xW.W)))
  val e    = Reg(Vec(n, SInt(W.W)))
  val lo   = Reg(Vec(mc, SInt(W.W)))
  val hi   = Reg(Vec(mc, SInt(W.W)))
  val z    = Reg(Vec(n, SInt(W.W)))
  /** the dual y = (y+, y-), upper and lower rows; it survives a solve (the warm start) */
  val yH   = Seq.fill(2)(Reg(Vec(mc, SInt(W.W))))
  /** the operand dual of pass K (accelerated: the extrapolated dual, its candidate, and the element stage's copy;
    * plain: y itself) */
  val wyH  = if (acc) Seq.fill(2)(Reg(Vec(mc, SInt(W.W)))) else yH
  val wycH = if (acc) Seq.fill(2)(Reg(Vec(mc, SInt(W.W)))) else Nil
  val wyE  = if (acc) Seq.fill(2)(Reg(Vec(mc, SInt(W.W)))) else yH
  val sz   = if (acc) None else Some(Reg(Vec(n, SInt(p.sumW.W))))
  val sg   = if (acc) Nil else Seq.fill(2)(Reg(Vec(mc, SInt(p.sumW.W))))
  /** one step of a rotating FIFO: the head leaves, `in` enters at the tail */
  def rotate(v: Vec[SInt], in: SInt): Unit = {
    for (i <- 0 until v.length - 1) v(i) := v(i + 1)
    v(v.length - 1) := in
  }
  val tThr = Reg(SInt(p.sumW.W))
  val kAcc = RegInit(0.U(8.W))
  val betaRom = VecInit(p.beta.map(v => v.S(p.betaW.W)))
  val betaR = Reg(SInt(p.betaW.W))
  val iter  = Reg(UInt(16.W))
  val imax  = Reg(UInt(16.W))
  val solveSat = RegInit(false.B)
  val solveOvf = RegInit(false.B)
  val ovfNow   = WireDefault(false.B)
  when(ovfNow) { solveOvf := true.B; regs.stOvf := true.B }
  // per iteration: the test's violations (plain: some Sg_i > T; accelerated: some g_i > eg), the sums of the gap
  // and of the restart test
  val viol   = RegInit(false.B)
  val gapW   = 2 * W + 8
  val gapAcc = RegInit(0.S(gapW.W))
  val rstAcc = RegInit(0.S(gapW.W))

  // ------------------------------------------------------------------ sequencer
  object St extends ChiselEnum { val idle, issue, gap, decide, out = Value }
  val st = RegInit(St.idle)
  /** the pass being issued: 0 F, 1 K, 2 G */
  val pass    = RegInit(0.U(2.W))
  val addr    = RegInit(0.U(log2Ceil(p.matRows + 1).W))
  val chunk   = RegInit(0.U(8.W))
  val row     = RegInit(0.U(16.W))
  val waitCnt = RegInit(0.U(16.W))
  val cycles  = RegInit(0.U(32.W))
  def chunksOf(ps: UInt): UInt = MuxLookup(ps, p.cF.U)(Seq(1.U -> p.cK.U, 2.U -> p.cG.U))
  def rowsOf(ps: UInt): UInt = MuxLookup(ps, (n + mc).U)(Seq(1.U -> n.U, 2.U -> mc.U))

  val take = st === St.idle && frameIn.io.full
  frameIn.io.take := take
  val warmNow = regs.ctrlWarm && regs.warmValid
  when(take) {
    wReg := frameIn.io.frame
    st := St.issue; pass := 0.U; addr := 0.U; chunk := 0.U; row := 0.U
    iter := 0.U; imax := regs.imaxReg; cycles := 0.U
    solveOvf := false.B
    tThr := p.eg.S; kAcc := 0.U; betaR := betaRom(1)
    viol := false.B; gapAcc := 0.S; rstAcc := 0.S
    for (h <- 0 until 2; i <- 0 until mc) {
      when(!warmNow) { yH(h)(i) := 0.S }
      if (acc) {
        wyH(h)(i) := Mux(warmNow, yH(h)(i), 0.S)
        wyE(h)(i) := Mux(warmNow, yH(h)(i), 0.S)
      }
    }
    sz.foreach(_.foreach(_ := 0.S))
    sg.foreach(_.foreach(_ := 0.S))
  }
  // a frame's saturation belongs to its solve (the frame may arrive while the previous one runs)
  val frameSat = RegInit(false.B)
  when(frameIn.io.sat) { frameSat := true.B }
  when(take) { solveSat := frameSat || frameIn.io.sat; frameSat := false.B } // the last word's pulse may come with take
  when(st =/= St.idle && st =/= St.out) { cycles := cycles + 1.U }

  val issuing   = st === St.issue
  val lastChunk = chunk === (chunksOf(pass) - 1.U)
  val lastRow   = row === (rowsOf(pass) - 1.U)
  when(issuing) {
    addr  := addr + 1.U
    chunk := Mux(lastChunk, 0.U, chunk + 1.U)
    when(lastChunk) { row := Mux(lastRow, 0.U, row + 1.U) }
    when(lastChunk && lastRow) {
      switch(pass) {
        is(0.U) { pass := 1.U }                       // pass K follows the first pass at once
        is(1.U) { st := St.gap; waitCnt := (p.gapK - 1).U }
        is(2.U) { st := St.gap; waitCnt := (p.gapG - 1).U }
      }
    }
  }
  when(st === St.gap) {
    waitCnt := waitCnt - 1.U
    when(waitCnt === 0.U) {
      when(pass === 1.U) { st := St.issue; pass := 2.U }.otherwise { st := St.decide }
    }
  }

  // ------------------------------------------------------------------ row unit
  val matRam = Module(new InitRam(s"${p.moduleName}_mat", p.matRows, p.lanes, p.coefW, p.matInit))
  matRam.io.clock := clock
  matRam.io.wen   := false.B
  matRam.io.waddr := 0.U
  matRam.io.wmask := 0.U
  matRam.io.wdata := 0.U
  matRam.io.raddr := addr
  class Tok extends Bundle {
    val valid = Bool(); val pass = UInt(2.W); val row = UInt(16.W); val first = Bool(); val last = Bool()
  }
  val tok0 = Wire(new Tok)
  tok0.valid := issuing; tok0.pass := pass; tok0.row := row; tok0.first := chunk === 0.U; tok0.last := lastChunk
  def tokAt(d: Int): Tok = ShiftRegister(tok0, d, 0.U.asTypeOf(new Tok), true.B)

  // the operands of a chunk, registered with the RAM read: w (first pass), v = wy+ - wy- (K), z (G)
  def chunked(v: Seq[SInt], cs: Int): Vec[Vec[SInt]] =
    VecInit((0 until cs).map(j => VecInit((0 until p.lanes).map(l => v.lift(j * p.lanes + l).getOrElse(0.S).pad(p.opW)))))
  val wCh  = chunked(wReg, p.cF)(chunk)
  val ypCh = chunked(wyH(0), p.cK)(chunk)
  val ymCh = chunked(wyH(1), p.cK)(chunk)
  val zCh  = chunked(z, p.cG)(chunk)
  val opR = RegNext(VecInit((0 until p.lanes).map { l =>
    MuxLookup(pass, wCh(l))(Seq(1.U -> (ypCh(l) -& ymCh(l))(p.opW - 1, 0).asSInt, 2.U -> zCh(l)))
  }))
  val tree = Module(new DotProductTree(DotProductParams(p.lanes, p.coefW, p.opW, p.accW, b, p.latMul, p.latAdd,
    Rounding.Nearest, p.target)))
  val tok1 = tokAt(1)
  tree.io.inValid := tok1.valid
  tree.io.coef    := matRam.io.rdata.asTypeOf(Vec(p.lanes, SInt(p.coefW.W)))
  tree.io.op      := opR
  val tokT  = tokAt(1 + p.treeLat)
  val accR  = Reg(SInt(p.accW.W))
  when(tokT.valid) { accR := Mux(tokT.first, 0.S, accR) + tree.io.sum }
  val tokR  = tokAt(p.rowLat)
  val rowOk = tokR.valid && tokR.last

  // ------------------------------------------------------------------ row results: first pass and pass K
  val eOf = e(0)
  val (zNew, ofZ) = sat(accR +& eOf)
  val (eNew, ofE) = sat(accR)
  val cIdx = tokR.row - n.U
  val (loNew, ofL) = sat(VecInit(p.lo0.map(_.S(W.W)))(cIdx) +& accR)
  val (hiNew, ofH) = sat(VecInit(p.hi0.map(_.S(W.W)))(cIdx) +& accR)
  when(rowOk && tokR.pass === 0.U) {
    // rows 0..n-1 (e), then n..n+mc-1 (the bounds), in order: each enters its FIFO at the tail
    when(tokR.row < n.U) {
      rotate(e, eNew)
      ovfNow := ofE
    }.otherwise {
      rotate(lo, loNew); rotate(hi, hiNew)
      ovfNow := ofL || ofH
    }
  }
  when(rowOk && tokR.pass === 1.U) {
    z(tokR.row) := zNew
    ovfNow := ofZ
    rotate(e, e(0))
    sz.foreach(s => rotate(s, s(0) + zNew))
  }

  // ------------------------------------------------------------------ pass G: the element stage, upper and lower row
  // E1: g = (s - hi, lo - s)
  val (sNow, ofS) = sat(accR)
  val (gpNow, ofGp) = sat(sNow -& hi(0))
  val (gmNow, ofGm) = sat(lo(0) -& sNow)
  when(rowOk && tokR.pass === 2.U) {
    rotate(lo, lo(0)); rotate(hi, hi(0))
    when(ofS || ofGp || ofGm) { ovfNow := true.B }
  }
  val e1 = RegNext(rowOk && tokR.pass === 2.U, false.B)
  val r1 = RegNext(tokR.row)
  val g1 = RegNext(VecInit(gpNow, gmNow))
  // E2: y_new = clip(wy + g, 0, ud), dy = y_new - y; the sums of the test
  val udRom = VecInit(p.ud.map(_.S(W.W)))
  val idx1  = Seq(r1, r1 + mc.U)
  val wy1   = wyE.map(_(0))
  val yNew1 = (0 until 2).map { h =>
    val t = wy1(h) +& g1(h)
    val u = udRom(idx1(h))
    Mux(t < 0.S, 0.S, Mux(t > u, u, t))(W - 1, 0).asSInt
  }
  val dy1 = (0 until 2).map(h => (yNew1(h) -& yH(h)(0))(W - 1, 0).asSInt)
  when(e1) {
    for (h <- 0 until 2) {
      rotate(yH(h), yNew1(h))                          // plain: also the operand dual
      if (acc) rotate(wyE(h), wyE(h)(0))
      if (!acc) {
        val nv = sg(h)(0) + g1(h)
        rotate(sg(h), nv)
        when(nv > tThr) { viol := true.B }
      }
    }
  }
  if (acc) when(e1 && (g1(0) > p.eg.S || g1(1) > p.eg.S)) { viol := true.B }
  val e2 = RegNext(e1, false.B)
  val r2 = RegNext(r1)
  val yN2 = RegNext(VecInit(yNew1))
  if (acc) {
    val g2  = RegNext(g1)
    val dy2 = RegNext(VecInit(dy1))
    val wy2 = RegNext(VecInit(wy1))
    def prod(a: SInt, c: SInt): SInt = FixedOps.mulRoundPipelined(a, c, p.latMul, b, Rounding.Nearest, p.target)
    val pGap = (0 until 2).map(h => prod(wy2(h), g2(h)))
    val pRst = (0 until 2).map(h => prod(g2(h), dy2(h)))
    val pExt = (0 until 2).map(h => prod(betaR, dy2(h)))
    val e3  = ShiftRegister(e2, p.latMul, false.B, true.B)
    val r3  = ShiftRegister(r2, p.latMul)
    val yN3 = ShiftRegister(yN2, p.latMul)
    when(e3) {
      gapAcc := gapAcc + pGap(0) + pGap(1)
      rstAcc := rstAcc + pRst(0) + pRst(1)
      for (h <- 0 until 2) {
        // the extrapolated dual stays in [0, ud] (so the gap test bounds V(z) - V*)
        val t = yN3(h) +& pExt(h)
        val u = udRom(r3 + (h * mc).U)
        wycH(h)(r3) := Mux(t < 0.S, 0.S, Mux(t > u, u, t))(W - 1, 0).asSInt
      }
    }
  }

  // ------------------------------------------------------------------ decision
  val gapOk   = gapAcc >= (-p.eV).S
  val stop    = !viol && (if (acc) gapOk else true.B)
  val restart = rstAcc < 0.S
  val finish  = stop || iter + 1.U === imax
  val outIdx  = RegInit(0.U(16.W))
  when(st === St.decide) {
    viol := false.B; gapAcc := 0.S; rstAcc := 0.S
    tThr := tThr + p.eg.S
    if (acc) {
      for (h <- 0 until 2; i <- 0 until mc) {
        val next = Mux(restart, yH(h)(i), wycH(h)(i))
        wyH(h)(i) := next
        wyE(h)(i) := next
      }
      val kNew = Mux(restart, 0.U, Mux(kAcc === 255.U, 255.U, kAcc + 1.U))
      kAcc  := kNew
      betaR := betaRom(Mux(kNew === 255.U, 255.U, kNew + 1.U))
    }
    when(finish) {
      st := St.out; outIdx := 0.U
      itersR := iter + 1.U; metR := stop
      regs.solveDone(cycles + 1.U)
    }.otherwise {
      st := St.issue; pass := 1.U; addr := p.baseK.U; iter := iter + 1.U
    }
  }

  // ------------------------------------------------------------------ output
  /** the status word follows the last of the nu (n with OUT_ALL) solution words */
  val statusNow = outIdx === Mux(regs.ctrlOutAll, n.U, nu.U)
  val statusWord = Cat(solveOvf, solveSat, metR, itersR)
  // the output words are clamped to the quantised input box [outLo_i, outHi_i] (one comparator pair per output word
  // position, against constants) and registered: only the output, the iteration's z and Sz stay unclamped
  def clampAt(x: SInt, i: Int): SInt = {
    val l = p.outLo(i).S(W.W); val h = p.outHi(i).S(W.W)
    Mux(x < l, l, Mux(x > h, h, x))
  }
  val word = Reg(SInt(W.W))
  val wordOk = Wire(Bool())
  if (acc) {
    // z is final from the decision cycle on: word 0 is loaded there, word i + 1 when word i leaves
    val zc = VecInit((0 until n).map(i => clampAt(z(i), i)))
    val outNext = RegInit(0.U(16.W))
    when(st === St.decide && finish) { word := zc(0); outNext := 1.U }
    when(m_axis.fire) { word := zc(outNext); outNext := outNext + 1.U }
    wordOk := true.B
  } else {
    // zbar_i = floor((2 Sz_i + I) / (2 I)): Sz / I rounded to nearest
    val div = Module(new SerialDivider(p.divW, 18))
    val have = RegInit(false.B)
    div.io.start := st === St.out && !have && !div.io.busy && !div.io.done && !statusNow
    div.io.x := (sz.get(outIdx) << 1) +& itersR.zext
    div.io.d := itersR << 1
    val q = div.io.q(W - 1, 0).asSInt
    val qc = VecInit((0 until n).map(i => clampAt(q, i)))(outIdx)
    when(div.io.done) { have := true.B; word := qc }
    when(m_axis.fire) { have := false.B }
    wordOk := have
  }
  m_axis.tvalid := st === St.out && (statusNow || wordOk)
  m_axis.tdata  := Mux(statusNow, statusWord.pad(p.streamW), word.pad(p.streamW).asUInt)
  m_axis.tlast  := statusNow
  when(m_axis.fire) {
    outIdx := outIdx + 1.U
    when(statusNow) { st := St.idle }
  }
  bus.Protocol.streamOut("m_axis", m_axis)
  regs.busy := st =/= St.idle || frameIn.io.full || frameIn.io.partial || s_axis.fire
}

/** The register map of a DGP core: the shared registers and ITERATIONS; the data are fixed at generation. */
object DgpRegs {
  val ITERATIONS = SolverRegs.FirstCoreReg

  def map(p: DgpParams): RegMap = {
    val shared = SolverRegs.registers("DGP1",
      config0 = Seq(Field.const("n", 0, 16, p.n, "decision variables n = N nu"),
        Field.const("m", 16, 16, 2 * p.mc, "one-sided constraints (dual words)")),
      config1 = Seq(Field.const("nw", 0, 16, p.nw, "parameter words per solve, w = (x, r)"),
        Field.const("frac_bits", 16, 8, p.fracBits, "fraction bits of the data and stream words"),
        Field.const("nu", 24, 8, p.nu, "inputs per stage")),
      ctrl = SolverRegs.ctrlFields(p.warmDefault, p.outAllDefault, "u0 (nu words)",
        warmText = "start from the previous solve's dual (unshifted) when STATUS.WARM_VALID, else from y = 0"),
      status = SolverRegs.statusFields(unused = Set("WRITE_REJECTED")),
      cyclesPerIteration = p.cyclesPerIteration, imaxDefault = p.imaxDefault,
      lastCycles = "cycles of the last solve, first pass to its decision cycle")
    val its = Register("ITERATIONS", ITERATIONS, "the last solve's iterations", Seq(
      Field.status("COUNT", 0, 16, "iterations run by the last solve"),
      Field.status("MET", 16, 1, "the last solve stopped at the test ((32c) of 003; accelerated: with the gap test)")))
    RegMap(p.moduleName, s"DGP core ${p.moduleName}: control and status; the problem data are fixed at generation. " +
      SolverRegs.rules, shared :+ its, Nil)
  }
}
