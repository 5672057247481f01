package dgp

import chisel3._
import chisel3.util._
import bus.{AxiLiteIO, AxiStreamIO}
import fixed.{FixedOps, Rounding}
import linalg.{DotProductParams, DotProductTree}
import dsp.Target
import mem.{InitRam, KeepReg}
import shell.{Field, FrameIn, RegMap, Register, SolverRegs}

/** Fixed-point dual gradient projection (iteration (35) of 003) for MPC with input and state constraints; the
  * arithmetic is that of mpc_cores/dgp/model.py, word for word.
  *
  * P row units of `lanes` multipliers each compute rows' dot products chunk by chunk (a round of rows takes a cycle
  * per chunk with a nonzero coefficient in one of them, at most ceil(c / lanes) for c columns); unit u takes the
  * rows u, u + P, ... of every pass from a matrix memory of its own holding its rows of Fe, Lb, K and G, all units
  * reading the same address and the same operand chunk. A solve: the
  * first pass (e = Fe w, then the bounds lo, hi = lo0, hi0 + Lb w, relative to G e), then per iteration pass K
  * (z = K v + e, v = wy+ - wy-) and pass G (s = G (z - e)), whose rows feed each unit's element stage (g, the
  * projected dual step, the sums of the stopping test); the iteration ends in a decision cycle (stop when the test
  * holds or at IMAX), from the units' sums added in registered levels. A zero start's first iteration (z = e, s = 0)
  * runs the element stage on the first pass's bound rows instead of passes K and G. Output: the averaged primal
  * (plain form; a serial divider forms Sz / I) or the last z (accelerated), u0 or all of z, each word clamped to the
  * quantised input box on its way out (the iteration's state unclamped), then a status word (iterations run in bits
  * 15:0, test met 16, input saturated 17, datapath overflow 18) with tlast.
  */
class DgpCore(val p: DgpParams) extends Module with DgpUnitOps {
  override def desiredName = p.moduleName
  import p.{mc, n, nu, nw, rK, rG}
  val P = p.units
  val W = p.dataW
  val b = p.fracBits
  val acc = p.accelerated

  val s_axis = IO(Flipped(new AxiStreamIO(p.streamW)))
  val m_axis = IO(new AxiStreamIO(p.streamW))
  val s_axil = IO(Flipped(new AxiLiteIO(p.axiAddrW)))

  val itersR = RegInit(0.U(16.W))
  val metR   = RegInit(false.B)
  val zeroR  = RegInit(false.B)
  val regs = new SolverRegs(s_axil, DgpRegs.map(p),
    coreSources = Map("ITERATIONS.COUNT" -> itersR, "ITERATIONS.MET" -> metR.asUInt,
      "ITERATIONS.ZERO_START" -> zeroR.asUInt))
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
  /** per unit, FPGA target, P > 1: each unit's registers take their controls and operands from kept copies of
    * their own (mem.KeepReg), so that no register drives all units across the device */
  val split = P > 1 && p.target != Target.Generic
  /** an FPGA target: kept copies of the controls per lane and per group of rows */
  val fpga  = p.target != Target.Generic

  // ------------------------------------------------------------------ state
  // The vectors read row by row are, per unit, rotating FIFOs read at their head (as the FGM's, Fig. 1 of 002):
  // e and Sz (one step per row of pass K), lo, hi, y, the element stage's copy of the operand dual and Sg (one step
  // per row of pass G, the new value entering at the tail). Each FIFO is read and rotated at one pipeline stage
  // only, and a pass rotates it exactly once round, so between passes unit u's element k is row k P + u. No row
  // needs a wide multiplexer. The vectors read whole (the operand chunks of w, the dual and z; the output) are
  // flat: row i of unit u's FIFOs is element i of them.
  val wReg = Reg(Vec(nw, SInt(p.xW.W)))
  val eU   = Seq.fill(P)(Reg(Vec(rK, SInt(W.W))))
  /** the accelerated form's dual and bounds in block RAM (DgpParams.ramState): the FIFOs of y, the extrapolated
    * dual, its candidate, lo and hi give way to per-unit memories (below) and to two flat FIFOs of wy+ - wy- */
  val ram = acc && p.ramState
  val loU  = if (ram) Nil else Seq.fill(P)(Reg(Vec(rG, SInt(W.W))))
  val hiU  = if (ram) Nil else Seq.fill(P)(Reg(Vec(rG, SInt(W.W))))
  /** z, per unit (row k P + u is unit u's element k after pass K), and its flat view */
  val zU   = Seq.fill(P)(Reg(Vec(rK, SInt(W.W))))
  /** the dual y = (y+, y-), upper and lower rows; it survives a solve (the warm start) */
  val yU   = if (ram) Nil else Seq.fill(2, P)(Reg(Vec(rG, SInt(W.W))))
  /** accelerated: the extrapolated dual, per unit; plain: y itself. The element stage rotates it once round in
    * pass G, so in pass K, which reads it as the operand, unit u's element k is row k P + u */
  val wyEU = if (ram) Nil else if (acc) Seq.fill(2, P)(Reg(Vec(rG, SInt(W.W)))) else yU
  /** accelerated: the extrapolated dual's candidate, per unit, entering row by row at the tail */
  val wycU = if (acc && !ram) Seq.fill(2, P)(Reg(Vec(rG, SInt(W.W)))) else Nil
  /** ram: per unit, pass K's operand v = wy+ - wy- of y (vY) and of the candidate (vC), entering at the tail as y
    * and the candidate do (so that between passes unit u's element k is row k P + u) */
  val vYU  = if (ram) Seq.fill(P)(Reg(Vec(rG, SInt(p.opW.W)))) else Nil
  val vCU  = if (ram) Seq.fill(P)(Reg(Vec(rG, SInt(p.opW.W)))) else Nil
  val szU  = if (acc) Nil else Seq.fill(P)(Reg(Vec(rK, SInt(p.sumW.W))))
  val sgU  = if (acc) Nil else Seq.fill(2, P)(Reg(Vec(rG, SInt(p.sumW.W))))
  val z     = flat(zU, n)
  /** the operand dual of pass K, flat */
  val wyOp: Seq[Seq[SInt]] = wyEU.map(flat(_, mc))
  val tThr = Reg(SInt(p.sumW.W))
  val kAcc = RegInit(0.U(8.W))
  val betaRom = VecInit(p.beta.map(x => x.S(p.betaW.W)))
  val betaR = Reg(SInt(p.betaW.W))
  val iter  = Reg(UInt(16.W))
  val imax  = Reg(UInt(16.W))
  /** the stored dual y is all zero (the element stage's flags, taken at every decision) */
  val yZero  = RegInit(true.B)
  /** a zero start: the solve's starting dual is all zero (a cold start, or a warm one from a zero y), so its first
    * iteration's z is e, which the first pass writes to z with e, and s = G (z - e) is 0: its passes K and G are
    * skipped, the element stage taking the first pass's bound rows */
  val zSolve = RegInit(false.B)
  /** zSolve while the first pass issues (its rows' tokens carry it) */
  val zTable = RegInit(false.B)
  val solveSat = RegInit(false.B)
  val solveOvf = RegInit(false.B)
  /** per unit, the overflow flags of its stages (each a condition of one cycle) */
  val ovfFlags = Seq.fill(P)(scala.collection.mutable.ArrayBuffer[Bool]())
  // per iteration and unit: the test's violations (plain: some Sg_i > T; accelerated: some g_i > eg), the sums of
  // the gap and of the restart test
  val gapW   = 2 * W + 8
  val violU  = RegInit(VecInit(Seq.fill(P)(false.B)))
  /** per iteration and unit: some row of y_new is nonzero */
  val nzU    = RegInit(VecInit(Seq.fill(P)(false.B)))
  val gapU   = RegInit(VecInit(Seq.fill(P)(0.S(gapW.W))))
  val rstU   = RegInit(VecInit(Seq.fill(P)(0.S(gapW.W))))
  /** the gap sum's start per unit: ram, unit 0's at eV, so that the test gap >= -eV is the sum's sign (no compare's
    * carry chain before the decision); else 0 */
  def gap0(u: Int): SInt = if (ram && u == 0) p.eV.S(gapW.W) else 0.S

  // ------------------------------------------------------------------ sequencer
  // one-hot: idle, issue, gap (the pipeline's wait after a pass, or after a zero start's first pass), decide and out
  // (the answer leaving), so that no condition decodes a state word
  val sIdle = RegInit(true.B)
  val Seq(sIssue, sGap, sDecide, sOut) = Seq.fill(4)(RegInit(false.B))
  val addr    = RegInit(0.U(log2Ceil(p.matRows + 1).W))
  // The issue slot at addr: its chunk, whether it is its round's first and last (DgpParams.slots) and whether it
  // ends its pass, registers loaded with addr. The next two slots' bits wait in registers (nx1, nx2), nx2 loaded from
  // a table of the slot three ahead (the jumps load constants), so that neither the operand select, the round's
  // count, the sequencer nor the lanes' copies wait on the table
  private val layout = new DgpLayout(p)
  import layout.{bitsOf, chunkW, slotBits}
  val chunk   = RegInit(slotBits.head._1.U(chunkW.W))
  val firstC  = RegInit(true.B)
  val lastC   = RegInit(slotBits.head._3.B)
  val endC    = RegInit(slotBits.head._4.B)
  private val slotAhead = VecInit((0 to p.matRows).map(a => bitsOf(a + 3)))
  val nx1 = RegInit(bitsOf(1))
  val nx2 = RegInit(bitsOf(2))
  // chunk and pass are set through their next values (chunkD, passD), from which each operand lane keeps copies
  val chunkD  = WireDefault(UInt(chunkW.W), chunk)
  /** the pass being issued, one-hot (F when neither): pass K, pass G */
  val Seq(pK, pG) = Seq.fill(2)(RegInit(false.B))
  val (pKD, pGD) = (WireDefault(pK), WireDefault(pG))
  /** the pass as the tokens and the lanes carry it: 0 F, 1 K, 2 G */
  val pass  = Cat(pG, pK)
  val passD = Cat(pGD, pKD)
  chunk := chunkD
  pK := pKD; pG := pGD
  /** ram: pass K's operand dual (DgpParams.ramState) is y (a start; after a restart), else the candidate; set
    * through its next value, from which each lane keeps copies */
  val opY  = RegInit(true.B)
  val opYD = WireDefault(opY)
  opY := opYD
  // The chunk of a jump's slot is loaded ahead, not by the jump (whose condition comes late in its cycle): the
  // first slot's while idle (a take jumps there), pass K's first slot's in the gap before the decision and in the
  // decision (the next iteration jumps there); outside the issue and these, chunk holds
  when(sIdle) { chunkD := slotBits(0)._1.U; pKD := false.B; pGD := false.B }
  when((sGap && pG) || sDecide) { chunkD := slotBits(p.baseK)._1.U }
  def jump(a: Int): Unit = {
    addr := a.U; firstC := slotBits(a)._2.B; lastC := slotBits(a)._3.B
    endC := slotBits(a)._4.B; nx1 := bitsOf(a + 1); nx2 := bitsOf(a + 2)
  }
  /** the round of rows within the pass (at most rK + rG - 1, in the first pass) */
  private val roundW = log2Ceil(rK + rG + 1)
  val round   = RegInit(0.U(roundW.W))
  private val gaps = Seq(p.gapZ, p.gapK, p.gapG)
  val waitCnt = RegInit(0.U(log2Ceil(gaps.max + 1).W))
  /** the gap's last cycle: waitCnt === 0, registered as the count is loaded or stepped */
  val gapEnd  = RegInit(false.B)
  val cycles  = RegInit(0.U(32.W))


  // the take decided a cycle ahead, a flip-flop (it loads w, the sequencer and the frame buffer)
  val take = RegInit(false.B)
  take := sIdle && frameIn.io.full && !take
  frameIn.io.take := take
  val warmNow = regs.ctrlWarm && regs.warmValid
  val zeroNow = !warmNow || yZero
  // The start's resets act a cycle after the take, per unit from its own copies; those of the duals and sums (and
  // the warm start) a cycle later, per group of rowGroup rows from copies of their own: the first pass's products
  // read none of them, a zero start's element stage reads the duals rowLat + 3 cycles after its first issue at the
  // earliest, and pass K's first operand select comes at least two cycles after the take
  val startU = unitRegs(take)
  val warmU  = if (ram) Nil else unitRegs(warmNow)
  val startG = if (ram) Nil else groupRegs(startU, rG)
  /** the start's clear of the duals (a cold start), a flip-flop per group of rows: their resets need no gate */
  val clearG = if (ram) Nil else groupRegs(startU.zip(warmU).map { case (s, w) => s && !w }, rG)
  val shiftG = if (ram && p.shift) groupRegs(startU, rG) else Nil
  val startGK = if (acc) Nil else groupRegs(startU, rK)
  val zsU    = if (acc) Nil else unitRegs(zSolve)
  when(take) {
    wReg := frameIn.io.frame
    sIdle := false.B; sIssue := true.B; jump(0); round := 0.U
    iter := 0.U; imax := regs.imaxReg; cycles := 0.U
    solveOvf := false.B
    tThr := p.eg.S; kAcc := 0.U; betaR := betaRom(1)
    zSolve := zeroNow; zTable := zeroNow
    opYD := true.B
  }
  /** the shifted warm start: per unit, the solve's first iteration (from the start to the first decision), whose
    * element stage takes y = wy (the start makes them equal), so that the start shifts the operand dual only */
  val firstU = if (p.shift) Seq.fill(P)(RegInit(false.B)) else Nil
  for (u <- 0 until P) {
    when(startU(u)) { violU(u) := false.B; nzU(u) := false.B; gapU(u) := gap0(u); rstU(u) := 0.S }
    firstU.lift(u).foreach(f => when(startU(u)) { f := true.B })
    // ram, the shifted warm start: vY shifted a stage within the unit (DgpParams.shiftElem) at every start, pass K's
    // operand of a warm start's first iteration (a zero start skips that pass, and its element stage rewrites vY)
    if (ram && p.shift) for (k <- 0 until rG) when(shiftG(u)(k / rowGroup)) {
      vYU(u)(k) := (if (p.shiftElem(u, k) >= 0) vYU(u)(p.shiftElem(u, k)) else 0.S)
    }
    if (!ram) for (k <- 0 until rG; h <- 0 until 2) {
      when(startG(u)(k / rowGroup)) {
        // the warm start: the operand dual from the dual kept, shifted a stage with p.shift (y itself is left as it
        // is: the first iteration's dy takes the operand dual, which a start makes equal to y, firstU)
        if (acc) wyEU(h)(u)(k) := (if (p.shift) layout.shifted(yU, h, u, k) else yU(h)(u)(k))
        if (!acc) sgU(h)(u)(k) := 0.S
      }
      when(clearG(u)(k / rowGroup)) {
        yU(h)(u)(k) := 0.S
        if (acc) wyEU(h)(u)(k) := 0.S
      }
    }
    szU.lift(u).foreach(s => for (k <- 0 until rK) when(startGK(u)(k / rowGroup)) { s(k) := 0.S })
  }
  // a frame's saturation belongs to its solve (the frame may arrive while the previous one runs)
  val frameSat = RegInit(false.B)
  when(frameIn.io.sat) { frameSat := true.B }
  when(take) { solveSat := frameSat || frameIn.io.sat; frameSat := false.B } // the last word's pulse may come with take
  when(!sIdle && !sOut) { cycles := cycles + 1.U }

  val issuing = sIssue
  // the gap's count loads in every issue cycle with the gap of the pass being issued (the gap after pass F is a zero
  // start's), so that the pass's end needs no condition of its own; it counts down in the gap
  private def byPass(f: Int => Data): Data = Mux(pK, f(p.gapK), Mux(pG, f(p.gapG), f(p.gapZ)))
  when(issuing) { waitCnt := byPass(g => (g - 1).U); gapEnd := byPass(g => (g == 1).B) }
  when(sGap) { waitCnt := waitCnt - 1.U; gapEnd := waitCnt === 1.U }
  when(issuing) {
    addr   := addr + 1.U
    chunkD := nx1(chunkW + 2, 3)
    firstC := nx1(2)
    lastC  := nx1(1)
    endC   := nx1(0)
    nx1    := nx2
    nx2    := slotAhead(addr)
    when(lastC) { round := Mux(endC, 0.U, round + 1.U) }
    // pass K follows the first pass at once; on a zero start, the decision after gapZ (its element stage takes the
    // bound rows); passes K and G end in their gaps
    when(endC) {
      when(!pK && !pG) { zTable := false.B; pKD := !zTable; pGD := zTable }
      when(pK || pG || zTable) { sIssue := false.B; sGap := true.B }
    }
  }
  val toDecide = sGap && gapEnd && !pK
  when(sGap && gapEnd) {
    sGap := false.B
    when(pK) { sIssue := true.B; pKD := false.B; pGD := true.B }.otherwise { sDecide := true.B }
  }
  /** the decision cycle, per unit (registered from the cycle before) */
  val decideU = unitRegs(toDecide)

  // ------------------------------------------------------------------ row units
  // Issue (cycle 0): the matrix address and the operand chunk in the sequencer's registers. Cycle 1: the chunk and
  // the pass in copies at each lane, which selects its word of each vector (registered). Cycle 2: the address in
  // copies beside each memory's blocks (the memory's read); each lane selects by the pass (pass K: the two duals'
  // words subtracted), registered. Cycle 3: the operand chunk copied to each unit, the memory's data. Cycle 4: the
  // memory's output register and the unit's copy of the chunk: the tree's inputs.
  /** the address a cycle after its issue: the memories register it in copies beside their blocks */
  val addrR = RegNext(addr)
  val matRam = (0 until P).map { u =>
    val r = Module(new InitRam(s"${p.moduleName}_mat$u", p.matRows, p.lanes, p.coefW, p.matInit(u), outReg = true,
      ecp5 = p.target == Target.Ecp5 && p.matRows <= 1024, raddrAhead = true))
    r.io.clock := clock
    r.io.wen   := false.B
    r.io.waddr := 0.U
    r.io.wmask := 0.U
    r.io.wdata := 0.U
    r.io.raddr := addrR
    r
  }
  class Tok extends Bundle {
    val valid = Bool(); val pass = UInt(2.W); val round = UInt(roundW.W); val first = Bool(); val last = Bool()
    /** a zero start's first pass */
    val zs = Bool()
  }
  val tok0 = Wire(new Tok)
  tok0.valid := issuing; tok0.pass := pass; tok0.round := round; tok0.first := firstC; tok0.last := lastC
  tok0.zs := zTable
  def tokAt(d: Int): Tok = ShiftRegister(tok0, d, 0.U.asTypeOf(new Tok), true.B)
  /** the token at stage `d` (>= 1) per unit: split, a kept copy each of the token a stage earlier */
  def unitTok(d: Int): Seq[Tok] = if (split) Seq.fill(P)(KeepReg(tokAt(d - 1))) else Seq.fill(P)(tokAt(d))

  // the operand chunk: w (first pass), wy+ - wy- (K), z - e (G). Each lane selects its word of each vector in cycle
  // 1 by copies of its own of the chunk and the pass (FPGA targets: kept registers, loaded from kept copies of a
  // group of lanes, which the next values load), so that no register or decoder drives every lane; the words are
  // registered where they are read (a lane's words of z, e and the duals belong to one unit when P divides the
  // lanes), and the subtractions and the pass's select follow in cycle 2 (e rotates in the first pass and pass K
  // only, so in pass G its flat view is in row order, as z's)
  /** lanes per first-level copy of the chunk and the pass */
  private val laneGroup = 4
  private def laneCopies[T <: Data](next: T, now: T): Seq[T] =
    if (fpga) {
      val groups = Seq.fill((p.lanes + laneGroup - 1) / laneGroup)(KeepReg(next))
      (0 until p.lanes).map(l => KeepReg(groups(l / laneGroup)))
    } else Seq.fill(p.lanes)(RegNext(now))
  val chunkL = laneCopies(chunkD, chunk)
  val passL  = laneCopies(passD, pass)
  /** lane l's word of the chunk: x(j lanes + l) at chunk j */
  def laneWord(x: Seq[SInt], cs: Int, l: Int): SInt =
    VecInit((0 until cs).map(j => x.lift(j * p.lanes + l).getOrElse(0.S).pad(p.opW)))(chunkL(l))
  val zwR = RegNext(VecInit((0 until p.lanes).map(l => laneWord(z, p.cG, l))))
  val ewR = RegNext(VecInit((0 until p.lanes).map(l => laneWord(flat(eU, n), p.cG, l))))
  val ypR = if (ram) null else RegNext(VecInit((0 until p.lanes).map(l => laneWord(wyOp(0), p.cK, l))))
  val ymR = if (ram) null else RegNext(VecInit((0 until p.lanes).map(l => laneWord(wyOp(1), p.cK, l))))
  /** ram: pass K's operand word of each lane, wy+ - wy- selected from the flat differences in cycle 1 */
  val vR = if (!ram) null else {
    val opYL = laneCopies(opYD, opY)
    val (vY, vC) = (flat(vYU, mc), flat(vCU, mc))
    RegNext(VecInit((0 until p.lanes).map(l => Mux(opYL(l), laneWord(vY, p.cK, l), laneWord(vC, p.cK, l)))))
  }
  val wwR = RegNext(VecInit((0 until p.lanes).map(l => laneWord(wReg, p.cF, l))))
  val opR = RegNext(VecInit((0 until p.lanes).map { l =>
    val pl = RegNext(passL(l))
    Mux(pl === 2.U, (zwR(l) -& ewR(l))(p.opW - 1, 0).asSInt, Mux(pl === 1.U,
      if (ram) vR(l) else (ypR(l) -& ymR(l))(p.opW - 1, 0).asSInt, wwR(l)))
  }))
  val opU  = KeepReg.copies(opR, P, split)
  val tokTU = unitTok(4 + p.treeLat)
  val tokRU = unitTok(p.rowLat)
  /** a zero start's bound rows at the element stage's entry, a stage after their sums */
  val tokZU = unitTok(p.rowLat + 1)
  val accR  = Seq.fill(P)(Reg(SInt(p.accW.W)))
  val tok4  = tokAt(4)
  val tree = (0 until P).map { u =>
    val t = Module(new DotProductTree(DotProductParams(p.lanes, p.coefW, p.opW, p.accW, b, p.latMul, p.latAdd,
      Rounding.Nearest, p.target)))
    t.io.inValid := tok4.valid
    t.io.coef    := matRam(u).io.rdata.asTypeOf(Vec(p.lanes, SInt(p.coefW.W)))
    t.io.op      := opU(u)
    when(tokTU(u).valid) { accR(u) := Mux(tokTU(u).first, 0.S, accR(u)) + t.io.sum }
    t
  }

  // ------------------------------------------------------------------ per unit: row results and the element stage
  // the bounds' constant parts by the first pass's round (rounds rK.. are the bounds' rows), the dual box by pass
  // G's round and (a zero start's element stage) by the first pass's
  val lo0U = layout.lo0U
  val hi0U = layout.hi0U
  val udU  = layout.udU
  val udZ  = layout.udZ
  /** the shifted warm start: per half and unit, whether a row's word is live, by pass G's round and by the first's */
  val liveU = layout.liveU
  val liveZ = layout.liveZ
  /** a row's new dual words are nonzero where they count for the next start's zero test (E3): with the shifted warm
    * start, only the live words (`live`, the row's bits carried along the element stage) */
  def nonzero(yN: Vec[SInt], live: Option[Vec[Bool]]): Bool = live match {
    case Some(l) => (yN(0) =/= 0.S && l(0)) || (yN(1) =/= 0.S && l(1))
    case None    => yN(0) =/= 0.S || yN(1) =/= 0.S
  }
  /** accelerated: per unit, the rows' restart and the extrapolated dual's writes */
  val restartU = Wire(Vec(P, Bool()))
  /** per unit, a condition on the token at stage `d` (the row result stage by default), registered from the stage
    * before (a kept copy each when split): the FIFOs' rotate enables come from flip-flops */
  def rowFlag(f: Tok => Bool, d: Int = p.rowLat): Seq[Bool] = {
    val pre = tokAt(d - 1)
    val c = pre.valid && pre.last && f(pre)
    if (split) Seq.fill(P)(KeepReg(c)) else Seq.fill(P)(RegNext(c, false.B))
  }
  val isE: Tok => Bool = t => t.pass === 0.U && t.round < rK.U    // first pass, a row of Fe
  val isB: Tok => Bool = t => t.pass === 0.U && t.round >= rK.U   // first pass, a row of Lb
  val isK: Tok => Bool = _.pass === 1.U
  val isG: Tok => Bool = _.pass === 2.U
  /** a zero start's bound row: it feeds the element stage a stage after its sum (s = 0), as a row of pass G */
  val isZ: Tok => Bool = t => isB(t) && t.zs
  val rowEU  = rowFlag(isE)
  /** pass K's rows a stage after their sums: z enters its FIFO */
  val rowZKU = rowFlag(isK, p.rowLat + 1)
  val rowGU  = rowFlag(isG)
  val rowZU  = rowFlag(isZ, p.rowLat + 1)
  /** the last chunk of a valid row at token stage `d` that meets `f` */
  def rowAt(d: Int, f: Tok => Bool): Bool = { val t = tokAt(d); t.valid && t.last && f(t) }
  /** per unit and group of rows of a FIFO of `len`, condition `c` (on the tokens two stages earlier) as flip-flops:
    * kept copies per group (FPGA targets), loaded from kept copies per unit; the FIFOs' rotate enables, no register
    * driving more than a group */
  def enables(len: Int, c: Bool): Seq[Seq[Bool]] =
    groupRegs(if (fpga) Seq.fill(P)(KeepReg(c)) else Seq.fill(P)(RegNext(c, false.B)), len)
  /** the condition `f` on the token at stage `d` */
  def rowEnables(d: Int, len: Int, f: Tok => Bool): Seq[Seq[Bool]] = enables(len, rowAt(d - 2, f))
  /** the element stage's rows at its stage `d` (a pass G row's sum at rowLat): pass G's rows, and a zero start's
    * bound rows, which run a stage behind (their tokens a stage further on) */
  def elementEnables(d: Int, len: Int): Seq[Seq[Bool]] = enables(len, rowAt(d - 2, isG) || rowAt(d - 1, isZ))
  val rowL = p.rowLat
  val enE = rowEnables(rowL, rK, isE)
  val enK = rowEnables(rowL, rK, isK)
  val enZ = rowEnables(rowL + 1, rK, isK)
  val enB = rowEnables(rowL + 1, if (ram) 1 else rG, isB)
  val enG = if (ram) Nil else rowEnables(rowL, rG, isG)
  /** ram: a memory of unit u with a row per element (rG), two words (the halves, or lo and hi) per row: read latency
    * 2 (block RAM with its output register on the ECP5) */
  def unitRam(what: String, u: Int): InitRam = {
    val r = Module(new InitRam(s"${p.moduleName}_$what$u", rG, 2, W, Nil, outReg = true,
      ecp5 = p.target == Target.Ecp5 && rG <= 1024))
    r.io.clock := clock
    r.io.wmask := 3.U
    r
  }
  def ramAddr(r: InitRam, x: UInt): UInt = x.pad(r.addrW)(r.addrW - 1, 0)
  def ramWords(r: InitRam): Vec[SInt] = r.io.rdata.asTypeOf(Vec(2, SInt(W.W)))
  /** ram: the element stage's first iteration of a zero start, per unit: its rows (the first pass's bound rows) take
    * y = wy = 0 */
  val zfU = if (ram) Seq.fill(P)(RegInit(false.B)) else Nil
  /** ram: per unit, pass K's operand dual is y (else the candidate), as the element stage reads it */
  val opYU = if (ram) unitRegs(opY) else Nil
  for (u <- 0 until P) {
    val tokR  = tokRU(u)
    val a     = accR(u)
    // first pass and pass K
    // pass K: z = sat(a + e), the sum registered before its saturation and z's FIFO (z is first read in pass G's
    // operand select, gapK + 2 cycles after the last row's sum)
    val zSum = Reg(SInt((p.accW.max(W) + 1).W))
    zSum := a +& eU(u)(0)
    val (zNew, ofZ) = sat(zSum)
    val (eNew, ofE) = sat(a)
    // the bounds' constants read a cycle ahead, by the token of the stage before
    val tokPre = tokAt(p.rowLat - 1)
    val lo0R = Reg(SInt(W.W))
    val hi0R = Reg(SInt(W.W))
    lo0R := lo0U(u)(tokPre.round)
    hi0R := hi0U(u)(tokPre.round)
    // first pass: rounds 0..rK-1 (e), then rK..rK+rG-1 (the bounds), in order: each enters its FIFO at the tail.
    // e enters z too, the z of a zero start's first iteration (pass K overwrites it otherwise), and the plain form's
    // Sz on a zero start
    rotate(eU(u), eNew, enE(u))
    rotate(zU(u), eNew, enE(u))
    ovfFlags(u) += rowEU(u) && ofE
    szU.lift(u).foreach(s => rotate(s, s(0) + eNew, enE(u).map(_ && zsU(u))))
    // the bounds' sums are registered, then saturated into their FIFOs a cycle later (they are first read in pass G)
    val bNext = enB(u).head
    val (loS, hiS) = (Reg(SInt((p.accW.max(W) + 1).W)), Reg(SInt((p.accW.max(W) + 1).W)))
    loS := lo0R +& a
    hiS := hi0R +& a
    val (loNew, ofL) = sat(loS)
    val (hiNew, ofH) = sat(hiS)
    ovfFlags(u) += bNext && (ofL || ofH)
    // ram: the bounds' memory, written by the first pass's bound rows (element round - rK) and read for pass G's rows:
    // the address of the token two stages ahead, so that the words come with the row's sum
    val lhRam = if (ram) Some(unitRam("lh", u)) else None
    lhRam match {
      case Some(r) =>
        r.io.wen   := bNext
        r.io.waddr := ramAddr(r, RegNext(tokR.round - rK.U))
        r.io.wdata := Cat(hiNew.asUInt, loNew.asUInt)
        r.io.raddr := ramAddr(r, RegNext(tokAt(p.rowLat - 3).round))
      case None => rotate(loU(u), loNew, enB(u)); rotate(hiU(u), hiNew, enB(u))
    }
    rotate(zU(u), zNew, enZ(u))
    ovfFlags(u) += rowZKU(u) && ofZ
    rotate(eU(u), eU(u)(0), enK(u))
    szU.lift(u).foreach(s => rotate(s, s(0) + zNew, enZ(u)))

    // pass G. E0: s = sat(G (z - e)), the bounds of the row (lo and hi rotate here) and its dual box, registered. A
    // zero start's bound row enters a stage after its sum, with s = 0 and the bounds as they enter their FIFOs
    val (sNow, ofS) = sat(a)
    val rowG = rowGU(u)
    val rowZ = rowZU(u)
    if (!ram) { rotate(loU(u), loU(u)(0), enG(u)); rotate(hiU(u), hiU(u)(0), enG(u)) }
    ovfFlags(u) += rowG && ofS
    val e0  = RegNext(rowG || rowZ, false.B)
    val s0  = Reg(SInt(W.W))
    s0 := Mux(rowZ, 0.S, sNow)
    val (lo0, hi0) = (Reg(SInt(W.W)), Reg(SInt(W.W)))  // typed: RegNext leaves the width to inference
    val tokZ = tokZU(u)
    val (loHead, hiHead) = lhRam.map(r => (ramWords(r)(0), ramWords(r)(1))).getOrElse((loU(u)(0), hiU(u)(0)))
    lo0 := Mux(rowZ, loNew, loHead)
    hi0 := Mux(rowZ, hiNew, hiHead)
    /** ram: the row's element index along the element stage (a zero start's bound rows by the first pass's round) */
    val k0 = RegNext(Mux(rowZ, tokZ.round - rK.U, tokR.round))
    val u0  = RegNext(VecInit((0 until 2).map(h => Mux(rowZ, udZ(h)(u)(tokZ.round), udU(h)(u)(tokR.round)))))
    val live0 = if (p.shift)
      Some(RegNext(VecInit((0 until 2).map(h => Mux(rowZ, liveZ(h)(u)(tokZ.round), liveU(h)(u)(tokR.round))))))
    else None
    val live1b = live0.map(x => RegNext(RegNext(x)))
    // E1: g = (s - hi, lo - s)
    val (gpNow, ofGp) = sat(s0 -& hi0)
    val (gmNow, ofGm) = sat(lo0 -& s0)
    ovfFlags(u) += e0 && (ofGp || ofGm)
    val e1 = RegNext(e0, false.B)
    val g1 = RegNext(VecInit(gpNow, gmNow))
    val u1 = RegNext(u0)
    // E1b: g - ud - 1, so that E2 tests wy + g > ud from a sign (both sums in parallel)
    val e1b = RegNext(e1, false.B)
    val g1b = RegNext(g1)
    val u1b = RegNext(u1)
    val gmu = RegNext(VecInit((0 until 2).map(h => g1(h) -& u1(h) - 1.S)))
    // E2: y_new = clip(wy + g, 0, ud) (plain: y rotates here, and Sg with the test's sum; accelerated: the two
    // sums registered, y_new selected by their signs in E3)
    // ram: y and the candidate read by the row's element index (the shifted warm start's first iteration: y at the
    // row's shift source, zero where it has none), the address a stage after the row's sum, the words at E1b
    val firstNow = firstU.lift(u).getOrElse(false.B)
    val (yRam, cRam) = if (ram) (Some(unitRam("y", u)), Some(unitRam("c", u))) else (None, None)
    val yD = yRam.map(ramWords)
    val wy2: Seq[SInt] = (yRam, cRam) match {
      case (Some(yr), Some(cr)) =>
        val src  = VecInit((0 until rG).map(k => math.max(if (p.shift) p.shiftElem(u, k) else k, 0).U(yr.addrW.W)))
        val dead = VecInit((0 until rG).map(k => (p.shift && p.shiftElem(u, k) < 0).B))
        yr.io.raddr := RegNext(Mux(firstNow, src(tokR.round), ramAddr(yr, tokR.round)))
        cr.io.raddr := RegNext(ramAddr(cr, tokR.round))
        val dead1b = ShiftRegister(dead(tokR.round) && firstNow, 3)
        val cD = ramWords(cr)
        (0 until 2).map(h => Mux(zfU(u) || dead1b, 0.S(W.W), Mux(opYU(u) || firstNow, yD.get(h), cD(h))))
      case _ => wyEU.map(_(u)(0))
    }
    val tSum = (0 until 2).map(h => wy2(h) +& g1b(h))
    val cSum = (0 until 2).map(h => wy2(h) +& gmu(h))
    def clipNew(t: SInt, c: SInt, ud: SInt): SInt = Mux(t < 0.S, 0.S, Mux(c >= 0.S, ud, t))(W - 1, 0).asSInt
    val yNew = (0 until 2).map(h => clipNew(tSum(h), cSum(h), u1b(h)))
    // the rotate enables of the element stage's FIFOs, per group: y_new (E2: plain y; accelerated, the
    // extrapolated dual), y (accelerated: E3), the extrapolated dual's candidate (accelerated: E6)
    lazy val en2 = elementEnables(rowL + 3, rG)(u)
    if (acc) {
      if (!ram) for (h <- 0 until 2) rotate(wyEU(h)(u), wyEU(h)(u)(0), en2)
      when(e1b && (g1b(0) > p.eg.S || g1b(1) > p.eg.S)) { violU(u) := true.B }
    } else {
      val nv = (0 until 2).map(h => sgU(h)(u)(0) + g1b(h))
      for (h <- 0 until 2) { rotate(yU(h)(u), yNew(h), en2); rotate(sgU(h)(u), nv(h), en2) }
      // E3: the test's sums against the threshold
      val e3 = RegNext(e1b, false.B)
      val nv3 = RegNext(VecInit(nv))
      val yN3 = RegNext(VecInit(yNew))
      when(e3 && (nv3(0) > tThr || nv3(1) > tThr)) { violU(u) := true.B }
      when(e3 && nonzero(yN3, live1b.map(RegNext(_)))) { nzU(u) := true.B }
    }
    restartU(u) := false.B
    if (acc) {
      val e2  = RegNext(e1b, false.B)
      val g2  = RegNext(g1b)
      val w2  = RegNext(VecInit(wy2))
      val u2  = RegNext(u1b)
      val (t2, c2) = (RegNext(VecInit(tSum)), RegNext(VecInit(cSum)))
      val yN2 = (0 until 2).map(h => clipNew(t2(h), c2(h), u2(h)))
      // E3: y rotates, its old value kept for dy (ram: y's word written, vY enters)
      val en3 = elementEnables(rowL + 4, rG)(u)
      val k1 = RegNext(k0)
      val k2 = RegNext(RegNext(k1))
      val yOld: Seq[SInt] = yRam match {
        case Some(r) =>
          r.io.wen   := e2
          r.io.waddr := ramAddr(r, k2)
          r.io.wdata := Cat(yN2(1).asUInt, yN2(0).asUInt)
          rotate(vYU(u), (yN2(0) -& yN2(1))(p.opW - 1, 0).asSInt, en3)
          RegNext(VecInit((0 until 2).map(h => Mux(zfU(u), 0.S(W.W), yD.get(h)))))
        case None =>
          for (h <- 0 until 2) rotate(yU(h)(u), yN2(h), en3)
          yU.map(_(u)(0))
      }
      val e3 = RegNext(e2, false.B)
      val yN3 = RegNext(VecInit(yN2))
      when(e3 && nonzero(yN3, live1b.map(x => RegNext(RegNext(x))))) { nzU(u) := true.B }
      val yO3 = RegNext(VecInit(yOld))
      val g3 = RegNext(g2)
      val w3 = RegNext(w2)
      val u3 = RegNext(u2)
      // E4: dy = y_new - y
      val e4  = RegNext(e3, false.B)
      val yN4 = RegNext(yN3)
      // (the shifted warm start: the first iteration's y is its wy)
      val yP3 = firstU.lift(u).map(f => VecInit((0 until 2).map(h => Mux(f, w3(h), yO3(h))))).getOrElse(yO3)
      val dy4 = RegNext(VecInit((0 until 2).map(h => (yN3(h) -& yP3(h))(W - 1, 0).asSInt)))
      /** y_new - ud - 1: the extrapolation's clip tests t > ud from the sign of t - ud - 1 (E6) */
      val yu4 = RegNext(VecInit((0 until 2).map(h => (yN3(h) -& u3(h)) -& 1.S)))
      val g4  = RegNext(g3)
      val w4  = RegNext(w3)
      val u4  = RegNext(u3)
      def prod(x: SInt, c: SInt): SInt = FixedOps.mulRoundPipelined(x, c, p.latMulE, b, Rounding.Nearest, p.target)
      val pGap = (0 until 2).map(h => prod(w4(h), g4(h)))
      val pRst = (0 until 2).map(h => prod(g4(h), dy4(h)))
      val pExt = (0 until 2).map(h => prod(betaR, dy4(h)))
      // E5 (latMulE later): the products' sums, and the extrapolation before its clip
      val e5  = ShiftRegister(e4, p.latMulE, false.B, true.B)
      val yN5 = ShiftRegister(yN4, p.latMulE)
      val yu5 = ShiftRegister(yu4, p.latMulE)
      val u5  = ShiftRegister(u4, p.latMulE)
      val e6   = RegNext(e5, false.B)
      val u6   = RegNext(u5)
      val sGap = RegNext(pGap(0) +& pGap(1))
      val sRst = RegNext(pRst(0) +& pRst(1))
      val tExt = RegNext(VecInit((0 until 2).map(h => yN5(h) +& pExt(h))))
      val dExt = RegNext(VecInit((0 until 2).map(h => yu5(h) +& pExt(h))))
      // E6: the sums, and the extrapolated dual, which stays in [0, ud] (so the gap test bounds V(z) - V*)
      when(e6) {
        gapU(u) := gapU(u) + sGap
        rstU(u) := rstU(u) + sRst
      }
      // a row past the unit's last has ud = 0, so its candidate is 0
      val en6 = elementEnables(rowL + 7 + p.latMulE, rG)(u)
      val cand = (0 until 2).map(h => clipNew(tExt(h), dExt(h), u6(h)))
      cRam match {
        case Some(r) =>
          r.io.wen   := e6
          r.io.waddr := ramAddr(r, RegNext(ShiftRegister(RegNext(RegNext(k2)), p.latMulE)))
          r.io.wdata := Cat(cand(1).asUInt, cand(0).asUInt)
          rotate(vCU(u), (cand(0) -& cand(1))(p.opW - 1, 0).asSInt, en6)
        case None => for (h <- 0 until 2) rotate(wycU(h)(u), cand(h), en6)
      }
    }
  }

  // the units' overflow flags, each registered, ORed per unit and registered, then over the units (the flag is read
  // at the status word, long after)
  val ovfNow = RegNext(VecInit((0 until P).map(u =>
    RegNext(VecInit(ovfFlags(u).toSeq.map(RegNext(_, false.B))).asUInt.orR, false.B))).asUInt.orR, false.B)
  when(ovfNow) { solveOvf := true.B; regs.stOvf := true.B }

  // ------------------------------------------------------------------ decision
  // the units' flags and sums added in registered levels (unitDepth), then the test's flags registered
  val violAll = reduce[Bool](violU, _ || _)
  val gapSum  = reduce[SInt](gapU, _ + _)
  val rstSum  = reduce[SInt](rstU, _ + _)
  val stop    = RegNext(!violAll && (if (ram) !gapSum(gapW - 1) else if (acc) gapSum >= (-p.eV).S else true.B))
  /** y_new is all zero: the next warm start is a zero start */
  val yZeroNext = RegNext(!reduce[Bool](nzU, _ || _))
  // the restart, per unit (it selects every dual word of the unit's rows)
  if (acc) restartU := VecInit(unitRegs(rstSum < 0.S))
  val restart = restartU(0)
  // (iter and imax change at the take and the decisions only, an iteration apart)
  val lastIter = RegNext(iter + 1.U === imax, false.B)
  val finish  = stop || lastIter
  val outIdx  = RegInit(0.U(16.W))
  for (u <- 0 until P) when(decideU(u)) { violU(u) := false.B; nzU(u) := false.B; gapU(u) := gap0(u); rstU(u) := 0.S }
  for ((f, u) <- firstU.zipWithIndex) when(decideU(u)) { f := false.B }
  for ((f, u) <- zfU.zipWithIndex) { when(startU(u)) { f := zSolve }; when(decideU(u)) { f := false.B } }
  // accelerated: the next extrapolated dual, y on a restart, else the candidate, loaded in the cycle after the
  // decision (pass K's first operand select is a cycle after its issue). The decision and the restart reach each
  // group of 8 of a unit's rows of each half from copies of their own (FPGA targets: kept registers loaded from the
  // unit's), so that no register drives a whole vector
  if (acc && !ram) for (u <- 0 until P) {
    val (decN, rsN) = (RegNext(decideU(u), false.B), RegNext(restartU(u)))
    for (h <- 0 until 2; g <- 0 until rG by 8) {
      val (dec, rs) = if (fpga) (KeepReg(decideU(u)), KeepReg(restartU(u))) else (decN, rsN)
      when(dec) {
        for (k <- g until math.min(g + 8, rG)) wyEU(h)(u)(k) := Mux(rs, yU(h)(u)(k), wycU(h)(u)(k))
      }
    }
  }
  // the counter and beta of the next iteration without a restart, registered from kAcc (which changes at the
  // take and the decisions only, an iteration apart): kNew = min(kAcc + 1, 255), beta at min(kNew + 1, 255)
  val kInc    = RegNext(Mux(kAcc === 255.U, 255.U, kAcc + 1.U))
  val betaInc = RegNext(betaRom(Mux(kAcc >= 253.U, 255.U, kAcc + 2.U)))
  // The decision sets up the next iteration whether or not it finishes (after an answer, the take sets up the
  // next solve), so that the test reaches only the state and the registers of the finished solve
  when(sDecide) {
    tThr := tThr + p.eg.S
    yZero := yZeroNext
    if (acc) {
      kAcc  := Mux(restart, 0.U, kInc)
      betaR := Mux(restart, betaRom(1), betaInc)
    }
    opYD := restart
    pKD := true.B; pGD := false.B; jump(p.baseK); iter := iter + 1.U; outIdx := 0.U
    sDecide := false.B; sOut := finish; sIssue := !finish
    when(finish) {
      itersR := iter + 1.U; metR := stop; zeroR := zSolve
      regs.solveDone(cycles + 1.U)
    }
  }

  // ------------------------------------------------------------------ output
  /** the status word follows the last of the nu (n with OUT_ALL) solution words */
  val statusNow = outIdx === Mux(regs.ctrlOutAll, n.U, nu.U)
  val statusWord = Cat(solveOvf, solveSat, metR, itersR)
  /** the answer's status word has left: the sequencer waits for the next frame */
  def idle(): Unit = { sOut := false.B; sIdle := true.B }
  /** accelerated: an answer is in the output queue (DgpAnswer) */
  val queued: Bool = if (acc) chisel3.experimental.noPrefix {
    DgpAnswer(p, fpga, z, sDecide && finish, regs.ctrlOutAll, outIdx, statusWord, m_axis, idle)
  } else false.B
  // plain: each word of the averaged primal from a serial divider (DgpPlainAnswer)
  if (!acc) chisel3.experimental.noPrefix {
    DgpPlainAnswer(p, sOut, VecInit(flat(szU, n)), itersR, outIdx, statusNow, statusWord, m_axis, idle)
  }
  bus.Protocol.streamOut("m_axis", m_axis)
  regs.busy := !sIdle || queued || frameIn.io.full || frameIn.io.partial || s_axis.fire
}
