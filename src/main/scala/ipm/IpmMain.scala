package ipm

/** Generator entry point: `ipm.IpmMain <config.json> <outDir> [...pairs]`. Writes <outDir>/<module>.sv, hw.json
  * (module, sizes, the programs' cycles, the MINRES schedule, the register map) and the SystemRDL description.
  */
object IpmMain extends App {
  gen.CoreMain.run(args, "ipm.IpmMain") { (cfg, out) =>
    val p = IpmParams.fromJson(cfg)
    gen.Emit.systemVerilog(new IpmCore(p), out, p.moduleName)
    gen.CoreMain.writeOutputs(out, hwJson(p), IpmRegs.map(p))
  }

  def hwJson(p: IpmParams): String = {
    val (regJson, regions) = gen.CoreMain.registerJson(IpmRegs.map(p))
    val st1 = ujson.read(Stage1Main.hwJson(p.st1))
    val mr  = ujson.read(minres.MinresMain.hwJson(p.mr))
    val o = ujson.Obj(
      "module" -> p.moduleName,
      "format" -> p.mr.formatName,
      "exp_width" -> p.mr.expW,
      "man_width" -> p.mr.manW,
      "N" -> p.N,
      "P" -> p.P,
      "problems_in_flight" -> p.slots,
      "in_words" -> p.inWords,
      "out_words" -> p.outWords,
      "multiplexed" -> p.multiplexed,
      "plan_words" -> p.planWords,
      "stage1" -> st1,
      "minres" -> mr,
      "axil_addr_width" -> p.axiAddrW,
      "registers" -> regJson,
      "regions" -> regions
    )
    ujson.write(o, indent = 2)
  }
}
