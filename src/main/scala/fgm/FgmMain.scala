package fgm

/** Generator entry point: `runMain fgm.FgmMain <config.json> <outDir> [<config.json> <outDir> ...]`.
  * Writes <outDir>/<module>.sv and <outDir>/hw.json (module name, cycle counts, register map) per pair.
  */
object FgmMain extends App {
  gen.CoreMain.run(args, "fgm.FgmMain") { (cfg, out) =>
    val p = FgmParams.fromJson(cfg)
    gen.Emit.systemVerilog(new FgmCore(p), out, p.moduleName)
    gen.Emit.writeText(s"$out/hw.json", hwJson(p))
  }

  def hwJson(p: FgmParams): String = {
    val regs = shell.SolverRegs.descriptions("0x46474D31 ('FGM1')", "[15:0] n, [31:16] P",
      "[15:0] nw, [23:16] frac_bits, [31:24] nu", "u0") ++ Seq(
      ("BETA", FgmRegs.BETA, "WO", "beta, Q-format with frac_bits fraction bits"),
      ("ONE_PLUS_BETA", FgmRegs.ONE_PLUS_BETA, "WO", "1 + beta")
    )
    val (regJson, regions) = gen.CoreMain.registerJson(regs, p.regionSizes, p.regionBase)
    val o = ujson.Obj(
      "module" -> p.moduleName,
      "n" -> p.n,
      "P" -> p.P,
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
