package admm

import shell.{Field, RegMap, Region, SolverRegs}

/** The register map of an ADMM core: the shared registers of shell.SolverRegs and the data memories, addressed by
  * component index. */
object AdmmRegs {
  def map(p: AdmmParams): RegMap = {
    val shared = SolverRegs.registers("ADM1",
      config0 = Seq(Field.const("n_A", 0, 16, p.n, "components of z"), Field.const("P", 16, 16, p.P, "row units")),
      config1 = Seq(Field.const("nw", 0, 16, p.nw, "parameter words per solve, w = (x, u_prev, r)"),
        Field.const("frac_bits", 16, 8, p.fracBits, "fraction bits of the data and stream words"),
        Field.const("nu", 24, 8, p.nu, "inputs per stage")),
      ctrl = SolverRegs.ctrlFields(p.warmDefault, p.outAllDefault, "du_0 (nu words)",
        warmText = "start from the previous z and nu shifted by one stage when STATUS.WARM_VALID, else cold"),
      status = SolverRegs.statusFields(),
      cyclesPerIteration = p.periodCycles, imaxDefault = p.imaxDefault)
    val word = s"signed, ${p.fracBits} fraction bits, sign-extended to 32 bits"
    val sizes = p.regionSizes.toMap
    def region(nm: String, dims: Seq[Int], desc: String, w: Int) =
      Region(nm, p.regionBase(nm), sizes(nm), dims, desc, Field.data(s"$word; must fit $w bits, else SLVERR"))
    val cols = 1 << p.cBits
    RegMap(p.moduleName, s"ADMM core ${p.moduleName}: control, status and write-only data memories. ${SolverRegs.rules}",
      shared, Seq(
        region("MAT_M", Seq(p.n, cols), "M11: element (i, j) is row i, column j (component indices of z); columns " +
          "from n_A on: DECERR", p.coefW),
        region("MAT_G", Seq(p.n, cols), "G~: element (i, j) is row i, column j over (x, u_prev, r, 1); columns from " +
          "nw + 1 on: DECERR", p.coefW),
        region("BND", Seq(p.n, 2), "component i: (i, 0) lower and (i, 1) upper bound of a box component, centre " +
          "and radius at the slack of a soft pair; other components: DECERR; a write drops the warm start", p.zW),
        region("WBOX", Seq(p.nw, 2), "parameter box: element (j, 0) the lower, (j, 1) the upper bound of word j of " +
          "w = (x, u_prev, r); words outside saturate and set STATUS.SAT", p.wW)))
  }
}
