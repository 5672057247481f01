package gen

import chisel3._

/** Generator entry point of the shared blocks' unit tests: `gen.BlocksMain <config.json> <outDir> [...pairs]`.
  * config.json lists the blocks to emit, each {"name", "block", parameters}; each becomes a top-level module
  * `<name>` in <outDir>/<name>.sv (its submodules prefixed with the name). <outDir>/hw.json repeats the list with
  * the file of each (verif/blocks wires them side by side into one Verilator model).
  *
  * Blocks and their parameters:
  *  - RegSlice {width, stream}: bus.RegSlice of UInt(width), or of a bus.StreamWord(width) when stream
  *  - FlowQueue {width, depth}: bus.FlowQueue of UInt(width)
  *  - AnswerQueue {width}: shell.AnswerQueue
  *  - FrameIn {words, wordW, streamW, box: [[lo, hi], ...], ids}: shell.FrameIn
  *  - PassSequencer {K, firstLen, L, copyAfterFirst, maxOut}: shell.PassSequencer
  *  - TurnSequencer {K, Kp, L, maxOut}: shell.TurnSequencer
  *  - SerialDivider {xW, dW}: fixed.SerialDivider
  *  - InitRam {depth, lanes, laneW, init: rows of lanes, outReg, ecp5, raddrAhead, broadcast}: mem.InitRam in a
  *    module with a clock and the RAM's other ports under io
  */
object BlocksMain extends App {
  CoreMain.run(args, "gen.BlocksMain") { (cfg, out) =>
    val blocks = ujson.read(cfg)("blocks").arr.toSeq
    val names  = blocks.map(_("name").str)
    require(names.distinct.length == names.length, s"block names repeat: ${names.mkString(", ")}")
    for (b <- blocks) {
      val name = b("name").str
      def int(k: String): Int = b(k).num.toInt
      def flag(k: String): Boolean = b.obj.get(k).exists(_.bool)
      val top = name // the module's name (inside a module `name` is its own member)
      def emit(m: => RawModule): Unit = Emit.systemVerilog(m, out, top)
      b("block").str match {
        case "RegSlice" =>
          val word = if (flag("stream")) new bus.StreamWord(int("width")) else UInt(int("width").W)
          emit(new bus.RegSlice(word) { override def desiredName = top })
        case "FlowQueue" =>
          emit(new bus.FlowQueue(UInt(int("width").W), int("depth")) { override def desiredName = top })
        case "AnswerQueue" => emit(new shell.AnswerQueue(int("width")) { override def desiredName = top })
        case "FrameIn" =>
          val box = ConfigJson.mat(b("box")).map { case Seq(lo, hi) => (lo, hi) }
          emit(new shell.FrameIn(name, int("words"), int("wordW"), int("streamW"), box, int("ids")) {
            override def desiredName = top
          })
        case "PassSequencer" =>
          emit(new shell.PassSequencer(int("K"), int("firstLen"), int("L"), flag("copyAfterFirst"), int("maxOut")) {
            override def desiredName = top
          })
        case "TurnSequencer" =>
          emit(new shell.TurnSequencer(int("K"), int("Kp"), int("L"), int("maxOut")) { override def desiredName = top })
        case "SerialDivider" => emit(new fixed.SerialDivider(int("xW"), int("dW")) { override def desiredName = top })
        case "InitRam" =>
          emit(new InitRamBlock(name, int("depth"), int("lanes"), int("laneW"), ConfigJson.mat(b("init")),
            flag("outReg"), flag("ecp5"), flag("raddrAhead"), flag("broadcast")))
        case other => throw new IllegalArgumentException(s"unknown block '$other' ($name)")
      }
    }
    val list = blocks.map(b => ujson.Obj.from(b.obj.toSeq :+ ("sv" -> ujson.Str(s"${b("name").str}.sv"))))
    Emit.writeText(s"$out/hw.json", ujson.write(ujson.Obj("blocks" -> ujson.Arr(list: _*)), indent = 2))
  }
}

/** A mem.InitRam (a black box) in a module of its own: the RAM's ports under io, its clock the module's. */
class InitRamBlock(top: String, depth: Int, lanes: Int, laneW: Int, init: Seq[Seq[BigInt]], outReg: Boolean,
    ecp5: Boolean, raddrAhead: Boolean, broadcast: Boolean) extends Module {
  override def desiredName = top
  private val ram = Module(new mem.InitRam(s"${top}_ram", depth, lanes, laneW, init, outReg = outReg, ecp5 = ecp5,
    raddrAhead = raddrAhead, broadcast = broadcast))
  val io = IO(new Bundle {
    val raddr = Input(UInt(ram.addrW.W))
    val rdata = Output(UInt(ram.rowW.W))
    val wen   = Input(Bool())
    val waddr = Input(UInt(ram.addrW.W))
    val wmask = Input(UInt(lanes.W))
    val wdata = Input(UInt(ram.rowW.W))
  })
  ram.io.clock := clock
  ram.io.raddr := io.raddr
  ram.io.wen   := io.wen
  ram.io.waddr := io.waddr
  ram.io.wmask := io.wmask
  ram.io.wdata := io.wdata
  io.rdata     := ram.io.rdata
}
