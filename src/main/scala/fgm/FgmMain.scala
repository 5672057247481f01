package fgm

/** Generator entry point: `runMain fgm.FgmMain <config.json> <outDir> [<config.json> <outDir> ...]`.
  * Writes <outDir>/<module>.sv, <outDir>/hw.json (module name, cycle counts, register map) and the SystemRDL
  * register description <outDir>/<module>.rdl per pair.
  */
object FgmMain extends App {
  gen.CoreMain.run(args, "fgm.FgmMain") { (cfg, out) =>
    val p = FgmParams.fromJson(cfg)
    gen.Emit.systemVerilog(new FgmCore(p), out, p.moduleName)
    gen.CoreMain.writeOutputs(out, hwJson(p), FgmRegs.map(p))
  }

  def hwJson(p: FgmParams): String = {
    val (regJson, regions) = gen.CoreMain.registerJson(FgmRegs.map(p))
    val o = ujson.Obj(
      "module" -> p.moduleName,
      "n" -> p.n,
      "P" -> p.P,
      "problems" -> p.Kp,
      "period_cycles" -> p.periodCycles,
      "K" -> p.K,
      "tree_inputs" -> p.m,
      "tree_depth" -> p.depth,
      "cycles_per_iteration" -> p.cyclesPerIteration,
      "cycles_eq23" -> p.cyclesEq23,
      "solve_overhead_cycles" -> p.solveOverhead,
      "cycles_per_solve" -> p.cyclesPerSolve(p.imaxDefault),
      "multipliers" -> p.multipliers,
      "axil_addr_width" -> p.axiAddrW,
      "stream_width" -> p.streamW,
      "p_bits" -> p.pBits,
      "col_bits" -> p.cBits,
      "registers" -> regJson,
      "regions" -> regions
    )
    ujson.write(o, indent = 2)
  }
}
