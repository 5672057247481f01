package dgp

import chisel3._
import bus.AxiStreamIO
import fixed.SerialDivider

/** The plain DGP core's answer path: each output word is the averaged primal zbar_i = floor((2 Sz_i + I) / (2 I)),
  * Sz / I rounded to nearest, from a serial divider, clamped to its word's quantised input box (the box registered
  * from the word's index, which holds while the divider runs), then the status word with tlast.
  */
object DgpPlainAnswer {
  /** Drives `port` while `out` (the core's output state); `sz`: the sums of z (flat), `iters`: I; `outIdx`: the
    * word index, stepped at each word sent; `done` runs as the status word goes out. */
  def apply(p: DgpParams, out: Bool, sz: Vec[SInt], iters: UInt, outIdx: UInt, statusNow: Bool, statusWord: UInt,
      port: AxiStreamIO, done: () => Unit): Unit = {
    val W = p.dataW
    val word = Reg(SInt(W.W))
    val div = Module(new SerialDivider(p.divW, 18))
    val have = RegInit(false.B)
    div.io.start := out && !have && !div.io.busy && !div.io.done && !statusNow
    div.io.x := (sz(outIdx) << 1) +& iters.zext
    div.io.d := iters << 1
    val q = div.io.q(W - 1, 0).asSInt
    val qLo = RegNext(VecInit(p.outLo.map(_.S(W.W)))(outIdx))
    val qHi = RegNext(VecInit(p.outHi.map(_.S(W.W)))(outIdx))
    when(div.io.done) { have := true.B; word := Mux(q < qLo, qLo, Mux(q > qHi, qHi, q)) }
    when(port.fire) { have := false.B }
    port.tvalid := out && (statusNow || have)
    port.tdata  := Mux(statusNow, statusWord.pad(p.streamW), word.pad(p.streamW).asUInt)
    port.tlast  := statusNow
    when(port.fire) {
      outIdx := outIdx + 1.U
      when(statusNow) { done() }
    }
  }
}
