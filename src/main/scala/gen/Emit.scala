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

  /** Elaborate `gen` into `outDir`/`topName`.sv (blackbox sources appended, so one file holds the design). */
  def systemVerilog(gen: => RawModule, outDir: String, topName: String): Path = {
    val dir = Paths.get(outDir)
    Files.createDirectories(dir)
    val tmp = dir.resolve(".chisel")
    ChiselStage.emitSystemVerilogFile(gen, args = Array("--target-dir", tmp.toString), firtoolOpts = firtoolOpts)
    val parts = Files.list(tmp).toArray.map(_.asInstanceOf[Path]).filter { f =>
      val s = f.toString; s.endsWith(".sv") || s.endsWith(".v")
    }.sortBy(f => if (f.getFileName.toString == s"$topName.sv") 0 else 1)
    val text = parts.map(f => new String(Files.readAllBytes(f))).mkString("\n")
    val out  = dir.resolve(s"$topName.sv")
    Files.write(out, text.getBytes)
    parts.foreach(Files.delete)
    Files.list(tmp).toArray.map(_.asInstanceOf[Path]).foreach(Files.delete)
    Files.delete(tmp)
    out
  }

  def writeText(path: String, text: String): Unit = {
    Files.createDirectories(Paths.get(path).getParent)
    Files.write(Paths.get(path), text.getBytes)
  }
}
