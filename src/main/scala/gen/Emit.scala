package gen

import java.nio.file.{Files, Path, Paths}
import chisel3.RawModule
import _root_.circt.stage.ChiselStage

/** SystemVerilog emission shared by the core generators: one self-contained .sv file per core. */
object Emit {
  val firtoolOpts: Array[String] = Array(
    "-disable-all-randomization",
    "-strip-debug-info",
    "--lowering-options=disallowLocalVariables,disallowPackedArrays,locationInfoStyle=wrapInAtSquareBracket"
  )

  private val FileMarker = """(?m)^// ----- 8< ----- FILE "([^"]+)" ----- 8< -----$""".r
  private val ModuleDecl = """(?m)^module\s+(\w+)""".r

  /** Elaborate `gen` into `outDir`/`topName`.sv. Blackbox sources are kept in the same file (the file list is
    * dropped) and every submodule is prefixed with the top name, so that several generated cores can be
    * compiled together without duplicate module names.
    */
  def systemVerilog(gen: => RawModule, outDir: String, topName: String): Path = {
    val raw = ChiselStage.emitSystemVerilog(gen, firtoolOpts = firtoolOpts)
    // split into (file name, text) sections and drop non-Verilog ones
    val marks    = FileMarker.findAllMatchIn(raw).toSeq
    val starts   = 0 +: marks.map(_.start)
    val names    = "main.sv" +: marks.map(_.group(1))
    val ends     = marks.map(_.start) :+ raw.length
    val sections = names.zip(starts.zip(ends)).collect {
      case (nm, (s, e)) if nm.endsWith(".sv") || nm.endsWith(".v") =>
        FileMarker.replaceAllIn(raw.substring(s, e), "")
    }
    var text = sections.mkString("\n")
    val subs = ModuleDecl.findAllMatchIn(text).map(_.group(1)).toSeq.distinct.filterNot(_.startsWith(topName))
    for (s <- subs.sortBy(-_.length)) text = text.replaceAll(s"\\b$s\\b", s"${topName}_$s")
    val dir = Paths.get(outDir)
    Files.createDirectories(dir)
    val out = dir.resolve(s"$topName.sv")
    Files.write(out, text.getBytes)
    out
  }

  def writeText(path: String, text: String): Unit = {
    Files.createDirectories(Paths.get(path).toAbsolutePath.getParent)
    Files.write(Paths.get(path), text.getBytes)
  }
}

/** Command line of a core generator: pairs `<config.json> <outDir>`, each elaborated on its own. A refusal prints
  * "REFUSED <config>: <rule>" and the others still build; the exit code is 1 if any was refused.
  */
object CoreMain {
  def run(args: Array[String], usage: String)(build: (String, String) => Unit): Unit = {
    require(args.length >= 2 && args.length % 2 == 0, s"usage: $usage <config.json> <outDir> [...pairs]")
    val refused = args.grouped(2).toSeq.flatMap { case Array(cfg, out) =>
      try {
        build(new String(Files.readAllBytes(Paths.get(cfg))), out)
        None
      } catch {
        case e: IllegalArgumentException =>
          println(s"REFUSED $cfg: ${e.getMessage}")
          Some(cfg)
      }
    }
    if (refused.nonEmpty) sys.exit(1)
  }

  /** The register list and regions of hw.json, from the core's register map: per register its byte offset, access
    * summary (RO, RW, WO, RO/W1C), description and fields; per region its byte offset, span and array dimensions.
    */
  def registerJson(map: shell.RegMap): (ujson.Arr, ujson.Obj) = {
    def field(f: shell.Field) = {
      val o = ujson.Obj("name" -> f.name, "lsb" -> f.lsb, "width" -> f.width, "sw" -> f.sw, "desc" -> f.desc)
      f.reset.foreach(v => o("reset") = ujson.Num(v.toDouble))
      if (f.w1c) o("w1c") = true
      o
    }
    val r = map.regs.sortBy(_.word).map { r =>
      ujson.Obj("name" -> r.name, "offset" -> 4 * r.word, "access" -> r.access, "desc" -> r.desc,
        "fields" -> ujson.Arr(r.fields.sortBy(_.lsb).map(field): _*))
    }
    val g = map.regions.map { g =>
      g.name -> ujson.Obj("offset" -> 4 * g.word, "bytes" -> 4 * g.size, "dims" -> ujson.Arr(g.dims.map(ujson.Num(_)): _*))
    }
    (ujson.Arr(r: _*), ujson.Obj.from(g))
  }

  /** Write the core's outputs beside its SystemVerilog: hw.json (with the AXI4-Lite response cycles every core
    * shares) and the SystemRDL register description. */
  def writeOutputs(out: String, hwJson: String, map: shell.RegMap): Unit = {
    val hw = ujson.read(hwJson)
    hw("axil_response_cycles") = ujson.Obj("write" -> bus.AxiLiteSlave.WriteResponseCycles,
      "read" -> bus.AxiLiteSlave.ReadResponseCycles)
    Emit.writeText(s"$out/hw.json", ujson.write(hw, indent = 2))
    Rdl.write(out, map)
  }
}
