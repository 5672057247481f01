package admm

/** Generator entry point: `runMain admm.AdmmMain <config.json> <outDir> [<config.json> <outDir> ...]`.
  * Writes <outDir>/<module>.sv, <outDir>/hw.json (module name, cycle counts, register map, row placement) and the
  * SystemRDL register description <outDir>/<module>.rdl.
  */
object AdmmMain extends App {
  gen.CoreMain.run(args, "admm.AdmmMain") { (cfg, out) =>
    val p = AdmmParams.fromJson(cfg)
    gen.Emit.systemVerilog(new AdmmCore(p), out, p.moduleName)
    gen.CoreMain.writeOutputs(out, hwJson(p), AdmmRegs.map(p))
  }

  def hwJson(p: AdmmParams): String = {
    val (regJson, regions) = gen.CoreMain.registerJson(AdmmRegs.map(p))
    val o = ujson.Obj(
      "module" -> p.moduleName,
      "n" -> p.n,
      "P" -> p.P,
      "problems" -> p.Kp,
      "period_cycles" -> p.periodCycles,
      "K" -> p.K,
      "tree_inputs" -> p.lanes,
      "chunks" -> p.chunks,
      "tree_depth" -> p.depth,
      "cycles_per_iteration" -> p.cyclesPerIteration,
      "accelerated" -> p.accelerated,
      "momentum_cycles" -> p.momLat,
      "cycles_eq24" -> p.cyclesEq24,
      "solve_overhead_cycles" -> p.solveOverhead,
      "cycles_per_solve" -> p.cyclesPerSolve(p.imaxDefault),
      "multipliers" -> p.multipliers,
      "shifts" -> ujson.Arr(p.shifts.map(ujson.Num(_)): _*),
      "row_units" -> ujson.Arr(p.rows.map(r => ujson.Arr(r.map(_.map(ujson.Num(_)).getOrElse(ujson.Null)): _*)): _*),
      "axil_addr_width" -> p.axiAddrW,
      "stream_width" -> p.streamW,
      "col_bits" -> p.cBits,
      "registers" -> regJson,
      "regions" -> regions
    )
    ujson.write(o, indent = 2)
  }
}
