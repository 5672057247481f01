package ipm

import chisel3._
import chisel3.util._

/** Stage 1 of the interior-point core (001, section VI-C): the sequential floating-point vector machine of
  * mpc_cores/ipm/isa.py, bit-exact with its interpreter (mpc_cores/ipm/machine.py).
  *
  * Interface. `start` (with `prog`, `slot`) runs program `prog` on slot `slot`; it is taken when the engine is
  * idle or on the cycle `done` is high (and ignored for a `prog` beyond the programs; `slot` must be < slots). `busy` is high from the cycle after `start` to `done` included. A
  * program started on cycle s raises `done` on cycle s + cycles(program) with cycles as
  * mpc_cores.ipm.isa.cycles when the streams do not stall (sum over the instructions of n + latency + 2); its
  * last result is written on the cycle after `done`, before any read of a program started on the `done`
  * cycle, so back-to-back programs run as one. IN takes words from `s_axis` (the format's word in the low bits
  * of tdata), OUT writes them to `m_axis` (tlast on an instruction's last word) through a 4-word buffer; both
  * wait for the other side, the only data-dependent timing.
  *
  * Pipeline, one element per cycle:
  *   T  issue: element index; index-table ROMs read (one per role d, a, b that gathers or scatters)
  *   M  addresses: vec addr + i, scalar addr, gather addr + table[i] (+ the slot's base in slot space);
  *      slot memory and constant ROMs read (one copy per operand a, b)
  *   R  memory words out; operand select (slot or constant), registered
  *   U  operands ready; into the unit of the op (Stage1Alu), result written latency(op) cycles later.
  * The R register keeps the block RAM's clock-to-out and the operand select out of the units' first step.
  * An instruction issues its n elements on consecutive cycles (IN: when a word is there; OUT: when the output
  * buffer has room for the words in flight) and the next one issues latency + 3 cycles after its last element,
  * that is on the cycle its last result is written: its first read is on the cycle after. So instructions run
  * strictly one after another and an instruction never reads a word it writes itself later (the programs keep
  * the write of element i away from the reads of the elements after i: mpc_cores.ipm.isa.stream_hazards).
  *
  * Memories. The slot memory (slots x slot_words words) is two SyncReadMems written identically, copy 0 read by
  * operand a and copy 1 by operand b (one read and one write port each: DP16KD on ECP5); the constant region is
  * a ROM per operand that reads it, the index tables one ROM per role, the program a ROM of instruction words
  * (mem.InitRam, contents in the emitted Verilog). Only the copies the programs use are built.
  */
class Stage1Engine(p: Stage1Params) extends Module {
  import Isa._
  override def desiredName = p.moduleName
  private val w = p.fmt.width

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
  private val i        = Reg(UInt(NW.W))

  private val entry  = table(p.entries.init.map(_.U(p.pcW.W)), 1 << p.progW, 0.U(p.pcW.W))
  private val ends   = table(p.entries.tail.map(_.U(p.pcW.W)), 1 << p.progW, 0.U(p.pcW.W))
  private val latOf  = table(Isa.ops.indices.map(o => p.latency(o).U(gap.getWidth.W)), 1 << OpW, 0.U(gap.getWidth.W))
  private val finish = running && !issuing && gap === 1.U && pc === pcEnd
  private val accept = start && (!running || finish) && prog < p.programs.length.U
  private val launch = running && !issuing && gap === 0.U && pc =/= pcEnd
  private val code   = Rom("Stage1Code", p.code, InstrW, Mux(running && !finish, pc, entry(prog)), clock)
  busy := running
  done := finish

  // ---- T: issue
  private val ins     = Mux(launch, InstrBits.decode(code), cur)
  private val iT      = Mux(launch, 0.U, i)
  private val lastT   = iT + 1.U === ins.n
  private val outQ    = Module(new Queue(UInt((w + 1).W), 4, flow = true))
  private val vM      = RegInit(false.B)
  private val vU      = RegInit(false.B)
  private val curOut  = cur.op === OUT.U
  private val vR      = RegInit(false.B)
  private val room    = outQ.io.count +& (vM && curOut) +& (vR && curOut) +& (vU && curOut) <= 3.U
  private val active  = launch || issuing
  private val issue   = active && Mux(ins.op === IN.U, s_axis.tvalid, Mux(ins.op === OUT.U, room, true.B))
  s_axis.tready := active && ins.op === IN.U

  when(running && !issuing && gap =/= 0.U) { gap := gap - 1.U }
  when(launch) {
    cur     := ins
    issuing := true.B
    pc      := pc + 1.U
    i       := 0.U
  }
  when(issue) {
    i := iT + 1.U
    when(lastT) {
      issuing := false.B
      gap     := latOf(ins.op) + Stage1Params.IssueGap.U
    }
  }
  when(finish) { running := false.B }
  when(accept) {
    running  := true.B
    issuing  := false.B
    gap      := 0.U
    pc       := entry(prog)
    pcEnd    := ends(prog)
    slotBase := slot * p.slotWords.U
  }

  private val tableBase = table(p.tableBase.init.map(_.U(17.W)), 1 << TableW, 0.U(17.W))
  private def tableRom(role: String, used: Boolean, o: OperandBits): UInt =
    if (used) Rom(s"Stage1Table$role", p.tableWords.map(BigInt(_)), p.tableW, tableBase(o.table) + iT, clock)
    else 0.U(p.tableW.W)
  private val tabD = tableRom("D", p.gatherD, ins.d)
  private val tabA = tableRom("A", p.gatherA, ins.a)
  private val tabB = tableRom("B", p.gatherB, ins.b)

  // ---- M: addresses (the element in M belongs to `cur`: the next instruction issues at least 2 cycles later)
  vM := issue
  private val iM    = RegNext(iT)
  private val lastM = RegNext(lastT)
  private val inM   = RegNext(s_axis.tdata(w - 1, 0))
  private def offset(o: OperandBits, tab: UInt): UInt = o.addr +& Mux(o.isGather, tab, Mux(o.isVec, iM, 0.U))
  private val aOff  = offset(cur.a, tabA)
  private val bOff  = offset(cur.b, tabB)
  private val dOff  = cur.d.addr +& Mux(cur.d.isGather, tabD, iM)
  private val mem   = new SlotMem(p.slotMemWords, w, if (p.slotB) 2 else 1)
  private val slotA = mem.read(0, slotBase + aOff)
  private val slotBw = if (p.slotB) mem.read(1, slotBase + bOff) else 0.U(w.W)
  private val constA = if (p.constA) Rom("Stage1ConstA", p.constWords, w, aOff, clock) else 0.U(w.W)
  private val constB = if (p.constB) Rom("Stage1ConstB", p.constWords, w, bOff, clock) else 0.U(w.W)

  // ---- R: memory words out, operands selected and registered
  vR := vM
  private val iR    = RegNext(iM)
  private val lastR = RegNext(lastM)
  private val inR   = RegNext(inM)
  private val addrR = RegNext(slotBase + dOff)

  // ---- U: operands, units, write-back (the element in U still belongs to `cur`: a new instruction is
  // loaded into `cur` at the end of its first issue cycle, at the earliest the cycle its predecessor's last
  // element is here)
  vU := vR
  private val iU    = RegNext(iR)
  private val lastU = RegNext(lastR)
  private val inU   = RegNext(inR)
  private val addrU = RegNext(addrR)
  private val aU    = RegNext(Mux(cur.a.inConst, constA, slotA))
  private val bU    = RegNext(Mux(cur.b.inConst, constB, slotBw))

  private val alu = Module(new Stage1Alu(p))
  alu.io.valid  := vU
  alu.io.op     := cur.op
  alu.io.n      := cur.n
  alu.io.idx    := iU
  alu.io.last   := lastU
  alu.io.a      := aU
  alu.io.b      := bU
  alu.io.inData := inU
  alu.io.addr   := addrU
  mem.write(alu.io.wen, alu.io.waddr, alu.io.wdata)

  outQ.io.enq.valid := vU && curOut
  outQ.io.enq.bits  := Cat(lastU, aU)
  m_axis.tvalid     := outQ.io.deq.valid
  m_axis.tdata      := outQ.io.deq.bits(w - 1, 0).pad(32)
  m_axis.tlast      := outQ.io.deq.bits(w)
  outQ.io.deq.ready := m_axis.tready
  bus.Protocol.streamOut("m_axis", m_axis)
  bus.Protocol.noOverflow("output buffer", outQ.io.enq.valid, outQ.io.enq.ready)
}
