package ipm

import chisel3._
import chisel3.util._
import float._

/** The units of the Stage 1 engine and its write-back. One element enters per cycle (announced a cycle ahead by
  * `pre`, with its operands a, b, into the op's unit's own registers; then with the input-stream word, its index in
  * the instruction, and its destination address); the unit of `op`
  * returns its result `latency(op)` cycles later (mpc_cores.ipm.isa.latency) with the destination address
  * delayed alongside; each unit's result is registered once more beside it, and `wen`, `wdata`, `waddr` (an OR
  * of those registers) drive the write port of the slot memory a cycle after the result. Instructions do not
  * overlap in here (the engine starts one only after the previous one's last result), so at most one unit
  * returns a result on a cycle.
  *
  *   ADD, SUB   FAdd (lat_add)        MUL FMul (lat_mul)     DIV FDiv (lat_div)     SQRT FSqrt (lat_sqrt)
  *   MIN, MAX, SELNEG   one FCompare (lat_cmp), operands delayed beside it; min(a, b): b < a ? b : a,
  *              max(a, b): a < b ? b : a, NaN if either is NaN; SELNEG: b < 0 ? -a : +inf, NaN if a is NaN
  *   MOV        one register (1), NaN canonicalised
  *   MINRED     a running minimum (2): a new element replaces it only if strictly less (the first of equal
  *              values stays; +0 == -0), a NaN sets a sticky flag; returned two cycles after the last element
  *   ACC        minres.FStreamAcc (lat_add + 1 + lat_add ceil(log2 lat_add)), one per ACC length of the
  *              programs (its length is built in)
  *   IN         the stream word, returned on the cycle it arrives here (0)
  * Reductions write to the destination address of their first element. Every NaN result is the canonical
  * quiet NaN (the float units return it; MOV, MIN, MAX, SELNEG and MINRED substitute it).
  */
class Stage1Alu(p: Stage1Params) extends Module {
  import Isa._
  private val fmt = p.fmt
  private val w   = fmt.width
  val io = IO(new Bundle {
    val op     = Input(UInt(OpW.W))
    val n      = Input(UInt(NW.W))
    val idx    = Input(UInt(NW.W))
    val last   = Input(Bool())
    val pre    = Input(Bool())      // an element enters on the next cycle, with these operands
    val aPre   = Input(UInt(w.W))
    val bPre   = Input(UInt(w.W))
    val inData = Input(UInt(w.W))
    val addr   = Input(UInt(p.memAddrW.W))
    val wen    = Output(Bool())
    val wdata  = Output(UInt(w.W))
    val waddr  = Output(UInt(p.memAddrW.W))
  })
  override def desiredName = s"Stage1Alu_${fmt.tag}"

  // op and n hold for all of an instruction's elements and from at least a cycle before its first (the engine
  // loads them at the launch, 7 cycles ahead): their decode is registered, off the operands' paths
  private val opIs = Isa.ops.indices.map(c => RegNext(io.op === c.U, false.B))
  /** an element of `codes` is here: valid and the op's decode in one register per call, next to the unit that
    * takes it (pre, valid a cycle ahead), so that no valid register drives every unit across the device */
  private def is(codes: Int*): Bool = RegNext(io.pre && codes.map(c => io.op === c.U).reduce(_ || _), false.B)
  /** the operands of the units of `codes`: each unit's own registers next to it, loaded the cycle before its
    * element enters (no shared operand register fanning out to every unit) */
  private def operands(codes: Int*): (UInt, UInt) = {
    val en = io.pre && codes.map(opIs(_)).reduce(_ || _)
    (RegEnable(io.aPre, en), RegEnable(io.bPre, en))
  }
  private val qnan    = fmt.qNaN.U(w.W)
  private val posInf  = fmt.inf(false).U(w.W)
  private val signBit = (BigInt(1) << (w - 1)).U(w.W)
  private def isNaN(x: UInt): Bool = x(w - 2, fmt.manW).andR && x(fmt.manW - 1, 0).orR

  /** tap(l): the destination address of the element that entered l cycles ago */
  private val tap = (1 to p.maxTap).scanLeft(io.addr)((x, _) => RegNext(x))
  /** reductions write to the address of their first element */
  private val redAddr = Reg(UInt(p.memAddrW.W))
  when(is(ACC, MINRED) && io.idx === 0.U) { redAddr := io.addr }

  private val add = Module(new FAdd(fmt, p.latAdd))
  add.in_valid := is(ADD, SUB)
  private val (addA, addB) = operands(ADD, SUB)
  add.a        := addA
  add.b        := addB
  add.sub      := opIs(SUB)
  private val mul = Module(new FMul(fmt, p.latMul, p.target))
  mul.in_valid := is(MUL)
  private val (mulA, mulB) = operands(MUL)
  mul.a        := mulA
  mul.b        := mulB
  private val div = Module(new FDiv(fmt, p.latDiv))
  div.in_valid := is(DIV)
  private val (divA, divB) = operands(DIV)
  div.a        := divA
  div.b        := divB
  private val sqrt = Module(new FSqrt(fmt, p.latSqrt))
  sqrt.in_valid := is(SQRT)
  sqrt.a        := operands(SQRT)._1

  // ---- MIN, MAX, SELNEG: one comparator; MIN compares b < a, MAX a < b, SELNEG b < +0
  private val isMin = opIs(MIN)
  private val isSel = opIs(SELNEG)
  private val cmp   = Module(new FCompare(fmt, p.latCmp))
  cmp.in_valid  := is(MIN, MAX, SELNEG)
  private val (cmpA, cmpB) = operands(MIN, MAX, SELNEG)
  // the comparator's own operands, ordered as they are loaded (opIs is valid on every pre cycle of its instruction:
  // the engine loads the op at the launch, 7 cycles before the first), so that no decode is ahead of the compare
  private val cmpEn = io.pre && (isMin || isSel || opIs(MAX))
  cmp.a         := RegEnable(Mux(isMin || isSel, io.bPre, io.aPre), cmpEn)
  cmp.b         := RegEnable(Mux(isMin, io.aPre, Mux(isSel, 0.U, io.bPre)), cmpEn)
  cmp.signaling := false.B
  private val cA     = Stages.delay(cmpA, p.latCmp)
  private val cB     = Stages.delay(cmpB, p.latCmp)
  private val cSel   = Stages.delay(isSel, p.latCmp)
  private val cmpOut = Mux(cSel, Mux(isNaN(cA), qnan, Mux(cmp.lt, cA ^ signBit, posInf)),
    Mux(isNaN(cA) || isNaN(cB), qnan, Mux(cmp.lt, cB, cA)))

  // ---- MOV
  private val movValid = RegNext(is(MOV), false.B)
  private val movA     = operands(MOV)._1
  private val movOut   = RegNext(Mux(isNaN(movA), qnan, movA))

  // ---- MINRED: the running minimum compares order keys, made a cycle ahead of it: a word's bits as an unsigned
  // number in the order of its value (negative: the bits inverted; else the sign bit set; -0 as +0), so that the
  // loop from the minimum's register to its enable is one unsigned compare. A NaN sets a sticky flag instead.
  private val redA = operands(MINRED)._1
  private def orderKey(x: UInt): UInt = {
    val neg = x(w - 1) && x(w - 2, 0).orR
    Mux(neg, ~x, x | signBit)
  }
  private val redV     = RegNext(is(MINRED), false.B)
  private val redFirst = RegNext(io.idx === 0.U)
  private val redWord  = RegNext(redA)
  private val redKey   = RegNext(orderKey(redA))
  private val redNaN   = RegNext(isNaN(redA))
  private val minReg   = Reg(UInt(w.W))
  private val minKey   = Reg(UInt(w.W))
  private val minNaN   = Reg(Bool())
  when(redV) {
    when(redFirst || redKey < minKey) {
      minReg := redWord
      minKey := redKey
    }
    minNaN := redNaN || !redFirst && minNaN
  }
  private val minValid = Stages.delayValid(is(MINRED) && io.last, 2)

  // ---- ACC: one streaming accumulator per length
  private val accA = operands(ACC)._1
  private val accs = p.accLengths.map { n =>
    val acc = Module(new minres.FStreamAcc(fmt, n, p.latAdd))
    acc.io.valid := is(ACC) && RegNext(io.n === n.U, false.B)
    acc.io.index := io.idx
    acc.io.term  := accA
    (acc.io.done, acc.io.sum, redAddr)
  }

  private val results: Seq[(Bool, UInt, UInt)] = Seq(
    (add.out_valid, add.out, tap(p.latAdd)),
    (mul.out_valid, mul.out, tap(p.latMul)),
    (div.out_valid, div.out, tap(p.latDiv)),
    (sqrt.out_valid, sqrt.out, tap(p.latSqrt)),
    (cmp.out_valid, cmpOut, tap(p.latCmp)),
    (movValid, movOut, tap(1)),
    (minValid, Mux(minNaN, qnan, minReg), redAddr),
    (is(IN), io.inData, tap(0))
  ) ++ accs
  // each unit's result registered beside it, zero unless valid, so that the write-back's select is an OR of
  // registers (not a one-hot select behind every unit's valid); the write port takes it a cycle later
  private val held = results.map { case (v, d, a) => (RegNext(v, false.B), RegNext(Mux(v, d, 0.U)), RegNext(Mux(v, a, 0.U))) }
  io.wen   := held.map(_._1).reduce(_ || _)
  io.wdata := held.map(_._2).reduce(_ | _)
  io.waddr := held.map(_._3).reduce(_ | _)
}
