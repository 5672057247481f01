package dgp

import chisel3._
import bus.AxiStreamIO
import mem.KeepReg

/** The accelerated DGP core's answer path. z is final from the decision cycle on; its copy clamped word by word (`clamp`,
  * the compares and the select in registered steps, registered once more here: three cycles behind z) loads the
  * answer register zc until the decision that finishes. The words then move into a four-word output queue
  * (shell.AnswerQueue) at `shift`, a register decided a cycle ahead from a flag of its own (the answer is going out:
  * from the cycle after that decision until the status word enters the queue) and the queue's room, zc shifting a
  * word down at each: the stream's tready meets only the queue. Each word of zc takes
  * its load and shift from kept copies of its own (FPGA targets), not one register driving every word's bits.
  */
object DgpAnswer {
  /** x clamped to output word i's quantised input box [outLo_i, outHi_i] (a comparator pair against constants), x
    * and its compares registered before the select: only the output, the iteration's z and Sz stay unclamped */
  def clamp(p: DgpParams, x: SInt, i: Int): SInt = {
    val (l, h) = (p.outLo(i).S(p.dataW.W), p.outHi(i).S(p.dataW.W))
    val (xr, below, above) = (RegNext(x), RegNext(x < l), RegNext(x > h))
    Mux(below, l, Mux(above, h, xr))
  }

  /** Drives `port`; `finishing`: the decision that finishes; `outIdx`: the core's word index
    * (the words decided; the status word follows the nu, or n with `outAll`, data words); `done` runs as the
    * status word enters the queue. Returns whether an answer waits in the queue. */
  def apply(p: DgpParams, fpga: Boolean, z: Seq[SInt], finishing: Bool, outAll: Bool, outIdx: UInt,
      statusWord: UInt, port: AxiStreamIO, done: () => Unit): Bool = {
    val n = p.n
    val zcl = RegNext(VecInit(z.zipWithIndex.map { case (x, i) => clamp(p, x, i) }))
    val zc = Reg(Vec(n, SInt(p.dataW.W)))
    val ansQ = Module(new shell.AnswerQueue(p.streamW))
    val shift = RegInit(false.B)
    /** the word the next shift moves is the status word */
    val pushStatus = RegInit(false.B)
    /** the status word has been decided: no more shifts this answer */
    val sentAll = RegInit(false.B)
    /** the answer is going out (the core's output state) */
    val on = RegInit(false.B)
    val shiftA = on && !sentAll && ansQ.io.room
    val countW = Mux(outAll, n.U, p.nu.U)
    shift := shiftA
    when(shiftA) {
      outIdx := outIdx + 1.U
      pushStatus := outIdx === countW
      sentAll := outIdx === countW
    }
    on := finishing || (on && !(shift && pushStatus))
    // the answer register loads while no answer is on its way, and in the answer's first cycle (z holds from before
    // the decision until the next take; the first shift comes a cycle later): its loads are copies of the flag
    val loads  = if (fpga) Seq.fill(n)(KeepReg(!on)) else Seq.fill(n)(RegNext(!on, true.B))
    val shifts = if (fpga) Seq.fill(n)(KeepReg(shiftA)) else Seq.fill(n)(shift)
    for (i <- 0 until n)
      when(shifts(i)) { zc(i) := zc.lift(i + 1).getOrElse(zc(i)) }.elsewhen(loads(i)) { zc(i) := zcl(i) }
    ansQ.io.push := shift
    ansQ.io.data := Mux(pushStatus, statusWord.pad(p.streamW), zc(0).pad(p.streamW).asUInt)
    ansQ.io.last := pushStatus
    when(shift && pushStatus) { done(); outIdx := 0.U; sentAll := false.B; pushStatus := false.B }
    port.tvalid := ansQ.io.deq.valid
    port.tdata  := ansQ.io.deq.bits.data
    port.tlast  := ansQ.io.deq.bits.last
    ansQ.io.deq.ready := port.tready
    ansQ.io.deq.valid
  }
}
