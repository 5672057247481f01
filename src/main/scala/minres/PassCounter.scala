package minres

import chisel3._
import chisel3.util._

/** Control word of one element of a pass: problem slot, element (row) index, iteration (0 = the init pass), and
  * for the feed the position of the row in the MPC structure (row r of stage k, primal index).
  */
class MinresCtl(p: MinresParams) extends Bundle {
  val bank = UInt(1.W) // the batch's bank of the double-buffered memories
  val e    = UInt(log2Ceil(p.S + 1).W)
  val slot = UInt(math.max(1, log2Ceil(p.P)).W)
  val j    = UInt(16.W)
  val r    = UInt(log2Ceil(p.period + 1).W)
  val k    = UInt(log2Ceil(p.T + 2).W)
  val prim = UInt(log2Ceil(p.nPrimal + 1).W)
}

/** A word of the output stream on its way to m_axis. */
class MinresOutWord extends Bundle {
  val data  = UInt(32.W)
  val last  = Bool()
  val final_ = Bool() // the last word of the bank's last problem: its fire releases the bank
  val badId = Bool() // an id word with bit 31 set (STATUS.NONFINITE when it is sent)
}

/** Counter of a pass: elements 0..S-1 of slots 0..P-1 of iterations 0..Imax of one batch, one element per cycle.
  * It latches the batch's Imax and bank at its start, so that it finishes its own batch while the next one
  * starts: a batch starts no earlier than the cycle on which the previous batch's feed takes its last element,
  * so each pass starts the next batch on or after its own last cycle of the previous one.
  */
class PassCounter(p: MinresParams) {
  require(p.S * p.P >= 2, s"a pass needs at least 2 elements (S P): got S=${p.S}, P=${p.P}")
  val run  = RegInit(false.B)
  val c    = RegInit(0.U.asTypeOf(new MinresCtl(p)))
  // the count's next value (tick assigns it): what elementAdr loads at a slot's start
  private val nxt = WireDefault(c)
  c := nxt
  val imax = RegInit(0.U(16.W))
  /** imax === 0, beside it */
  val imaxZero = RegInit(false.B)
  // the count's last element, last slot and last iteration as flags beside it, set a cycle ahead, so that the
  // counter's decisions are registers
  private val lastE    = RegInit(false.B)
  private val lastSlot = RegInit(false.B)
  private val lastJ    = RegInit(false.B)
  // c.j + 1 === imax, registered: c.j and imax change at most once per pass of S P >= 2 cycles, and the flag is
  // read at a pass's last element, so it is current there; no compare lies between the count and lastJ
  private val jLast    = RegNext(c.j + 1.U === imax, false.B)
  /** an element of the matrix order is processed this cycle */
  def valid: Bool = run && c.e < p.N.U
  /** element 0 of a slot is processed this cycle (valid && c.e === 0): a register of its own, set a cycle ahead */
  val first = RegInit(false.B)
  /** on the cycle before a slot's first element (and while the count is stopped: slot 0), that slot: a register
    * set on the slot's element S - 2 of the previous slot (needs S >= 2), so that a select by slot can be registered
    * ahead of the slot's start */
  val slotAhead = RegInit(0.U(chiselTypeOf(c.slot).getWidth.W))
  private val started = WireDefault(false.B) // tick's start
  /** f(c, inN(c.e)) for an address f(c, e) = base(bank, slot) + e, with inN(e) = e for e < n, else 0: a register
    * that counts up along a slot and is loaded with the base (f of the next count at e = 0) at a slot's start
    * and once its element passes n - 1, so that no compare or adder lies between the count and it */
  def elementAdr(f: (MinresCtl, UInt) => UInt, n: Int): UInt = {
    val a = Reg(chiselTypeOf(f(c, c.e)))
    // c.e >= n - 1 as a flag beside the count, set a cycle ahead (the count's next e is 0 after a slot's last
    // element and at a start, else e + 1), so that the load select is a function of registers
    val past = if (n <= 1) true.B else RegInit(false.B)
    if (n > 1) when(started) { past := false.B }.elsewhen(run) { past := !lastE && (past || c.e === (n - 2).U) }
    when(started || run && (lastE || past)) { a := f(nxt, 0.U) }
      .elsewhen(run) { a := a + 1.U }
    a
  }
  /** `imaxInZero`: imaxIn === 0, when the caller has it as a register (else it is decoded here) */
  def tick(start: Bool, imaxIn: UInt, bank: UInt, imaxInZero: Option[Bool] = None): Unit = {
    val zero = imaxInZero.getOrElse(imaxIn === 0.U)
    started := start
    when(start) {
      run      := true.B
      nxt      := 0.U.asTypeOf(c)
      nxt.bank := bank
      imax     := imaxIn
      imaxZero := zero
      first    := true.B
      lastE    := (p.S == 1).B
      lastSlot := (p.P == 1).B
      lastJ    := zero
    }.elsewhen(run) {
      first := lastE && !(lastSlot && lastJ) // run stays on after this cycle
      lastE := (if (p.S == 1) true.B else !lastE && c.e === (p.S - 2).U)
      if (p.S >= 2) when(!lastE && c.e === (p.S - 2).U) { slotAhead := Mux(lastSlot, 0.U, c.slot + 1.U) }
      nxt.e := Mux(lastE, 0.U, c.e + 1.U)
      // position in the MPC structure: rows r = 0..2n+m-1 of stages k = 0..T, primal rows counted
      val lastR = c.r === (p.period - 1).U
      nxt.r    := Mux(lastE, 0.U, Mux(lastR, 0.U, c.r + 1.U))
      nxt.k    := Mux(lastE, 0.U, Mux(lastR, c.k + 1.U, c.k))
      nxt.prim := Mux(lastE, 0.U, Mux(c.r >= p.n.U, c.prim + 1.U, c.prim))
      when(lastE) {
        nxt.slot := Mux(lastSlot, 0.U, c.slot + 1.U)
        lastSlot := (if (p.P == 1) true.B else !lastSlot && c.slot === (p.P - 2).U)
        when(lastSlot) {
          nxt.j := c.j + 1.U
          lastJ := jLast
          when(lastJ) { run := false.B }
        }
      }
    }.otherwise {
      first := false.B
    }
  }
}
