package ipm

/** Generator entry point: `ipm.Stage1Main <config.json> <outDir> [...pairs]`. Writes <outDir>/<module>.sv and
  * <outDir>/hw.json: module name, format, latencies (per unit and per op), the programs with their entry, length
  * and cycles as the engine counts them (start to done without stream stalls), the memories and units built.
  */
object Stage1Main extends App {
  gen.CoreMain.run(args, "ipm.Stage1Main") { (cfg, out) =>
    val p = Stage1Params.fromJson(cfg)
    gen.Emit.systemVerilog(new Stage1Engine(p), out, p.moduleName)
    gen.Emit.writeText(s"$out/hw.json", hwJson(p))
  }

  def hwJson(p: Stage1Params): String = {
    val progs = p.programs.zipWithIndex.map { case ((name, code), k) =>
      ujson.Obj("name" -> name, "index" -> k, "entry" -> p.entries(k), "length" -> code.length,
        "cycles" -> p.programCycles(k))
    }
    val o = ujson.Obj(
      "module" -> p.moduleName,
      "exp_w" -> p.fmt.expW,
      "man_w" -> p.fmt.manW,
      "slots" -> p.slots,
      "slot_words" -> p.slotWords,
      "const_words" -> p.constWords.length,
      "const_banks" -> p.constBanks,
      "instructions" -> p.code.length,
      "latency" -> ujson.Obj("add" -> p.latAdd, "mul" -> p.latMul, "div" -> p.latDiv, "sqrt" -> p.latSqrt,
        "cmp" -> p.latCmp, "acc" -> p.latAcc),
      "op_latency" -> ujson.Obj.from(Isa.ops.zipWithIndex.map { case (op, k) => op -> ujson.Num(p.latency(k)) }),
      "issue_gap" -> Stage1Params.IssueGap,
      "program_start" -> Stage1Params.ProgramStart,
      "programs" -> ujson.Arr(progs: _*),
      "memories" -> ujson.Obj(
        "slot_copies" -> (if (p.slotB) 2 else 1),
        "slot_words_total" -> p.slotMemWords,
        "const_roms" -> (Seq(p.constA, p.constB).count(identity)),
        "table_roms" -> (Seq(p.gatherD, p.gatherA, p.gatherB).count(identity)),
        "table_words" -> p.tableWords.length),
      "acc_lengths" -> ujson.Arr(p.accLengths.map(ujson.Num(_)): _*)
    )
    ujson.write(o, indent = 2)
  }
}
