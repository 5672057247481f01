package ipm

import chisel3._
import chisel3.util._
import float.Stages

/** Stage 1 of the interior-point core (001, section VI-C): the sequential floating-point vector machine of
  * mpc_cores/ipm/isa.py, bit-exact with its interpreter (mpc_cores/ipm/machine.py).
  *
  * Interface. `start` (with `prog`, `slot`) runs program `prog` on slot `slot`; it is taken when the engine is
  * idle or on the cycle `done` is high (and ignored for a `prog` beyond the programs; `slot` must be < slots). `busy` is high from the cycle after `start` to `done` included. A
  * program started on cycle s raises `done` on cycle s + cycles(program) with cycles as
  * mpc_cores.ipm.isa.cycles when the streams do not stall (1 + the sum over the instructions of n + latency + 7); its
  * last result reaches the write port two cycles after `done`, before any read of a program started on the `done`
  * cycle, so back-to-back programs run as one. IN takes words from `s_axis` (the format's word in the low bits
  * of tdata), OUT writes them to `m_axis` (tlast on an instruction's last word) through an 8-word buffer; both
  * wait for the other side, the only data-dependent timing.
  *
  * Pipeline, one element per cycle:
  *   T  issue: element index. The index tables (one per role d, a, b that gathers or scatters) were read on the
  *      cycle before, in two copies: at the address of the element at T (the instruction's table base, registered
  *      when its word was fetched, + the index) and at it + 1, both kept in registers, so that neither the issue
  *      decision nor an adder lies before a ROM
  *   G  table words out of their ROMs (each ROM's second register: on the ECP5 its block RAM's own), the copy
  *      picked by whether the element before issued, registered in the fabric
  *   M  addresses: operand base (the slot's base + the operand's address, registered at the instruction's
  *      launch) + the index or the table word, registered
  *   A  slot memory and constant ROMs read at them (one copy per operand a, b)
  *   R  memory words out, registered per bank of the slot memory (SlotMem) and in the constant ROMs (as the table ROMs)
  *   Q  the words registered once more in the fabric next to their block RAMs, which lie far from the units
  *   S  bank select and operand select (slot or constant), registered once per operand (the memories and the
  *      units lie far apart: this register splits the route between them)
  *   D  the operands into the op's unit's own registers (each unit has its operand registers, Stage1Alu)
  *   U  operands ready; into the unit of the op (Stage1Alu), result latency(op) cycles later (at the write port
  *      a cycle after).
  * Every block RAM's output and every address adder ends in a register, so no path runs from one memory
  * through an adder into another, nor from a memory into a unit.
  * The instruction ROM is read ahead: the word at the program counter is decoded into a register (with its
  * table bases) before its launch, so a program's first instruction launches two cycles after `start` (one cycle
  * per program, Stage1Params.ProgramStart).
  * An instruction issues its n elements on consecutive cycles (IN: when a word is there; OUT: when the output
  * buffer has room for the words in flight, a credit counter) and the next one issues latency + 8 cycles after
  * its last element, that is on the cycle its last result leaves its unit: that result reaches the write port a
  * cycle later (Stage1Alu) and the slot memory the cycle after, and the new instruction's first read is three
  * cycles after the issue. The
  * sequencer decides from flags registered a cycle ahead (gap = 0 or 1, last element, last instruction, IN or
  * OUT), so no compare or adder lies between its registers and the issue. So instructions run
  * strictly one after another and an instruction never reads a word it writes itself later (the programs keep
  * the write of element i away from the reads of the elements after i: mpc_cores.ipm.isa.stream_hazards).
  *
  * Memories. The slot memory (slots x slot_words words) is two copies written identically (SlotMem, banks of
  * block RAMs with their output register), copy 0 read by operand a and copy 1 by operand b (one read and one
  * write port each: DP16KD on ECP5); the constant region is
  * a ROM per operand that reads it, the index tables one ROM per role, the program a ROM of instruction words
  * (mem.InitRam, contents in the emitted Verilog). Only the copies the programs use are built.
  */
class Stage1Engine(p: Stage1Params) extends Module {
  import Isa._
  /** output buffer: one word per pipeline stage (G, M, A, R, Q, S, D, U) and one more, so that OUT streams without a gap */
  private val OutDepth = 9
  override def desiredName = p.moduleName
  private val w = p.fmt.width
  /** block RAMs as DP16KD with their output register where they have one (SlotMem, the registered ROMs) */
  private val ecp5 = p.target == dsp.Target.Ecp5

  val start  = IO(Input(Bool()))
  val prog   = IO(Input(UInt(p.progW.W)))
  val slot   = IO(Input(UInt(p.slotW.W)))
  val busy   = IO(Output(Bool()))
  val done   = IO(Output(Bool()))
  val s_axis = IO(Flipped(new bus.AxiStreamIO(32)))
  val m_axis = IO(new bus.AxiStreamIO(32))

  private def table[T <: Data](values: Seq[T], size: Int, fill: T): Vec[T] = VecInit(values.padTo(size, fill))

  // ---- sequencer
  private val maxLat   = Isa.ops.indices.map(p.latency).max
  private val running  = RegInit(false.B)
  private val issuing  = RegInit(false.B)
  private val gap      = RegInit(0.U(log2Ceil(maxLat + Stage1Params.IssueGap + 1).W))
  private val pc       = Reg(UInt(p.pcW.W))
  private val pcEnd    = Reg(UInt(p.pcW.W))
  private val slotBase = Reg(UInt(p.memAddrW.W))
  private val cur      = Reg(new InstrBits)
  private val slotBases = table(Seq.tabulate(p.slots)(k => (k * p.slotWords).U(p.memAddrW.W)), 1 << p.slotW,
    0.U(p.memAddrW.W))
  // several constant banks: the slot's bank, (slot mod banks) times the bank's words
  private val constBaseW = log2Ceil(p.constWords.length)
  private val constBase  = Option.when(p.constBanks > 1)(Reg(UInt(constBaseW.W)))
  private val constBases = Option.when(p.constBanks > 1)(table(Seq.tabulate(p.slots)(k =>
    (k % p.constBanks * p.constLen).U(constBaseW.W)), 1 << p.slotW, 0.U(constBaseW.W)))
  private val i        = Reg(UInt(NW.W))

  private val entry  = table(p.entries.init.map(_.U(p.pcW.W)), 1 << p.progW, 0.U(p.pcW.W))
  private val ends   = table(p.entries.tail.map(_.U(p.pcW.W)), 1 << p.progW, 0.U(p.pcW.W))
  private val latOf  = table(Isa.ops.indices.map(o => p.latency(o).U(gap.getWidth.W)), 1 << OpW, 0.U(gap.getWidth.W))
  // the control decisions come from flags registered a cycle ahead: gap = 0, gap = 1, pc = pcEnd
  private val gapZero = RegInit(true.B)
  private val gapOne  = RegInit(false.B)
  private val atEnd   = RegInit(true.B)
  private val finish = running && !issuing && gapOne && atEnd
  // a start is taken into a register (with its program and slot) and acted on a cycle later, so the caller's
  // decisions meet registers here; the first word is still read from its table in the cycle of the start, and
  // the first launch stays two cycles after it
  private val startR = RegInit(false.B)
  startR := start && (!running && !startR || finish) && prog < p.programs.length.U
  private val progR  = RegNext(prog)
  private val slotR  = RegNext(slot)
  private val accept = startR
  // a launch is due when the gap ends (gapOne: it ends on the next cycle) or a cycle after an accept; it is kept
  // in a register so that the issue decision below starts at registers. The gap's end is itself a register, set
  // a cycle ahead (the count at 2), so that the table ROMs' addresses (below) are one select of registers.
  private val gapEnd    = RegNext(running && !issuing && !gapZero && gap === 2.U && !atEnd, false.B)
  assert(gapEnd === (running && !issuing && !gapZero && gapOne && !atEnd),
    "Stage1Engine: gap end register out of step")
  private val launchNxt = accept || gapEnd
  private val launch    = RegNext(launchNxt, false.B)
  assert(launch === (running && !issuing && gapZero && !atEnd), "Stage1Engine: launch register out of step")
  // the ROM word of pc, or a program's first word from a table of its own (a register either way): `prog` comes
  // from the caller's decisions in the cycle of the start and meets only that table, not the ROM's decoder
  private val firstWord = table(p.entries.init.map(e => p.code(e).U(InstrW.W)), 1 << p.progW, 0.U(InstrW.W))
  private val codeAtPc  = Rom("Stage1Code", p.code, InstrW, pc, clock)
  private val codeFirst = RegNext(firstWord(prog))
  private val code      = Mux(RegNext(running && !finish), codeAtPc, codeFirst)
  busy := running || startR
  done := finish

  // the instruction at pc, decoded, and its table bases, registered ahead of its launch (the ROM word of the pc
  // of cycle t is here on t + 2: pc moves at a launch and the next launch is at least 7 cycles later)
  private val tableBase = table(p.tableBase.init.map(_.U(17.W)), 1 << TableW, 0.U(17.W))
  private val word      = InstrBits.decode(code)
  private val nxt       = RegNext(word)
  private def bases(x: InstrBits): Vec[UInt] = VecInit(Seq(x.d, x.a, x.b).map(o => tableBase(o.table)))
  private val nxtTab    = RegNext(bases(word))
  private val nxtOne    = RegNext(word.n === 1.U)
  private val nxtTwo    = RegNext(word.n === 2.U)
  private val nxtLeft   = RegNext(word.n - 1.U) // elements after the first
  private val nxtIn     = RegNext(word.op === IN.U)
  private val nxtOut    = RegNext(word.op === OUT.U)
  private val curIn     = RegInit(false.B)
  private val curOut    = RegInit(false.B)
  private val isLast    = Reg(Bool()) // element i of cur is its last
  private val left      = Reg(UInt(NW.W)) // elements of cur after element i

  // ---- T: issue
  private val ins     = Mux(launch, nxt, cur)
  private val iT      = Mux(launch, 0.U, i)
  private val lastT   = Mux(launch, nxtOne, isLast)
  private val insIn   = Mux(launch, nxtIn, curIn)
  private val insOut  = Mux(launch, nxtOut, curOut)
  private val outQ    = Module(new bus.FlowQueue(UInt((w + 1).W), OutDepth))
  // OUT words in flight or in the buffer at most OutDepth: one credit per free place
  private val credit  = RegInit(OutDepth.U(log2Ceil(OutDepth + 1).W))
  private val active  = launch || issuing
  // whether the instruction's element can issue (IN: an input word; OUT: a credit), for the one launching and for
  // the one issuing, picked by the launch register last
  private val room    = credit =/= 0.U
  private val issue   = Mux(launch, Mux(nxtIn, s_axis.tvalid, !nxtOut || room),
    issuing && Mux(curIn, s_axis.tvalid, !curOut || room))
  s_axis.tready := active && insIn
  credit := credit - (issue && insOut).asUInt + outQ.io.deq.fire.asUInt

  when(running && !issuing && !gapZero) {
    gap     := gap - 1.U
    gapZero := gap === 1.U
    gapOne  := gap === 2.U
  }
  when(launch) {
    cur     := ins
    curIn   := nxtIn
    curOut  := nxtOut
    isLast  := nxtOne
    left    := nxtLeft
    issuing := true.B
    pc      := pc + 1.U
    atEnd   := pc + 1.U === pcEnd
    i       := 0.U
  }
  when(issue) {
    i      := iT + 1.U
    // the next element is the last when one follows this one: a compare on a register, no adder ahead of it
    val leftT = Mux(launch, nxtLeft, left)
    left   := leftT - 1.U
    isLast := Mux(launch, nxtTwo, left === 1.U)
    when(lastT) {
      issuing := false.B
      gap     := latOf(ins.op) + Stage1Params.IssueGap.U
      gapZero := false.B
      gapOne  := false.B
    }
  }
  when(finish) { running := false.B }
  when(accept) { // a cycle after the start: the first instruction launches on the next cycle
    running  := true.B
    issuing  := false.B
    gap      := 0.U
    gapZero  := true.B
    gapOne   := false.B
    pc       := entry(progR)
    pcEnd    := ends(progR)
    atEnd    := false.B // programs are not empty (Stage1Params)
    slotBase := slotBases(slotR)
    constBase.foreach(_ := constBases.get(slotR))
  }

  // The table words are read a cycle ahead of T, from two copies of each table ROM: copy 0 at the address of the
  // element at T now (or at the next instruction's base when it launches next), copy 1 at that address + 1. On the
  // cycle the words leave the ROMs (G), the issue decision of the cycle they were read on selects one, and the word
  // is registered in the fabric (M), where the operand address adders take it. adr0 and adr1 are registers (the
  // address at T and it + 1), so no issue logic or adder lies before a ROM; the table words reach the adders from a
  // register of their own, not from a block RAM across the device.
  private def plus1(v: Vec[UInt]): Vec[UInt] = VecInit(v.map(_ + 1.U))
  private val firstBases = bases(InstrBits.decode(firstWord(prog))) // a program's first instruction's, at its start
  private val firstTab   = RegNext(firstBases)
  private val firstTab1  = RegNext(plus1(firstBases))
  private val nxtTab1    = RegNext(plus1(bases(word)))
  // the bases at the next launch (the first instruction's in the cycle of an accept: nxtTab takes them a cycle later)
  private val baseNxt  = Mux(accept, firstTab, nxtTab)
  private val baseNxt1 = Mux(accept, firstTab1, nxtTab1)
  private val adr0 = Reg(Vec(3, UInt(17.W)))
  private val adr1 = Reg(Vec(3, UInt(17.W)))
  for (k <- 0 until 3) {
    adr0(k) := Mux(launchNxt, baseNxt(k), Mux(issue, adr1(k), adr0(k)))
    adr1(k) := Mux(launchNxt, baseNxt1(k), Mux(issue, adr1(k) + 1.U, adr1(k)))
  }
  private val pick = Stages.delay(issue && !launchNxt, 2) // at G: the word of copy 1
  private def tableRom(role: String, used: Boolean, k: Int): UInt =
    if (used) {
      def copy(c: Int, a: UInt) = Rom.registered(s"Stage1Table$role$c", p.tableWords.map(BigInt(_)), p.tableW, a,
        clock, ecp5)
      RegNext(Mux(pick, copy(1, adr1(k)), copy(0, Mux(launchNxt, baseNxt(k), adr0(k)))))
    } else 0.U(p.tableW.W)
  private val tabD = tableRom("D", p.gatherD, 0)
  private val tabA = tableRom("A", p.gatherA, 1)
  private val tabB = tableRom("B", p.gatherB, 2)

  // ---- G: table words registered (the element in G, M, A, R, Q, S and D belongs to `cur`: the next instruction
  // launches at least 8 cycles after the last element issues); the operands' bases registered from the launch on
  // the element's valid bit, index, last flag and input word travel beside it: `at(k)` is the element k stages
  // after T (1: G, 2: M, 3: A, 4: R, 5: Q, 6: S, 7: D, 8: U)
  private val eT = Wire(new Stage1Elem(w))
  eT.i    := iT
  eT.last := lastT
  eT.in   := s_axis.tdata(w - 1, 0)
  private val at = (1 to 8).scanLeft(eT)((x, _) => RegNext(x))
  private val vS = Stages.delayValid(issue, 6)
  private val vD = RegNext(vS, false.B)
  private val vU = RegNext(vD, false.B)
  private val iM = at(2).i
  private val aBase = RegNext(slotBase +& cur.a.addr)
  private val bBase = RegNext(slotBase +& cur.b.addr)
  private val dBase = RegNext(slotBase +& cur.d.addr)

  // ---- M: addresses, registered
  private val (tabAM, tabBM, tabDM) = (tabA, tabB, tabD) // registered in the fabric at M
  private def offset(o: OperandBits, tab: UInt): UInt = Mux(o.isGather, tab, Mux(o.isVec, iM, 0.U))
  private val mem    = new SlotMem(p.moduleName, p.slotMemWords, w, if (p.slotB) 2 else 1, ecp5 = ecp5)
  private val aOff   = offset(cur.a, tabAM)
  private val bOff   = offset(cur.b, tabBM)
  private val aAdr  = RegNext(aBase + aOff)
  private val bAdr  = RegNext(bBase + bOff)
  // constant operands: their address is relative to the constant region (the slot base is not added), or to the
  // slot's bank of it (the bank's base added to the operand's address at the launch, as the slot base)
  private def constAdr(o: OperandBits, off: UInt): UInt = constBase match {
    case None    => RegNext(o.addr +& off)
    case Some(c) => RegNext(RegNext(c +& o.addr) + off)
  }
  private val caAdr = constAdr(cur.a, aOff)
  private val cbAdr = constAdr(cur.b, bOff)
  private val dAdr  = RegNext(dBase + Mux(cur.d.isGather, tabDM, iM))

  // ---- A: the memories read at the registered addresses
  private val slotA  = mem.read(0, aAdr)
  private val slotBw = if (p.slotB) mem.read(1, bAdr) else 0.U(w.W)
  private val constA = if (p.constA) Rom.registered("Stage1ConstA", p.constWords, w, caAdr, clock, ecp5) else 0.U(w.W)
  private val constB = if (p.constB) Rom.registered("Stage1ConstB", p.constWords, w, cbAdr, clock, ecp5) else 0.U(w.W)

  // ---- R: memory words out, registered (the slot memory's per bank, in SlotMem)
  // ---- Q: memory words registered once more, in the fabric next to their block RAMs (the slot memory's in SlotMem)
  private val (constAR, constBR) = (RegNext(constA), RegNext(constB))

  // ---- S: bank and operand selected, registered once per operand
  // ---- D: the selected operands into the op's unit's registers (Stage1Alu)

  // ---- U: operands, units, write-back (the element in U still belongs to `cur`: a new instruction is
  // loaded into `cur` at the end of its first issue cycle, at the earliest the cycle its predecessor's last
  // element is here)
  private val eU    = at(8)
  private val addrU = Stages.delay(dAdr, 5) // registered at M, here at U
  private val aD    = RegNext(Mux(cur.a.inConst, constAR, slotA))
  private val bD    = RegNext(Mux(cur.b.inConst, constBR, slotBw))
  private val aU    = RegEnable(aD, vD && curOut) // the OUT word; the units register their own operands

  private val alu = withReset(LocalReset(p.target != dsp.Target.Generic)) { Module(new Stage1Alu(p)) }
  alu.io.op     := cur.op
  alu.io.n      := cur.n
  alu.io.idx    := eU.i
  alu.io.last   := eU.last
  alu.io.pre    := vD
  alu.io.aPre   := aD
  alu.io.bPre   := bD
  alu.io.inData := eU.in
  alu.io.addr   := addrU
  mem.write(alu.io.wen, alu.io.waddr, alu.io.wdata)

  outQ.io.enq.valid := vU && curOut
  outQ.io.enq.bits  := Cat(eU.last, aU)
  m_axis.tvalid     := outQ.io.deq.valid
  m_axis.tdata      := outQ.io.deq.bits(w - 1, 0).pad(32)
  m_axis.tlast      := outQ.io.deq.bits(w)
  outQ.io.deq.ready := m_axis.tready
  bus.Protocol.streamOut("m_axis", m_axis)
  bus.Protocol.noOverflow("output buffer", outQ.io.enq.valid, outQ.io.enq.ready)
}

/** What travels beside an element through the Stage 1 pipeline: its index in the instruction, whether it is the
  * last, and the input-stream word (IN) */
class Stage1Elem(w: Int) extends Bundle {
  val i    = UInt(Isa.NW.W)
  val last = Bool()
  val in   = UInt(w.W)
}
