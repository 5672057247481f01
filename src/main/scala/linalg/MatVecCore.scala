package linalg

import chisel3._
import chisel3.util._
import bus.AxiStreamIO
import fixed.FixedOps
import mem.InitRam
import shell.FrameIn

/** s = M v on streams: the linear-system step of a splitting method as a hardware block for a CPU that runs the
  * rest of the method (the heterogeneous split of 004, section 5; the generated C's `_solve_split`).
  *
  * A frame is the n words of v on s_axis (tlast on the last; a word outside the operand width saturates). The block
  * answers with the n words of s on m_axis, row 0 first, tlast on the last. tuser per word: bit 0 the row's product
  * or partial sum saturated (the sum word's flag of the core's adder tree), bit 1 a word of the frame's v saturated,
  * bit 2 a tlast of the frame's v was misplaced (frames are counted in words: nothing is lost).
  *
  * P row units share v (held in the input frame's registers); unit u works through rows u, u + P, ... from a block
  * RAM of its rows, one per cycle, into the core's DotProductTree, and writes each sum into a result block RAM of
  * its own. The next frame loads while this one's words leave. Every accepted frame gives one answer, in order,
  * under any backpressure. The matrix is fixed at generation (the memories are initialised from it).
  */
class MatVecCore(val p: MatVecParams) extends Module {
  override def desiredName = p.moduleName
  import p.{K, P, n}

  val s_axis = IO(Flipped(new AxiStreamIO(p.inW)))
  val m_axis = IO(new AxiStreamIO(p.outW, 3))

  val frameIn = Module(new FrameIn(p.moduleName + "_v", n, p.opW, p.inW,
    Seq.fill(n)((FixedOps.minOf(p.opW), FixedOps.maxOf(p.opW)))))
  frameIn.io.s_axis <> s_axis
  frameIn.io.hold    := false.B
  frameIn.io.boxWen  := false.B
  frameIn.io.boxWord := 0.U
  frameIn.io.boxHi   := false.B
  frameIn.io.boxData := 0.S

  // the input flags of the frame being loaded, then of the frame whose words are read out
  val accSat, accTlast, runSat, runTlast = RegInit(false.B)
  when(frameIn.io.sat) { accSat := true.B }
  when(frameIn.io.tlastErr) { accTlast := true.B }

  // ------------------------------------------------------------------ run: t = 0 .. runCycles - 1
  val running = RegInit(false.B)
  val outBusy = RegInit(false.B) // result rows still to be read
  val t       = RegInit(0.U(log2Ceil(p.runCycles + 1).W))
  val go      = frameIn.io.full && !running && !outBusy
  when(go) {
    running := true.B
    t       := 0.U
  }.elsewhen(running) {
    t := t + 1.U
    when(t === (p.runCycles - 1).U) {
      running := false.B
      outBusy := true.B
    }
  }
  // the frame's operands are read by the tree up to t = K + 1: then the next frame may load
  val take = running && t === (K + 1).U
  frameIn.io.take := take
  when(take) {
    runSat   := accSat || frameIn.io.sat
    runTlast := accTlast || frameIn.io.tlastErr
    accSat   := false.B
    accTlast := false.B
  }

  val kRead  = t(p.kW - 1, 0)
  val rdOk   = running && t < K.U
  val inVal  = ShiftRegister(rdOk, 2, false.B, true.B)
  val kWrite = ShiftRegister(kRead, 2 + p.dp.latency)

  val outRam = (0 until P).map { u =>
    val mat  = Module(new InitRam(s"${p.moduleName}_mat$u", K, n, p.coefW, p.matInit(u), outReg = true,
      ecp5 = p.target == dsp.Target.Ecp5))
    val res  = Module(new InitRam(s"${p.moduleName}_res$u", K, 1, p.sumW + 1, Seq()))
    val tree = Module(new DotProductTree(p.dp))
    mat.io.clock := clock
    mat.io.raddr := kRead
    mat.io.wen   := false.B
    mat.io.waddr := 0.U
    mat.io.wmask := 0.U
    mat.io.wdata := 0.U
    tree.io.inValid := inVal
    tree.io.coef    := mat.io.rdata.asTypeOf(Vec(n, SInt(p.coefW.W)))
    tree.io.op      := frameIn.io.frame
    res.io.clock := clock
    res.io.wen   := tree.io.outValid
    res.io.waddr := kWrite
    res.io.wmask := 1.U
    res.io.wdata := Cat(tree.io.overflow, tree.io.sum.asUInt)
    res
  }

  // ------------------------------------------------------------------ output: rows in order through a queue
  class Word extends Bundle {
    val s    = SInt(p.sumW.W)
    val flag = UInt(3.W)
    val last = Bool()
  }
  val q       = Module(new Queue(new Word, 3))
  val rdU     = RegInit(0.U(math.max(1, log2Ceil(P)).W))
  val rdK     = RegInit(0.U(p.kW.W))
  val lastRow = rdU === ((n - 1) % P).U && rdK === ((n - 1) / P).U
  // a read in flight lands in the queue in the next cycle: count it against the room
  val inFlight = RegInit(false.B)
  val canIssue = outBusy && (q.io.count +& inFlight.asUInt) < 3.U
  inFlight := canIssue
  for (r <- outRam) r.io.raddr := rdK
  when(canIssue) {
    when(lastRow) {
      outBusy := false.B
      rdU     := 0.U
      rdK     := 0.U
    }.elsewhen(rdU === (P - 1).U) {
      rdU := 0.U
      rdK := rdK + 1.U
    }.otherwise { rdU := rdU + 1.U }
  }
  val uL    = RegNext(rdU)
  val lastL = RegNext(lastRow)
  val rd    = VecInit(outRam.map(_.io.rdata))(uL)
  q.io.enq.valid     := inFlight
  q.io.enq.bits.s    := rd(p.sumW - 1, 0).asSInt
  q.io.enq.bits.flag := Cat(runTlast, runSat, rd(p.sumW))
  q.io.enq.bits.last := lastL
  bus.Protocol.noOverflow("result queue", q.io.enq.valid, q.io.enq.ready)

  m_axis.tvalid := q.io.deq.valid
  m_axis.tdata  := q.io.deq.bits.s.pad(p.outW).asUInt
  m_axis.tlast  := q.io.deq.bits.last
  m_axis.tuser.get := q.io.deq.bits.flag
  q.io.deq.ready := m_axis.tready
  bus.Protocol.streamOut("m_axis", m_axis)
}
