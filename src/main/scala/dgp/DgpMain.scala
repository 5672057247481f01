package dgp

/** Generator entry point: `runMain dgp.DgpMain <config.json> <outDir> [...pairs]`: <outDir>/<module>.sv, hw.json
  * (module name, cycle counts, register map) and the SystemRDL register description. */
object DgpMain extends App {
  gen.CoreMain.run(args, "dgp.DgpMain") { (cfg, out) =>
    val p = DgpParams.fromJson(cfg)
    gen.Emit.systemVerilog(new DgpCore(p), out, p.moduleName)
    gen.CoreMain.writeOutputs(out, hwJson(p), DgpRegs.map(p))
  }

  def hwJson(p: DgpParams): String = {
    val (regJson, regions) = gen.CoreMain.registerJson(DgpRegs.map(p))
    ujson.write(ujson.Obj(
      "module" -> p.moduleName, "n" -> p.n, "mc" -> p.mc, "P" -> p.units, "lanes" -> p.lanes,
      "accelerated" -> p.accelerated, "rounds" -> ujson.Obj("K" -> p.rK, "G" -> p.rG),
      "chunks" -> ujson.Obj("F" -> p.cF, "K" -> p.cK, "G" -> p.cG),
      "issue_cycles" -> ujson.Obj("F" -> p.issueF, "K" -> p.issueK, "G" -> p.issueG),
      "gap_cycles" -> ujson.Obj("K" -> p.gapK, "G" -> p.gapG),
      "tree_depth" -> p.depth, "row_latency" -> p.rowLat,
      "cycles_per_iteration" -> p.cyclesPerIteration, "solve_overhead_cycles" -> p.solveOverhead,
      "zero_start_gap" -> p.gapZ, "zero_start_saving_cycles" -> p.zeroStartSaving,
      "div_cycles" -> p.divCycles, "multipliers" -> p.multipliers, "matrix_rows" -> p.matRows,
      "axil_addr_width" -> p.axiAddrW, "stream_width" -> p.streamW,
      "registers" -> regJson, "regions" -> regions), indent = 2)
  }
}
