package minres

/** Generator entry point: `runMain minres.MinresMain <config.json> <outDir> [...pairs]`. Writes <outDir>/<module>.sv,
  * <outDir>/hw.json (module, P, schedule, cycle counts, storage, register map) and the SystemRDL register
  * description <outDir>/<module>.rdl.
  */
object MinresMain extends App {
  gen.CoreMain.run(args, "minres.MinresMain") { (cfg, out) =>
    val p = MinresParams.fromJson(cfg)
    gen.Emit.systemVerilog(new MinresCore(p), out, p.moduleName)
    gen.CoreMain.writeOutputs(out, hwJson(p), MinresRegs.map(p))
  }

  def hwJson(p: MinresParams): String = {
    val (regJson, regions) = gen.CoreMain.registerJson(MinresRegs.map(p))
    val o = ujson.Obj(
      "module" -> p.moduleName,
      "format" -> p.formatName,
      "exp_width" -> p.expW,
      "man_width" -> p.manW,
      "word_width" -> p.fmt.width,
      "N" -> p.N,
      "M" -> p.M,
      "K" -> p.K,
      "P" -> p.P,
      "P_eq15" -> p.pAuto,
      "k1" -> p.k1,
      "k2" -> p.k2,
      "slot_cycles" -> p.S,
      "cycles_per_iteration" -> p.cyclesPerIteration,
      "cycles_bound" -> (p.P * p.N + p.P),
      "batch_cycles_formula" -> s"(Imax + 1) * ${p.cyclesPerIteration} + ${p.batchCycles(0) - p.cyclesPerIteration}",
      "batch_cycles_imax0" -> p.batchCycles(0),
      "schedule" -> ujson.Obj("t_row" -> p.tRow, "t_delta" -> p.tDelta, "t_B" -> p.tB, "t_scalar" -> p.tS,
        "t_C" -> p.tC, "need" -> p.need, "lat_matvec" -> p.latMatvec, "lat_scalar" -> p.latScalar, "shared_scalar" -> p.sharedScalar, "shared_acc" -> p.shareAcc,
        "acc_tail" -> p.accTail),
      "storage_words" -> p.storageWords,
      "storage_variable" -> p.storageVariable,
      "storage_constant" -> p.storageConstant,
      "storage_dense_cds" -> p.storageDense,
      "storage_bound_001" -> p.storageBound,
      "frame_words" -> p.frameWords,
      "out_words" -> p.outWords,
      "warm" -> p.warm,
      "storage_warm" -> p.storageWarm,
      "multipliers" -> p.multipliers,
      "axil_addr_width" -> p.axiAddrW,
      "registers" -> regJson,
      "regions" -> regions
    )
    ujson.write(o, indent = 2)
  }
}
