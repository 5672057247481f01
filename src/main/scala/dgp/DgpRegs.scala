package dgp

import shell.{Field, RegMap, Register, SolverRegs}

/** The register map of a DGP core: the shared registers and ITERATIONS; the data are fixed at generation. */
object DgpRegs {
  val ITERATIONS = SolverRegs.FirstCoreReg

  def map(p: DgpParams): RegMap = {
    val shared = SolverRegs.registers("DGP1",
      config0 = Seq(Field.const("n", 0, 16, p.n, "decision variables n = N nu"),
        Field.const("m", 16, 16, 2 * p.mc, "one-sided constraints (dual words)")),
      config1 = Seq(Field.const("nw", 0, 16, p.nw, "parameter words per solve, w = (x, r)"),
        Field.const("frac_bits", 16, 8, p.fracBits, "fraction bits of the data and stream words"),
        Field.const("nu", 24, 8, p.nu, "inputs per stage")),
      ctrl = SolverRegs.ctrlFields(p.warmDefault, p.outAllDefault, "u0 (nu words)",
        warmText = "start from the previous solve's dual (unshifted) when STATUS.WARM_VALID, else from y = 0"),
      status = SolverRegs.statusFields(unused = Set("WRITE_REJECTED")),
      cyclesPerIteration = p.cyclesPerIteration, imaxDefault = p.imaxDefault,
      lastCycles = "cycles of the last solve, first pass to its decision cycle")
    val its = Register("ITERATIONS", ITERATIONS, "the last solve's iterations", Seq(
      Field.status("COUNT", 0, 16, "iterations run by the last solve"),
      Field.status("MET", 16, 1, "the last solve stopped at the test ((32c) of 003; accelerated: with the gap test)"),
      Field.status("ZERO_START", 17, 1, "the last solve started from an all-zero dual (every cold start) and skipped " +
        "its first pass K: its cycles are those of core.json's zero_start_saving_cycles fewer")))
    RegMap(p.moduleName, s"DGP core ${p.moduleName}: control and status; the problem data are fixed at generation. " +
      SolverRegs.rules, shared :+ its, Nil)
  }
}
