package minres

import chisel3._
import shell.{Field, RegMap, SolverRegs}

/** The warm form's inputs from the interior-point core (MinresParams.warm): the MINRES iterations of the next
  * batch (latched at its start, 1..65535) and `close`, a pulse that sends a partly loaded batch on at once. */
class MinresIpmIO extends Bundle {
  val imax  = UInt(16.W)
  val close = Bool()
}

/** The register map of a MINRES core: the shared registers of shell.SolverRegs (no warm start, no output choice,
  * no data memories) with STATUS bit 6 NONFINITE. */
object MinresRegs {
  def map(p: MinresParams): RegMap = {
    val none = "no effect on this core"
    val regs = SolverRegs.registers("MNR1",
      config0 = Seq(Field.const("N", 0, 16, p.N, "order of the KKT matrix"),
        Field.const("P", 16, 16, p.P, "problems per batch")),
      config1 = Seq(Field.const("n", 0, 8, p.n, "states"), Field.const("m", 8, 8, p.m, "inputs"),
        Field.const("T", 16, 16, p.T, "horizon")),
      ctrl = SolverRegs.ctrlFields(warmDefault = false, outAllDefault = false, "", warmText = none, outText = none),
      status = SolverRegs.statusFields(warm = false, unused = Set("SAT", "OVERFLOW", "WRITE_REJECTED"),
        extra = Seq(Field.w1c("NONFINITE", 6, "a non-finite input word or solution; the problem's output id has " +
          "bit 31 set"))),
      cyclesPerIteration = p.cyclesPerIteration, imaxDefault = p.imaxDefault,
      lastCycles = "cycles of the last batch", solves = "problems solved since reset")
    RegMap(p.moduleName, s"MINRES core ${p.moduleName}: control and status, 32-bit registers on AXI4-Lite, no " +
      "data memories; an unmapped address: DECERR.", regs, Nil)
  }
}
