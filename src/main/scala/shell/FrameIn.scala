package shell

import chisel3._
import chisel3.util._
import bus.AxiStreamIO
import fixed.FixedOps
import mem.InitRam

/** Input frame of a solver core: `words` signed words on s_axis, each saturated to its box [lo_j, hi_j] (held in
  * a small rewritable RAM), collected until the core takes the frame. Frames are counted in words: a tlast in
  * the wrong place sets `tlastErr` and loses nothing.
  *
  * @param name   prefix of the box RAM's module name
  * @param words  words per frame
  * @param wordW  width of the saturated words
  * @param box    (lo, hi) per word, the power-on contents of the box RAM
  * @param ids    problems of an interleaving core (> 1: s_axis has tuser, the frame's problem id, taken from its
  *               first word and saturated to ids - 1, which sets `sat`)
  */
class FrameIn(name: String, words: Int, wordW: Int, streamW: Int, box: Seq[(BigInt, BigInt)], ids: Int = 1)
    extends Module {
  require(box.length == words, s"FrameIn: ${box.length} boxes for $words words")
  require(ids >= 1, s"FrameIn: ids must be >= 1, got $ids")
  val idW = if (ids > 1) log2Ceil(ids) else 0
  val io = IO(new Bundle {
    val s_axis = Flipped(new AxiStreamIO(streamW, idW))
    /** the complete frame's problem id (zero width without interleaving) */
    val id = Output(UInt(idW.W))
    /** accept no new frame (words of a frame already begun are still taken) */
    val hold = Input(Bool())
    /** the core takes the complete frame this cycle */
    val take  = Input(Bool())
    val full  = Output(Bool())
    /** a frame's last word is taken this cycle (`full` rises in the next) */
    val fills = Output(Bool())
    val frame = Output(Vec(words, SInt(wordW.W)))
    /** some words of a frame have arrived */
    val partial = Output(Bool())
    /** pulses: a word saturated (a cycle after its handshake); a tlast was misplaced */
    val sat      = Output(Bool())
    val tlastErr = Output(Bool())
    /** box rewrite: word j, bound hi (else lo) */
    val boxWen  = Input(Bool())
    val boxWord = Input(UInt(math.max(1, log2Ceil(words)).W))
    val boxHi   = Input(Bool())
    val boxData = Input(SInt(wordW.W))
  })

  // Two copies of the box memory, written alike: one reads the box of the word after this one, the other this
  // word's, and the handshake picks between their outputs a cycle later (so it does not reach a read address).
  val boxRams = Seq.fill(2)(Module(new InitRam(s"${name}_box", words, 2, wordW, box.map { case (l, h) => Seq(l, h) })))
  for (r <- boxRams) {
    r.io.clock := clock
    r.io.wen   := io.boxWen
    r.io.waddr := io.boxWord
    r.io.wmask := UIntToOH(io.boxHi, 2)
    r.io.wdata := Fill(2, io.boxData.asUInt)
  }

  val buf  = Reg(Vec(words, SInt(wordW.W)))
  val cntW = log2Ceil(words + 1)
  val cnt  = RegInit(0.U(cntW.W))
  // cnt's successor and its comparisons, kept in registers: the handshake and the box read address are a gate
  // or two from registers, not an incrementer and comparators
  val cntNext = RegInit((if (words == 1) 0 else 1).U(cntW.W))
  val last    = RegInit((words == 1).B) // cnt === words - 1
  val atZero  = RegInit(true.B)         // cnt === 0
  val full    = RegInit(false.B)
  io.s_axis.tready := !full && !(io.hold && atZero)
  val fire = io.s_axis.fire
  // The box of the next word is read a cycle ahead: the word after this one's if this one is taken, else this one's.
  boxRams(0).io.raddr := cntNext
  boxRams(1).io.raddr := cnt
  val boxNow = Mux(RegNext(fire, false.B), boxRams(0).io.rdata, boxRams(1).io.rdata)
  val lo = boxNow(wordW - 1, 0).asSInt
  val hi = boxNow(2 * wordW - 1, wordW).asSInt
  // A word's comparisons against its box end in registers in the cycle of its handshake; the clamped word is
  // written a cycle later. The last word of a frame reaches io.frame through a bypass in that cycle, so the frame
  // is whole when `full` rises (the cores take it from then on; they read no word of a partial frame).
  val x       = io.s_axis.tdata.asSInt
  val pend    = RegNext(fire, false.B)
  val pendEnd = RegNext(fire && last, false.B)
  // the word's one-hot position, rotated with cnt: a word's write enable is a register, not a decode of its index,
  // each formed from tvalid and registers (word 0 is the one the hold applies to), not from the handshake's fan-out
  val hot     = RegInit(1.U(words.W))
  val pendHot = RegNext(VecInit((0 until words).map(i =>
    io.s_axis.tvalid && !full && hot(i) && (if (i == 0) !io.hold else true.B))).asUInt, 0.U)
  assert(pendHot === RegNext(Mux(fire, hot, 0.U), 0.U), "FrameIn: word enables out of step with the handshake")
  val pendX   = RegEnable(x(wordW - 1, 0).asSInt, fire) // the word itself is taken only when it is in its box
  val below   = RegEnable(FixedOps.lt(x, lo), fire)
  val above   = RegEnable(FixedOps.lt(hi, x), fire)
  val pendLo  = RegEnable(lo, fire)
  val pendHi  = RegEnable(hi, fire)
  val v       = FixedOps.clampSelect(below, above, pendX, pendLo, pendHi)
  // the problem id: the first word's tuser, saturated to the problems there are
  val idReg = RegInit(0.U(idW.W))
  val idSat = io.s_axis.tuser.map(u => u >= ids.U && atZero).getOrElse(false.B)
  io.s_axis.tuser.foreach { u =>
    when(fire && atZero) { idReg := Mux(u >= ids.U, (ids - 1).U, u) }
  }
  io.id := idReg
  io.sat      := pend && (below || above || RegNext(idSat))
  io.tlastErr := fire && (io.s_axis.tlast =/= last)
  for (i <- 0 until words) when(pendHot(i)) { buf(i) := v }
  when(fire) {
    hot      := (if (words == 1) 1.U else Mux(last, 1.U, (hot << 1)(words - 1, 0)))
    cnt      := cntNext
    cntNext  := Mux(cntNext === (words - 1).U, 0.U, cntNext + 1.U)
    last     := cntNext === (words - 1).U
    atZero   := last
    when(last) { full := true.B }
  }
  when(io.take) { full := false.B }
  bus.Protocol.noOverflow("input frame", fire, !full)
  io.full    := full
  // fire && last, formed from tvalid and registers (not through the handshake's wide fan-out): the last word
  // implies a frame begun, so the hold does not apply to it
  io.fills := io.s_axis.tvalid && last && !full && (if (words == 1) !(io.hold && atZero) else true.B)
  assert(io.fills === (fire && last), "FrameIn: fills out of step with the handshake")
  io.frame   := VecInit(buf.init :+ Mux(pendEnd, v, buf.last))
  io.partial := !atZero
}
