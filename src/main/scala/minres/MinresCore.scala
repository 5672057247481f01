package minres

import chisel3._
import chisel3.util._
import bus.{AxiLiteIO, AxiStreamIO}
import float.{FloatFormat, Stages}
import linalg.FDotProduct
import shell.SolverRegs

/** MINRES solver for the banded KKT system of section VI-A of 001, P problems interleaved (Fig. 1 of 001).
  *
  * A batch of up to P problems arrives on s_axis: per problem an id word, the variable part of the matrix (the
  * diagonal of the primal rows, T(n+m)+n words) and b (N words), raw words of the format in the low bits of the
  * 32-bit stream words (the upper bits are ignored on input and zero on output), tlast on the last word. The
  * next batch loads into the other bank while one solves. The core runs the init pass and Imax MINRES
  * iterations on every slot, then sends per problem the id (bit 31 set if an input word or the solution is
  * not finite) and the solution z (N words). Batches overlap: the next one starts as soon as the previous one's
  * feed has taken its last element (its passes, and then its answers, finish meanwhile), so back to back
  * batches of Imax iterations take (Imax + 1) P S cycles each.
  *
  * Schedule: slot p of iteration j starts its feed at ((j P + p) S); every pass serves one slot at a time, so
  * one instance of each unit serves all problems:
  *   feed + matvec: v_j is read into a shift register of 2M-1 words (vector alignment by shifting) M cycles
  *     ahead of its rows; row i multiplies K words of the window, chosen by the row's key, by their band
  *     coefficients (constants, and the variable diagonal) in the dot-product block (K multipliers, adder tree;
  *     K is the most nonzeros of a row, mpc_cores/minres/band.py); delta = v_j . A v_j streams into an accumulator;
  *   pass B: u = (A v_j - delta v_j) - gamma_j v_{j-1} and ||u||^2 (accumulator);
  *   scalar part: gamma_{j+1}, the Givens rotation, its coefficients (once per slot: one operator per kind on a
  *     static schedule, or one per operation when the slots are shorter than that schedule);
  *   pass C: v_{j+1} = u / gamma_{j+1}, w_{j+1}, x.
  * Offsets are in MinresParams; P S >= need guarantees that v_{j+1} is written before the slot's next feed.
  */
class MinresCore(val p: MinresParams) extends Module {
  override def desiredName = p.moduleName
  private val fmt: FloatFormat = p.fmt
  private val W = fmt.width // bits of a word of the format (the low bits of a stream word)
  import p.{N, M, P, S, n, m, T, nPrimal, taps}

  val s_axis = IO(Flipped(new AxiStreamIO(32)))
  val m_axis = IO(new AxiStreamIO(32))
  val s_axil = IO(Flipped(new AxiLiteIO(p.axiAddrW)))
  /** the warm form's control from the interior-point core: iterations per batch and the closing of a partial batch */
  val ipm = if (p.warm) Some(IO(Input(new MinresIpmIO))) else None

  require(n < 256 && m < 256 && T < 65536, s"CONFIG1 holds n, m < 256 and T < 65536: got n=$n, m=$m, T=$T")
  /** STATUS.NONFINITE: a non-finite input word or solution (write 1 to clear) */
  val nonfinite = RegInit(false.B)
  val regs = new SolverRegs(s_axil, MinresRegs.map(p), Seq("NONFINITE" -> nonfinite))

  private val ops = new TimedOps(fmt, p.latAdd, p.latMul, p.latDiv, p.latSqrt, p.target)
  import ops.{add, div, mul, sqrt, sub}
  private val zero   = 0.U(W.W)
  private val one    = (BigInt(fmt.bias) << fmt.manW).U(W.W)
  /** the exponent field is not all ones */
  private def finite(w: UInt): Bool = w(W - 2, fmt.manW) =/= fmt.maxExpField.U

  // ---- vector memories: block RAM, one write and one registered read port per memory (VecRam), addresses
  // slot-major. Single-buffered where the schedule reads a word before it is overwritten (v_j by the feed and
  // passes B and C before pass C writes v_{j+1} over it); w alternates between two banks by the parity of j, so
  // that w_j and w_{j-1} come from different memories.
  private val prim = if (p.target == dsp.Target.Ecp5) Some(p.moduleName) else None
  private def vec(name: String, depth: Int, copies: Int = 1) = new VecRam(name, depth, W, copies, prim)
  val vmem  = vec("vmem", P * N, copies = 3)  // v_j: copy 0 feed, 1 pass B, 2 pass C (written by pass C)
  val vpmem = vec("vpmem", P * N)             // v_{j-1} for pass B (pass B copies v_j into it)
  val umem  = vec("umem", P * N)              // u, from pass B to pass C
  val wmem  = Seq(vec("wmem0", P * N), vec("wmem1", P * N)) // w_j in bank j % 2
  val xmem  = vec("xmem", 2 * P * N, copies = 2) // x by bank: copy 0 pass C, copy 1 the output stream
  val ymem  = vec("ymem", P * N)              // A v_j, from the matvec to pass B
  val bmem  = vec("bmem", 2 * P * N)          // right-hand sides, double-buffered (load bank)
  val dmem  = vec("dmem", 2 * P * nPrimal)    // variable column (primal diagonal), double-buffered
  // warm form: d (copy 0 the feed, copy 1 the row scaling) and z0 (the init pass's feed), double-buffered
  val smem  = if (p.warm) Some(vec("smem", 2 * P * N, copies = 2)) else None
  val zmem  = if (p.warm) Some(vec("zmem", 2 * P * N)) else None
  /** (buf P + slot) len + e and slot N + e, the products as tables of constants indexed by the (buf, slot) bits: a
    * few LUT levels ahead of the adder instead of a multiplier on the memories' address paths */
  private def adr2(buf: UInt, slot: UInt, e: UInt, len: Int): UInt = base2(buf, slot, len) +& e
  private def base2(buf: UInt, slot: UInt, len: Int): UInt = {
    val (wb, ws) = (buf.getWidth, slot.getWidth)
    val prods    = Seq.tabulate(1 << (wb + ws))(k => BigInt(((k >> ws) * P + (k & ((1 << ws) - 1))) * len))
    val w        = math.max(1, prods.max.bitLength)
    VecInit(prods.map(_.U(w.W)))(Cat(buf, slot))
  }
  private def adr1(slot: UInt, e: UInt): UInt = adr2(0.U(1.W), slot, e, N)
  private def base1(slot: UInt): UInt = base2(0.U(1.W), slot, N)
  private def inN(e: UInt): UInt = Mux(e < N.U, e, 0.U)
  /** the write addresses of a pass's control word c delayed by t >= 2 cycles (adrAt) */
  private def adr1At(c: MinresCtl, t: Int): UInt = adrAt(c, t)(x => (base1(x.slot), x.e))
  private def adr2At(c: MinresCtl, t: Int): UInt = adrAt(c, t)(x => (base2(x.bank, x.slot, N), x.e))
  /** an address base + offset (f of the control word c) delayed by t >= 2 cycles: the base (a table of the bank
    * and slot) and the offset registered from c's delay by t - 2, their sum registered, so that no adder meets a
    * memory and no table or compare meets the adder */
  private def adrAt(c: MinresCtl, t: Int)(f: MinresCtl => (UInt, UInt)): UInt = {
    require(t >= 2, "address parts registered two cycles ahead")
    val (base, off) = f(Stages.delay(c, t - 2))
    RegNext(RegNext(base) +& RegNext(off))
  }

  // ---- per-problem scalars
  private def scal() = Reg(Vec(P, UInt(W.W)))
  val delta = scal()
  val cR = scal(); val cpR = scal(); val sR = scal(); val spR = scal(); val gamR = scal(); val etaR = scal()
  val g1R = scal(); val a1R = scal(); val a2R = scal(); val a3R = scal(); val cetaR = scal()
  val res0R = Reg(Vec(2 * P, UInt(W.W))) // ||r_0||, bank * P + slot: the init pass's norm (sent after x, warm form)

  // ---- input: frames into the load bank
  val ldBank = RegInit(0.U(1.W))
  val ldSlot = RegInit(0.U(log2Ceil(P + 1).W))
  private val ld = new bus.FrameCount(p.frameWords) // tready and the word's kind from its flags
  private val ldWord = ld.value
  private val ldAt0 = ld.at0
  val full   = RegInit(VecInit(false.B, false.B))
  val cnt    = Reg(Vec(2, UInt(log2Ceil(P + 1).W)))
  val ids    = Reg(Vec(2 * P, UInt(31.W))) // bank * P + slot
  val inBad  = Reg(Vec(2 * P, Bool()))
  // several coefficient tables: each problem's table, (id mod 2^tableIdBits) mod tables, set with its id
  private val nTab    = p.coefTables.length
  private val tabOfId = Option.when(nTab > 1)(VecInit((0 until (1 << p.tableIdBits)).map(i => (i % nTab).U(log2Ceil(nTab).W))))
  val tabs = Option.when(nTab > 1)(Reg(Vec(2 * P, UInt(log2Ceil(nTab).W))))

  s_axis.tready := !full(ldBank) && !(regs.ctrlHold && ldAt0)
  private val d = s_axis.tdata(W - 1, 0) // a data word: the format's word in the low bits
  private val lastWord = ld.atLast
  // one write port each: the load bank's words as they arrive, registered before the memories (the handshake
  // fans out to every block RAM of the load path; a word lands a cycle after its handshake, and a batch reads its
  // bank's last word no earlier than N - 1 cycles after its start)
  private val ldData = s_axis.fire && !ldAt0
  private def load(m: VecRam, en: Bool, a: UInt): Unit = m.write(RegNext(en, false.B), RegNext(a), RegNext(d))
  load(dmem, ldData && ldWord <= nPrimal.U, adr2(ldBank, ldSlot, ldWord - 1.U, nPrimal))
  if (p.warm) {
    // id, diag (nPrimal), d (N), b (N), z0 (N)
    val o1 = nPrimal + 1; val o2 = o1 + N; val o3 = o2 + N
    load(smem.get, ldData && ldWord >= o1.U && ldWord < o2.U, adr2(ldBank, ldSlot, ldWord - o1.U, N))
    load(bmem, ldData && ldWord >= o2.U && ldWord < o3.U, adr2(ldBank, ldSlot, ldWord - o2.U, N))
    load(zmem.get, ldData && ldWord >= o3.U, adr2(ldBank, ldSlot, ldWord - o3.U, N))
  } else load(bmem, ldData && ldWord > nPrimal.U, adr2(ldBank, ldSlot, ldWord - (nPrimal + 1).U, N))
  when(s_axis.fire) {
    when(s_axis.tlast =/= lastWord) { regs.stTlast := true.B }
    when(ldAt0) {
      ids(ldBank * P.U + ldSlot)   := s_axis.tdata(30, 0)
      tabs.foreach(_(ldBank * P.U + ldSlot) := tabOfId.get(s_axis.tdata(p.tableIdBits - 1, 0)))
      inBad(ldBank * P.U + ldSlot) := false.B
    }.otherwise {
      when(!finite(d)) {
        inBad(ldBank * P.U + ldSlot) := true.B
        nonfinite := true.B
      }
    }
    ld.step()
    when(lastWord) {
      when(ldSlot === (P - 1).U) {
        full(ldBank) := true.B
        cnt(ldBank)  := P.U
        ldBank       := ~ldBank
        ldSlot       := 0.U
      }.otherwise { ldSlot := ldSlot + 1.U }
    }
  }

  // ---- batches: one per bank. A batch starts when its bank is loaded and the previous batch's feed has taken its
  // last element, so consecutive batches keep the matrix-vector product busy; a finished batch's answers stream
  // out of its bank while the next one runs. The bank is loaded again once its answers are out.
  val started = RegInit(VecInit(false.B, false.B)) // running, or finished with answers not yet all out
  val active  = RegInit(VecInit(false.B, false.B)) // running: its x not yet complete
  val doneB   = RegInit(VecInit(false.B, false.B)) // finished: its answers are streaming or waiting to
  val nextBank = RegInit(0.U(1.W))                // bank of the next batch to start
  val curBank  = RegInit(0.U(1.W))                // bank of the batch started last
  val g        = Reg(Vec(2, UInt(32.W)))           // cycles since the batch's start
  val gEnd     = Reg(Vec(2, UInt(32.W)))           // its last x write, minus one
  val atEnd    = RegInit(VecInit(Seq.fill(2)(false.B))) // g = its last x write (a compare registered a cycle ahead)
  val gFeed    = Reg(Vec(2, UInt(32.W)))           // its feed's last element, minus one
  val gFeedM1  = Reg(Vec(2, UInt(32.W)))           // gFeed - 1, for the compare a cycle ahead
  val fed      = RegInit(VecInit(false.B, false.B)) // g has reached the feed's last element (g >= gFeed + 1)
  val batchCyc = Reg(Vec(2, UInt(32.W)))
  val xBad     = Reg(Vec(2 * P, Bool()))

  // A partly filled bank is sent on after flushCycles idle cycles of the input while the solver has nothing to do.
  val idleCnt = RegInit(0.U(16.W))
  val partial = ldAt0 && ldSlot =/= 0.U && !full(ldBank)
  // the interior-point core's close may come before the batch's last word is in (its stream has a register
  // slice): it waits here until it is
  private val closeReq  = ipm.map(_.close).getOrElse(false.B)
  private val closePend = RegInit(false.B)
  private val closeNow  = p.warm.B && partial && (closeReq || closePend)
  when(closeNow) { closePend := false.B }.elsewhen(closeReq) { closePend := true.B }
  when(closeNow) {
    full(ldBank) := true.B
    cnt(ldBank)  := ldSlot
    ldBank       := ~ldBank
    ldSlot       := 0.U
  }
  private val solverIdle = !started.asUInt.orR && !full(~ldBank)
  when(!p.warm.B && partial && !s_axis.tvalid && solverIdle) {
    idleCnt := idleCnt + 1.U
    when(idleCnt === (p.flushCycles - 1).U) {
      full(ldBank) := true.B
      cnt(ldBank)  := ldSlot
      ldBank       := ~ldBank
      ldSlot       := 0.U
      idleCnt      := 0.U
    }
  }.otherwise { idleCnt := 0.U }

  private val prevFed  = !active(curBank) || fed(curBank)
  val startBatch = full(nextBank) && !started(nextBank) && prevFed
  private val imaxIn = ipm.map(_.imax).getOrElse(regs.imaxReg)
  when(startBatch) {
    started(nextBank) := true.B
    active(nextBank)  := true.B
    g(nextBank)       := 0.U
    gEnd(nextBank)    := ~0.U(32.W) // set from the product when it is ready
    gFeed(nextBank)   := ~0.U(32.W)
    gFeedM1(nextBank) := ~1.U(32.W)
    fed(nextBank)     := false.B
    for (q <- 0 until P) xBad(nextBank * P.U + q.U) := false.B
    curBank  := nextBank
    nextBank := ~nextBank
  }
  // g = gFeed from the compare of g with gFeed - 1 a cycle ahead (while the batch was active: g counts up by one,
  // and the values of the cycle of its start are the previous batch's), registered in halves
  private def half(x: UInt, h: Int): UInt = x(16 * h + 15, 16 * h)
  private val feedEq = Seq.tabulate(2, 2)((b, h) => RegNext(half(g(b), h) === half(gFeedM1(b), h), false.B))
  private val wasAct = Seq.tabulate(2)(b => RegNext(active(b), false.B))
  for (b <- 0 until 2) when(active(b)) {
    g(b) := g(b) + 1.U
    when(wasAct(b) && feedEq(b)(0) && feedEq(b)(1)) { fed(b) := true.B } // g = gFeed: no carry chain
    atEnd(b) := g(b) === gEnd(b)
    when(atEnd(b)) {
      atEnd(b)    := false.B
      active(b)   := false.B
      doneB(b)    := true.B
      batchCyc(b) := g(b) + 1.U
    }
  }
  /** the cycle t of the batch started last (t = 0: the cycle after its start decision, MinresParams.StartReg),
    * from a flag registered a cycle ahead: a pass starts within the first iteration, when no other batch can
    * start (its feed is not done), so the bank a cycle ahead is the bank of that cycle */
  private val go = RegNext(startBatch, false.B)
  private def startAt(t: Int): Bool =
    if (t == 0) go else RegNext(active(curBank) && g(curBank) === (t - 1).U, false.B)
  /** the batch's I_MR, latched at its start decision */
  private val imaxS = RegEnable(imaxIn, startBatch)
  private val imaxSZero = RegEnable(imaxIn === 0.U, startBatch)

  // The memories' words arrive RL cycles after their address: passes B and C count RL + 1 cycles ahead
  // (counters pbA and pcA; their addresses a cycle later, registered) and their words and control meet at the
  // offsets tB and tC (bc, cc). The feed's words enter the shift register RL cycles after its count (tRow counts
  // them).
  private val RL = VecRam.ReadLatency
  /** curBank as a pass counter takes it at its start: on an FPGA target a kept copy per counter (mem.KeepReg, the
    * same value: set with curBank), so that the register the batch logic reads across the core does not also drive
    * the counters' address adders */
  private def bankCopy(): UInt = if (p.target == dsp.Target.Generic) curBank else {
    val d = Wire(UInt(1.W))
    val q = mem.KeepReg(d)
    d := Mux(reset.asBool, 0.U, Mux(startBatch, nextBank, q))
    q
  }
  val feed = new PassCounter(p); feed.tick(startAt(0), imaxS, bankCopy(), Some(imaxSZero))
  val pbA  = new PassCounter(p); pbA.tick(startAt(p.tB - RL - 1), feed.imax, bankCopy(), Some(feed.imaxZero))
  val ps   = new PassCounter(p); ps.tick(startAt(p.tS), feed.imax, bankCopy(), Some(feed.imaxZero))
  val pcA  = new PassCounter(p); pcA.tick(startAt(p.tC - RL - 1), feed.imax, bankCopy(), Some(feed.imaxZero))
  /** a pass's address phase, a cycle behind its counter (which starts a cycle earlier): the counter's word and its
    * read addresses (in a slot's vector; in a bank's slot's vector) registered. The addresses are the counter's
    * elementAdr registers (counting beside it) registered once more, so that no adder or compare meets a memory,
    * and the register driving the memories has nothing but a register before it */
  private def addressPhase(pc: PassCounter): (MinresCtl, UInt, UInt) =
    (RegNext(pc.c), RegNext(pc.elementAdr((c, e) => adr1(c.slot, e), N)),
      RegNext(pc.elementAdr((c, e) => adr2(c.bank, c.slot, e, N), N)))
  // the batch's last cycles, I_MR P S + c: the I_MR latched at the start decision times a constant, a product of
  // the target's pipelined multiplier (on the ECP5 a MULT18X18D with its registers), set when it is ready on the
  // batch's fourth cycle (g = 3; until then they hold the largest count)
  private val cpi     = p.cyclesPerIteration.S((BigInt(p.cyclesPerIteration).bitLength + 1).W)
  private val latCyc  = p.target.minLatency(imaxS.getWidth + 1, cpi.getWidth).max(3)
  private val imaxCyc = fixed.FixedOps.mulPipelined(imaxS.zext, cpi, latCyc, target = p.target).asUInt
  require(p.cyclesPerIteration - 2 > latCyc + 1, "the feed's end lies past the cycle its compare is set up")
  for (b <- 0 until 2) when(active(b) && g(b) === latCyc.U) {
    gEnd(b)  := imaxCyc +& (p.batchCycles(0) - 2).U
    gFeed(b) := imaxCyc +& (p.cyclesPerIteration - 2).U
    gFeedM1(b) := imaxCyc +& (p.cyclesPerIteration - 3).U
  }

  // ---- feed: v_j into the alignment shift register, M cycles ahead of the row
  // (the read addresses kept in registers beside the counter)
  private val sr0 = vmem.read(0, feed.elementAdr((c, e) => adr1(c.slot, e), N))
  // warm form: d v_j (z0 in the init pass), latFeed = lat_mul cycles later
  private val feedWord = if (!p.warm) sr0 else {
    val fAdr = feed.elementAdr((c, e) => adr2(c.bank, c.slot, e, N), N)
    val dv   = mul(Timed(smem.get.read(0, fAdr), 0), Timed(sr0, 0))
    Mux(Stages.delay(RegNext(feed.c.j === 0.U), RL - 1 + p.latFeed), Stages.delay(zmem.get.read(0, fAdr), p.latFeed),
      dv.v)
  }
  val sr = VecInit(Seq.iterate(feedWord, taps)(RegNext(_)))
  require(RL == 2 && p.tRow > RL, "the row keys' tables are read two cycles before their registers")
  val rowAdr1  = Stages.delay(feed.c, p.tRow - RL - 1) // a cycle ahead of rowAdr: the row keys' tables read
  val rowAdr   = RegNext(rowAdr1) // address phase of the variable column's read
  val row      = Stages.delay(rowAdr, RL)
  val rowValid = Stages.delayValid(feed.valid, p.tRow)

  // ---- the sparse row (mpc_cores/minres/band.py): the row's key (position in the period, or a row of the last
  // stage) selects, per slot, an offset o of the window and a coefficient: a constant, or the variable diagonal
  // (dmem) at o = 0. Operands are registered before the products (latMatvec counts that cycle).
  private val dRead  =
    dmem.read(0, adrAt(feed.c, p.tRow - RL)(c => (base2(c.bank, c.slot, nPrimal), Mux(c.r < n.U, 0.U, c.prim))))
  val dot = Module(new FDotProduct(fmt, p.K, p.latMul, p.latAdd, p.dotMove, p.target))
  require(dot.latency + 1 == p.latMatvec, "matvec latency")
  /** f of the row key of c (q: a position in the period, or period + a row of the last stage), read from c's
    * fields (no key adder), two cycles after c: the period's table and the last stage's read at c.r and the stage
    * compare registered, then their select registered, so that the tables and the select take a cycle each */
  private def keyAt[T <: Data](f: Int => T, c: MinresCtl): T =
    RegNext(Mux(RegNext(c.k === T.U), RegNext(VecInit((0 until p.keys - p.period).map(r => f(p.period + r)))(c.r)),
      RegNext(VecInit((0 until p.period).map(f))(c.r))))
  /** f of the row's key, registered at the row */
  private def perKey[T <: Data](f: Int => T): T = keyAt(f, rowAdr)
  private val tabRow = tabs.map(t => Stages.delay(RegNext(t(rowAdr.bank * P.U + rowAdr.slot)), RL - 2))
  for (s <- 0 until p.K) {
    val cands = p.candidates(s)
    val selOf = (q: Int) => p.offsets(q)(s).map(o => cands.indexOf(o)).getOrElse(0).U(log2Ceil(cands.length + 1).W)
    val diag  = perKey(q => p.offsets(q)(s).contains(0).B)
    // the constant: one table, or (several) each table's registered and the row's problem's selected (AND-OR)
    val coef  = tabs match {
      case None    => perKey(q => p.coefs(q)(s).U(W.W))
      case Some(_) =>
        val at = RegNext(tabRow.get)
        p.coefTables.map(c => perKey(q => c(q)(s).U(W.W))).zipWithIndex
          .map { case (v, i) => Mux(at === i.U, v, 0.U) }.reduce(_ | _)
    }
    // whether the slot holds a term: it is used and column e + o is inside the matrix, from compares registered
    // two cycles ahead and the key's offset a cycle ahead, so that the operands' clear is one register
    val insPre  = RegNext(VecInit(cands.map(o => if (o >= 0) rowAdr.e < (N - o).U else rowAdr.e >= (-o).U)))
    val selPre  = keyAt(selOf, rowAdr1)
    val usedPre = keyAt(q => p.offsets(q)(s).isDefined.B, rowAdr1)
    val ok      = RegNext(usedPre && insPre(selPre))
    // the window word at the key's offset, zero without a term: an AND-OR select by one-hot registers (written out:
    // chisel3.util.Mux1H ignores its select when it has a single input)
    val hot     = RegNext(VecInit(cands.indices.map(i => usedPre && insPre(i) && selPre === i.U)))
    dot.io.a(s) := RegNext(Mux(ok, Mux(diag, dRead, coef), zero))
    dot.io.b(s) := RegNext(cands.indices.map(i => Mux(hot(i), sr(M - 1 - cands(i)), zero)).reduce(_ | _))
  }
  val ay   = Timed(dot.io.sum, p.latMatvec)
  // warm form: row i scaled by d_i (its read addressed RL cycles ahead)
  val y    = if (!p.warm) ay else {
    mul(Timed(smem.get.read(1, adrAt(row, ay.t - RL)(c => (base2(c.bank, c.slot, N), inN(c.e)))), ay.t), ay)
  }
  ymem.write(Stages.delayValid(rowValid, y.t), adr1At(row, y.t), y.v)
  // delta = v_j . A v_j (warm form: (d v_j) . (A d v_j), the same sum on the feed's words)
  val dTerm = mul(Timed(sr(M - 1), 0), ay)
  val dAcc  = Module(new FStreamAcc(fmt, N, p.latAdd, p.shareAcc))
  dAcc.io.valid := Stages.delayValid(rowValid, dTerm.t)
  dAcc.io.index := ops.delayTo(row.e, 0, dTerm.t)
  dAcc.io.term  := dTerm.v
  require(dTerm.t + dAcc.latency + 1 + p.tRow + N - 1 == p.tDelta, "delta schedule")
  val dSlot = ops.delayTo(row.slot, 0, dTerm.t + dAcc.latency)
  when(dAcc.io.done) { delta(dSlot) := dAcc.io.sum }

  // ---- pass B: u = (y - delta v_j) - gamma v_{j-1}; ||u||^2; v_j copied into vpmem for the next iteration
  private val (bA, bAdr, bAdrB) = addressPhase(pbA)
  private val bRhs   = bmem.read(0, bAdrB)
  private val bY     = ymem.read(0, bAdr)
  private val bVj    = vmem.read(1, bAdr)
  private val bVjm1  = vpmem.read(0, bAdr)
  private val bA1    = Stages.delay(bA, RL - 1)
  private val bc     = RegNext(bA1)
  private val bValid = Stages.delayValid(pbA.valid, RL + 1)
  // the selects of pass B and C from compares registered beside bc / cc (the same values, off the operand paths)
  private val bInit  = RegNext(bA1.j === 0.U)
  private val bFirst = RegNext(bA1.j <= 1.U)
  val yIn   = Mux(bInit, bRhs, bY)
  val vjB   = Mux(bInit, zero, bVj)
  val vjm1B = Mux(bFirst, zero, bVjm1)
  vpmem.write(bValid, Stages.delay(bAdr, RL), vjB) // bc's address (e < N where valid)
  // warm form, init pass: u = (b - 1 (d A z0)) - 0 0 = b - d A z0
  val dB    = Mux(bInit, if (p.warm) one else zero, delta(bc.slot))
  val mB    = if (p.warm) Mux(bInit, bY, bVj) else vjB
  val gB    = Mux(bInit, zero, gamR(bc.slot))
  val u     = sub(sub(Timed(yIn, 0), mul(Timed(dB, 0), Timed(mB, 0))), mul(Timed(gB, 0), Timed(vjm1B, 0)))
  require(u.t == p.latB, "pass B latency")
  umem.write(Stages.delayValid(bValid, u.t), adr1At(bc, u.t), u.v)
  val nTerm = mul(u, u)
  val nAcc  = Module(new FStreamAcc(fmt, N, p.latAdd, p.shareAcc))
  nAcc.io.valid := Stages.delayValid(bValid, nTerm.t)
  nAcc.io.index := ops.delayTo(bc.e, 0, nTerm.t)
  nAcc.io.term  := nTerm.v
  require(p.tB + N - 1 + nTerm.t + nAcc.latency + 1 == p.tNrm, "norm schedule")
  // ||u||^2 of a slot is done on the cycle before its scalar part starts (tS = tNrm): one register, no slot select
  require(p.tS == p.tNrm, "the norm is done on the cycle before the scalar part")
  private val nrm2 = RegEnable(nAcc.io.sum, nAcc.io.done)

  // ---- scalar part: gamma_{j+1}, Givens rotation (eq. numbers: Elman, Silvester, Wathen Alg. 2.4), the graph of
  // MinresParams.scalarOps once per slot: on one operator per kind (SharedScalar) when the slots are long enough,
  // else on one operator per operation
  private val sc = ps.c
  private val sSlot = sc.slot
  private def at0(v: UInt) = Timed(v, 0)
  private val tS = p.latScalar
  // the other sources are selected by slot a cycle ahead of the trigger into registers (PassCounter.slotAhead), so
  // that the slot's fanout is off the operand paths. That register holds what the select would read on the trigger
  // cycle when no write to the slot lands on the cycle before it: delta's (tDelta - 1 after the start of the slot's
  // pass, once per P S cycles) and the scalar part's own (latScalar after the slot's previous trigger, which came
  // P S or more cycles earlier)
  private val perSlot = Seq("delta" -> delta, "c" -> cR, "cp" -> cpR, "s" -> sR, "sp" -> spR, "gamma" -> gamR,
    "eta" -> etaR)
  private val ahead = P >= 2 && S >= 2 && (p.tS - p.tDelta) % (P * S) != 0 && tS + 1 < P * S
  private val srcs = Map("nrm" -> nrm2) ++ perSlot.map { case (k, v) =>
    k -> (if (ahead) RegNext(v(ps.slotAhead)) else v(sSlot))
  }
  private val res: String => UInt = if (p.sharedScalar) {
    val sh = new SharedScalar(fmt, p.scalarSchedule, ps.first, srcs, p.target)
    name => sh.value(name, tS)
  } else {
    val v = scala.collection.mutable.Map[String, Timed]() ++ srcs.map { case (k, x) => k -> at0(x) }
    for ((name, kind, args) <- p.scalarOps) v(name) = kind match {
      case "mul"  => mul(v(args(0)), v(args(1)))
      case "add"  => add(v(args(0)), v(args(1)))
      case "sub"  => sub(v(args(0)), v(args(1)))
      case "div"  => div(v(args(0)), v(args(1)))
      case "sqrt" => sqrt(v(args(0)))
    }
    require(p.scalarOps.map(o => v(o._1).t).max == tS, "scalar latency")
    name => ops.at(v(name), tS)
  }
  private val Seq(g1d, a1d, a2d, a3d, c1d, s1d, cetaD) = Seq("g1", "a1", "a2", "a3", "c1", "s1", "ceta").map(res)
  private val eta1D = res("seta") ^ (BigInt(1) << (W - 1)).U // eta_{j+1} = -(s eta)
  // the writes' enables decoded a cycle ahead into a register per slot (and per bank and slot for ||r_0||), so
  // that the scalars' clock enables come from registers and not from a decoder of the slot spread over the die
  private val scW1   = ops.delayTo(sc, 0, tS - 1)
  private val scV1   = Stages.delayValid(ps.first, tS - 1)
  private val scInit1 = Stages.delay(sc.j === 0.U, tS - 1) // the init pass, compared at the source
  private val scInit  = RegNext(scInit1)
  private val scWen  = RegNext(VecInit.tabulate(P)(q => scV1 && scW1.slot === q.U), VecInit.fill(P)(false.B))
  private val res0Wen = RegNext(VecInit.tabulate(2 * P)(k => scV1 && scInit1 &&
    scW1.bank === (k / P).U && scW1.slot === (k % P).U), VecInit.fill(2 * P)(false.B))
  for (q <- 0 until P) when(scWen(q)) {
    when(scInit) {
      cR(q) := one; cpR(q) := one; sR(q) := zero; spR(q) := zero
      gamR(q) := g1d; etaR(q) := g1d
    }.otherwise {
      cpR(q) := cR(q); cR(q) := c1d; spR(q) := sR(q); sR(q) := s1d
      gamR(q) := g1d; etaR(q) := eta1D
    }
    g1R(q) := g1d; a1R(q) := a1d; a2R(q) := a2d; a3R(q) := a3d
    cetaR(q) := cetaD
  }
  for (k <- 0 until 2 * P) when(res0Wen(k)) { res0R(k) := g1d }

  // ---- pass C: v_{j+1} = u / gamma_{j+1}; w_{j+1} = ((v_j - a3 w_{j-1}) - a2 w_j) / a1; x += c eta w_{j+1}
  // x is double-buffered by bank: copy 0 for pass C, copy 1 for the output stream of a finished batch.
  private val (cA, cAdr, cAdrB) = addressPhase(pcA)
  private val cU     = umem.read(0, cAdr)
  private val cVj    = vmem.read(2, cAdr)
  private val cW01   = wmem.map(_.read(0, cAdr))
  private val cX0    = xmem.read(0, cAdrB)
  private val cA1    = Stages.delay(cA, RL - 1)
  private val cc     = RegNext(cA1)
  private val cLe1   = RegNext(cA1.j <= 1.U)
  private val cLe2   = RegNext(cA1.j <= 2.U)
  private val cJnz   = RegNext(cA1.j =/= 0.U) // not the init pass: w and x are written (delayed to their writes)
  private val cValid = Stages.delayValid(pcA.valid, RL + 1)
  private val par    = cc.j(0)  // bank of w_j; w_{j-1} and w_{j+1} are in the other
  val uC    = at0(cU)
  val vjC   = at0(cVj)
  val wjm1C = at0(Mux(cLe2, zero, Mux(par, cW01(0), cW01(1))))
  val wjC   = at0(Mux(cLe1, zero, Mux(par, cW01(1), cW01(0))))
  val xC    = at0(Mux(cLe1, zero, cX0))
  val vNew  = div(uC, at0(g1R(cc.slot)))
  val wNew  = div(sub(sub(vjC, mul(at0(a3R(cc.slot)), wjm1C)), mul(at0(a2R(cc.slot)), wjC)), at0(a1R(cc.slot)))
  val xNew  = add(xC, mul(at0(cetaR(cc.slot)), wNew))
  require(vNew.t == p.latCv && wNew.t == p.latCw && xNew.t == p.latCx, "pass C latency")
  vmem.write(Stages.delayValid(cValid, vNew.t), adr1At(cc, vNew.t), vNew.v)
  private val cW  = ops.delayTo(cc, 0, wNew.t)
  private val wEn = Stages.delayValid(cValid, wNew.t) && Stages.delay(cJnz, wNew.t)
  private val wAdr = adr1At(cc, wNew.t)
  for (k <- 0 until 2) wmem(k).write(wEn && cW.j(0) =/= k.U, wAdr, wNew.v) // w_{j+1}: bank (j+1) % 2
  private val cX  = ops.delayTo(cc, 0, xNew.t)
  private val xEn = Stages.delayValid(cValid, xNew.t) && Stages.delay(cJnz, xNew.t)
  xmem.write(xEn, adr2At(cc, xNew.t), xNew.v)
  // set a cycle after the write (the output reads the flag RL - 1 cycles after an issue, which comes no earlier than
  // the batch's last write)
  private val xBadSet = RegNext(xEn && !finite(xNew.v), false.B)
  private val xBadAt  = RegNext(cX.bank * P.U + cX.slot)
  when(xBadSet) { xBad(xBadAt) := true.B }

  // ---- output: per problem the id word, then z (N words from xmem). Words are issued RL cycles ahead of their
  // read into an (RL + 2)-word queue (enough for one word per cycle under any backpressure: a word is issued only
  // if the queue will have room for it and those in flight); m_axis is the queue's head.
  // Batches finish in the order they start, so the output takes the banks in turn (outBank).
  val outBank = RegInit(0.U(1.W))
  val issSlot = RegInit(0.U(log2Ceil(P + 1).W)) // output position: problem issSlot, word issIdx (0: the id word)
  val issIdx  = RegInit(0.U(log2Ceil(N + 2).W))
  // the read address of the next word, base(outBank, issSlot) + max(issIdx - 1, 0), kept in a register
  private val outAdr = RegInit(0.U(adr2(outBank, issSlot, 0.U, N).getWidth.W))
  private val xOut   = xmem.read(1, outAdr)
  private val ob     = outBank * P.U + issSlot
  private val count  = cnt(outBank)
  private val outQn = RL + 2
  val outQ    = Module(new Queue(new MinresOutWord, outQn))
  val issDone = RegInit(false.B)
  private val issueW   = Wire(Bool())
  // the issues of the last RL cycles, the oldest (its word read now) `pending`
  val pending = RegInit(false.B)
  private val earlier  = if (RL == 1) Seq() else Seq.iterate(RegNext(issueW, false.B), RL - 1)(RegNext(_, false.B))
  pending := earlier.lastOption.getOrElse(issueW)
  // the words in the queue and in flight (the queue's count + the issues of the last RL cycles), kept in a
  // register beside its room flag: it grows by an issue and shrinks by an answer's handshake, so no pointer compare
  // lies before the issue (were it low, the queue's overflow assertion would fire; were it high, the output would
  // stall off its cycle contract)
  private val occ  = RegInit(0.U(log2Ceil(outQn + 1).W))
  private val room = RegInit(true.B)
  private val issue = doneB(outBank) && !issDone && room
  private val occNext = occ + issue.asUInt - m_axis.fire.asUInt
  occ    := occNext
  room   := occNext < outQn.U
  issueW := issue
  require(RL >= 2, "the output reads its flags a cycle after the issue")
  private val obLate = Stages.delay(ob, RL - 1) // the flags are read a cycle before the word (xBad's set is late)
  private val oBad   = RegNext(inBad(obLate) || xBad(obLate))
  private def pend[T <: Data](x: T): T = Stages.delay(x, RL)
  private val pendId   = pend(issIdx === 0.U)
  private val pendWord = Cat(oBad, Stages.delay(ids(RegNext(ob)), RL - 1)) // ids of the output's bank: stable, as res0R
  private val lastIdx  = (p.outWords - 1).U
  private val pendLast = pend(issIdx === lastIdx)
  private val pendFin  = pend(issIdx === lastIdx && issSlot === count - 1.U)
  private val pendRes  = pend(issIdx === (N + 1).U)
  // res0R of the output's bank is stable while it is output: the index is registered a cycle ahead of the select
  private val pendR0   = Stages.delay(res0R(RegNext(ob)), RL - 1)
  outQ.io.enq.valid      := pending
  outQ.io.enq.bits.data  := Mux(pendId, pendWord, Mux(pendRes && p.warm.B, pendR0, xOut))
  outQ.io.enq.bits.last  := pendLast
  outQ.io.enq.bits.final_ := pendFin
  outQ.io.enq.bits.badId := pendId && pendWord(31)
  when(issue) {
    issIdx := Mux(issIdx === lastIdx, 0.U, issIdx + 1.U)
    outAdr := Mux(issIdx === lastIdx, adr2(outBank, issSlot + 1.U, 0.U, N), Mux(issIdx === 0.U, outAdr, outAdr + 1.U))
    when(issIdx === lastIdx) {
      issSlot := issSlot + 1.U
      when(issSlot === count - 1.U) { issDone := true.B }
    }
  }
  m_axis.tvalid       := outQ.io.deq.valid
  m_axis.tdata        := outQ.io.deq.bits.data
  m_axis.tlast        := outQ.io.deq.bits.last
  outQ.io.deq.ready   := m_axis.tready
  bus.Protocol.streamOut("m_axis", m_axis)
  bus.Protocol.noOverflow("output queue", outQ.io.enq.valid, outQ.io.enq.ready)
  bus.Protocol.noOverflow("load bank", s_axis.fire, !full(ldBank))
  // the bank is released by its final word's handshake, a flag carried with the word (no count compare after
  // tready)
  when(m_axis.fire) {
    when(outQ.io.deq.bits.badId) { nonfinite := true.B }
    when(outQ.io.deq.bits.last) { regs.solveDone(batchCyc(outBank)) }
    when(outQ.io.deq.bits.final_) {
      issSlot          := 0.U
      issDone          := false.B
      doneB(outBank)   := false.B
      started(outBank) := false.B
      full(outBank)    := false.B
      outBank          := ~outBank
      outAdr           := adr2(~outBank, 0.U, 0.U, N)
    }
  }

  // ---- registers: the shared ones and STATUS.NONFINITE (MinresRegs)
  regs.busy := started.asUInt.orR || full.asUInt.orR || !ldAt0 || ldSlot =/= 0.U || s_axis.fire
  regs.writes()
}
