package gen

import shell.{Field, RegMap, Region, Register}

/** The SystemRDL 2.0 description of a core's register map: one `addrmap` named after the module, the registers
  * with their fields (software and hardware access, write-1-to-clear, reset values), and each data memory as an
  * `external` register array whose dimensions give its address arithmetic: element [i0][i1]..[ik] of a region
  * at byte address B with dimensions [d0][d1]..[dk] is at B + 4 ((i0 d1 + i1) d2 + .. + ik).
  * PeakRDL turns it into the C header, the register reference and IP-XACT (mpc_cores/regmap.py).
  */
object Rdl {
  /** A string literal; the description's square brackets are spelt as RDL's [lb] and [rb] tags. */
  private def str(s: String): String =
    "\"" + s.flatMap {
      case '"'  => "\\\""
      case '\\' => "\\\\"
      case '['  => "[lb]"
      case ']'  => "[rb]"
      case c    => c.toString
    } + "\""

  private def hex(v: BigInt): String = "0x" + v.toString(16).toUpperCase

  private def field(f: Field, ind: String): String = {
    val props = Seq(s"sw = ${f.sw};", s"hw = ${f.hw};") ++ (if (f.w1c) Seq("onwrite = woclr;") else Nil) :+
      s"desc = ${str(f.desc)};"
    val reset = f.reset.map(v => s" = ${hex(v)}").getOrElse("")
    s"${ind}field { ${props.mkString(" ")} } ${f.name}[${f.msb}:${f.lsb}]$reset;\n"
  }

  private def register(r: Register): String =
    s"    reg {\n        desc = ${str(r.desc)};\n" + r.fields.sortBy(_.lsb).map(field(_, "        ")).mkString +
      s"    } ${r.name} @ ${hex(4 * r.word)};\n"

  private def region(g: Region): String =
    s"    external reg {\n        desc = ${str(g.desc)};\n" + field(g.value, "        ") +
      s"    } ${g.name}${g.dims.map(d => s"[$d]").mkString} @ ${hex(4 * g.word)};\n"

  def text(map: RegMap): String = {
    val items = map.regs.map(r => r.word -> register(r)) ++ map.regions.map(g => g.word -> region(g))
    s"// ${map.name}: register map (SystemRDL 2.0), generated with the core.\n" +
      s"addrmap ${map.name} {\n    desc = ${str(map.desc)};\n    default regwidth = 32;\n" +
      items.sortBy(_._1).map(_._2).mkString("\n", "\n", "") + "};\n"
  }

  /** Write `outDir`/<module>.rdl. */
  def write(outDir: String, map: RegMap): Unit = Emit.writeText(s"$outDir/${map.name}.rdl", text(map))
}
