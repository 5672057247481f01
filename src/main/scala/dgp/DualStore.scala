package dgp

import chisel3._
import chisel3.util._
import mem.KeepReg

/** The DGP core's dual vectors in banks: the dual y and (accelerated) the extrapolated dual wy and its candidate,
  * each word both halves (upper rows, then lower rows, of one constraint row).
  *
  * Row r of a vector is in bank r mod B at address r / B. B is the lanes times m = ceil(P / lanes), so that a pass K
  * chunk j reads lane l's word (row j lanes + l) from bank l + lanes (j mod m), and the element stage's P rows of a
  * round (k P .. k P + P - 1, one per unit) are in P different banks. A bank holds ceil(rows / B) words in
  * registers, with one write port (each word's enable decoded from the address) and one read port whose address is
  * registered; the read data are registered at the bank and selected by the lanes (pass K) or the units (the
  * element stage) a cycle later. (In ECP5 distributed RAM, which only some slices hold, the banks of the bench's
  * row-unit core did not route.)
  *
  * Accelerated, three buffers of banks: Y holds y; of B0 and B1, one is the candidate (cBuf) and the other the
  * extrapolated dual, unless that is y (eIsY: after a start or a restart). So the decision's select (y on a restart,
  * else the candidate) and the start's copy of y are a flag and a buffer index, not a load of every word. A cold
  * start's clear is a flag (zero) that makes every read of y and wy zero until the next decision, by which the
  * element stage has written every row of y and of the candidate. Plain: Y only, and wy is y.
  *
  * Timing: pass K's chunk (chunkNext, the chunk's next value at the issue) is registered at the banks in the issue
  * cycle, the read's address in cycle 1 (the data registered at the bank), `kOp` in cycle 2. An element read
  * (rdGo, the unit's rows in order, rG of them each iteration) gives its row's words in `eRow` and `yRow` three
  * cycles later. A write (yWr, cWr, the unit's rows in order) is registered and reaches its bank a cycle later. The
  * roles change at `decide` (a flip-flop, with `restart`) and `start` (with `cold`); their copies at the banks a
  * cycle later, so a read's address may follow two cycles after.
  */
class DualStore(p: DgpParams, fpga: Boolean, chunkW: Int) extends Module {
  import p.{lanes, mc, rG, cK}
  val P = p.units
  val W = p.dataW
  val acc = p.accelerated
  /** banks: lanes times m, at least P */
  val m: Int = (P + lanes - 1) / lanes
  val B: Int = lanes * m
  /** rows the element stage writes (rG per unit, the last rounds' missing rows zero) and rows pass K reads */
  val rowsE: Int = rG * P
  val rowsK: Int = cK * lanes
  val depth: Int = (math.max(rowsE, rowsK) - 1) / B + 1
  val aW: Int = log2Ceil(depth).max(1)
  val buffers: Int = if (acc) 3 else 1
  def word: Vec[SInt] = Vec(2, SInt(W.W))

  val io = IO(new Bundle {
    val chunkNext = Input(UInt(chunkW.W))
    /** pass K's operand, lane l's word of wy (both halves), in cycle 2 of its chunk's issue */
    val kOp     = Output(Vec(lanes, word))
    val rdGo    = Input(Vec(P, Bool()))
    val eRow    = Output(Vec(P, word))
    val yRow    = Output(Vec(P, word))
    val yWr     = Input(Vec(P, Valid(word)))
    val cWr     = Input(Vec(P, Valid(word)))
    val start   = Input(Vec(P, Bool()))
    val cold    = Input(Vec(P, Bool()))
    val decide  = Input(Vec(P, Bool()))
    val restart = Input(Vec(P, Bool()))
  })

  // ------------------------------------------------------------------ roles, per unit
  val eIsY = RegInit(VecInit(Seq.fill(P)(true.B)))
  val cBuf = RegInit(VecInit(Seq.fill(P)(false.B)))
  val zero = RegInit(VecInit(Seq.fill(P)(true.B)))
  for (u <- 0 until P) {
    when(io.start(u)) { eIsY(u) := true.B; zero(u) := io.cold(u) }
    when(io.decide(u)) {
      eIsY(u) := io.restart(u)
      when(!io.restart(u)) { cBuf(u) := !cBuf(u) }
      zero(u) := false.B
    }
  }
  /** bank b's copy of a unit's register (unit b mod P's): kept apart on FPGA targets */
  def atBank[T <: Data](x: Vec[T], b: Int): T = if (fpga) KeepReg(x(b % P)) else RegNext(x(b % P))

  // ------------------------------------------------------------------ the units' walks over the banks
  /** a unit's position in its rows: the bank (one-hot), the address, the row; `step` moves to the next row (after
    * the last, back to the first) */
  class Walk(u: Int) {
    val oh   = RegInit(VecInit((0 until B).map(b => (b == u).B)))
    val addr = RegInit(0.U(aW.W))
    val k    = RegInit(0.U(log2Ceil(rG + 1).W))
    def step(): Unit = {
      when(k === (rG - 1).U) {
        k := 0.U; addr := 0.U
        oh := VecInit((0 until B).map(b => (b == u).B))
      }.otherwise {
        k := k + 1.U
        oh := VecInit((0 until B).map(b => oh((b - P + B) % B)))
        when(VecInit((B - P until B).map(oh(_))).asUInt.orR) { addr := addr + 1.U }
      }
    }
  }
  /** the banks unit u's rows visit */
  def banksOf(u: Int): Seq[Int] = (0 until rG).map(k => (k * P + u) % B).distinct.sorted
  def unitsOf(b: Int): Seq[Int] = (0 until P).filter(u => banksOf(u).contains(b))

  // ------------------------------------------------------------------ writes: registered, then at the banks
  class WriteReq extends Bundle {
    val valid = Bool(); val oh = Vec(B, Bool()); val addr = UInt(aW.W); val data = UInt((2 * W).W)
  }
  def writes(req: Vec[Valid[Vec[SInt]]]): Seq[WriteReq] = (0 until P).map { u =>
    val w = new Walk(u)
    when(req(u).valid) { w.step() }
    val r = Wire(new WriteReq)
    r.valid := req(u).valid; r.oh := w.oh; r.addr := w.addr; r.data := req(u).bits.asUInt
    RegNext(r, 0.U.asTypeOf(new WriteReq))
  }
  val yW = writes(io.yWr)
  val cW = if (acc) writes(io.cWr) else Nil

  // ------------------------------------------------------------------ reads
  val rd = (0 until P).map(u => new Walk(u))
  for (u <- 0 until P) when(io.rdGo(u)) { rd(u).step() }
  /** pass K's address and its mask (the rows past those the element stage writes) by chunk, per bank */
  private def kAddr(j: Int): Int = j / m
  val chunkG = (0 until (B + 3) / 4).map(_ => if (fpga) KeepReg(io.chunkNext) else RegNext(io.chunkNext))
  val mems = Seq.fill(buffers, B)(Reg(Vec(depth, UInt((2 * W).W))))
  val eBank = Reg(Vec(B, UInt((2 * W).W)))
  val yBank = Reg(Vec(B, UInt((2 * W).W)))
  for (b <- 0 until B) {
    val (eIsYb, cBufb, zerob) = (atBank(eIsY, b), atBank(cBuf, b), atBank(zero, b))
    // writes: y to Y; the candidate to the B that is not wy
    def port(reqs: Seq[WriteReq], us: Seq[Int]): (Bool, UInt, UInt) = {
      val hits = us.map(u => reqs(u).valid && reqs(u).oh(b))
      (VecInit(hits).asUInt.orR, Mux1H(hits, us.map(reqs(_).addr)), Mux1H(hits, us.map(reqs(_).data)))
    }
    val us = unitsOf(b)
    if (us.nonEmpty) {
      val (yWe, yWa, yWd) = port(yW, us)
      when(yWe) { mems(0)(b)(yWa) := yWd }
    }
    if (acc && us.nonEmpty) {
      val (cWe, cWa, cWd) = port(cW, us)
      when(cWe && !cBufb) { mems(1)(b)(cWa) := cWd }
      when(cWe && cBufb) { mems(2)(b)(cWa) := cWd }
    }
    // the read address: a unit's element read, else pass K's by the chunk
    val hits = us.map(u => io.rdGo(u) && rd(u).oh(b))
    val chunk = chunkG(b / 4)
    val kA = VecInit((0 until (1 << chunkW)).map(j => kAddr(j).min(depth - 1).U(aW.W)))(chunk)
    val kPast = VecInit((0 until (1 << chunkW)).map(j => (kAddr(j) * B + b >= rowsE).B))(chunk)
    val anyHit = if (us.isEmpty) false.B else VecInit(hits).asUInt.orR
    val addrR = RegNext(if (us.isEmpty) kA else Mux(anyHit, Mux1H(hits, us.map(rd(_).addr)), kA))
    val pastR = RegNext(!anyHit && kPast, false.B)
    val data = mems.map(_(b)(addrR))
    val masked = zerob || pastR
    yBank(b) := Mux(masked, 0.U, data(0))
    eBank(b) := Mux(masked, 0.U, if (acc) Mux(eIsYb, data(0), Mux(cBufb, data(1), data(2))) else data(0))
  }
  def halves(x: UInt): Vec[SInt] = x.asTypeOf(word)
  // pass K: lane l's bank of chunk j is l + lanes (j mod m)
  val jSel = ShiftRegister(chunkG.head % m.U, 2)
  for (l <- 0 until lanes)
    io.kOp(l) := halves(if (m == 1) eBank(l) else VecInit((0 until m).map(i => eBank(l + lanes * i)))(jSel))
  // the element stage: the unit's bank, a cycle behind its address
  for (u <- 0 until P) {
    val sel = RegNext(RegNext(rd(u).oh))
    val bs = banksOf(u)
    io.eRow(u) := RegNext(halves(Mux1H(bs.map(sel(_)), bs.map(eBank(_)))))
    io.yRow(u) := RegNext(halves(Mux1H(bs.map(sel(_)), bs.map(yBank(_)))))
  }
}
