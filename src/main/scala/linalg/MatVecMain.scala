package linalg

/** Generator entry point: `runMain linalg.MatVecMain <config.json> <outDir> [...]`. Writes <outDir>/<module>.sv
  * and <outDir>/hw.json (module name, sizes, stream widths and the cycle contract). */
object MatVecMain extends App {
  gen.CoreMain.run(args, "linalg.MatVecMain") { (cfg, out) =>
    val p = MatVecParams.fromJson(cfg)
    gen.Emit.systemVerilog(new MatVecCore(p), out, p.moduleName)
    gen.Emit.writeText(s"$out/hw.json", ujson.write(ujson.Obj(
      "module" -> p.moduleName,
      "n" -> p.n,
      "P" -> p.P,
      "K" -> p.K,
      "multipliers" -> p.multipliers,
      "tree_latency" -> p.dp.latency,
      "run_cycles" -> p.runCycles,
      "latency_cycles" -> p.latency,
      "period_cycles" -> p.periodCycles,
      "in_stream_width" -> p.inW,
      "out_stream_width" -> p.outW,
      "op_width" -> p.opW,
      "sum_width" -> p.sumW
    ), indent = 2))
  }
}
