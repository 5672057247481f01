package fgm

import java.nio.file.{Files, Paths}

/** Generator entry point: `runMain fgm.FgmMain <config.json> <outDir> [<config.json> <outDir> ...]`.
  * Writes <outDir>/<module>.sv and <outDir>/hw.json (module name, cycle counts, register map) per pair.
  */
object FgmMain extends App {
  require(args.length >= 2 && args.length % 2 == 0, "usage: fgm.FgmMain <config.json> <outDir> [...pairs]")
  // Each configuration is checked on its own: a refusal names the file and the rule, and the others still build.
  val refused = args.grouped(2).toSeq.flatMap { case Array(cfg, out) =>
    try {
      val p = FgmParams.fromJson(new String(Files.readAllBytes(Paths.get(cfg))))
      gen.Emit.systemVerilog(new FgmCore(p), out, p.moduleName)
      gen.Emit.writeText(s"$out/hw.json", hwJson(p))
      None
    } catch {
      case e: IllegalArgumentException =>
        println(s"REFUSED $cfg: ${e.getMessage}")
        Some(cfg)
    }
  }
  if (refused.nonEmpty) sys.exit(1)

  def hwJson(p: FgmParams): String = {
    val regs = Seq(
      ("ID", FgmRegs.ID, "RO", "0x46474D31 ('FGM1')"),
      ("CONFIG0", FgmRegs.CONFIG0, "RO", "[15:0] n, [31:16] P"),
      ("CONFIG1", FgmRegs.CONFIG1, "RO", "[15:0] nw, [23:16] frac_bits, [31:24] nu"),
      ("CTRL", FgmRegs.CTRL, "RW", "[0] WARM_START, [1] HOLD (finish the current solve, accept no new frame), [2] OUT_ALL (stream all n words of z, else u0)"),
      ("IMAX", FgmRegs.IMAX, "RW", "iterations per solve, 1..65535 (writing 0 or more than 65535: SLVERR, ignored); latched at the start of each solve"),
      ("STATUS", FgmRegs.STATUS, "RO/W1C", "[0] BUSY, [1] SAT (a state word was outside the box and saturated), [2] OVERFLOW (a datapath word saturated), [3] WRITE_REJECTED, [4] TLAST_ERROR, [5] WARM_VALID; write 1 to clear bits 1-4"),
      ("SOLVES", FgmRegs.SOLVES, "RO", "solves completed since reset"),
      ("LAST_CYCLES", FgmRegs.LAST_CYCLES, "RO", "cycles of the last solve, first pass to last iteration"),
      ("CYCLES_PER_ITER", FgmRegs.CYCLES_PER_ITER, "RO", "L_F, cycles per iteration"),
      ("BETA", FgmRegs.BETA, "WO", "beta, Q-format with frac_bits fraction bits"),
      ("ONE_PLUS_BETA", FgmRegs.ONE_PLUS_BETA, "WO", "1 + beta")
    )
    val regJson = regs.map { case (nm, a, acc, d) =>
      ujson.Obj("name" -> nm, "offset" -> 4 * a, "access" -> acc, "desc" -> d)
    }
    val regions = p.regionSizes.map { case (nm, sz) =>
      nm -> ujson.Obj("offset" -> 4 * p.regionBase(nm), "bytes" -> 4 * sz)
    }
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
      "registers" -> ujson.Arr(regJson: _*),
      "regions" -> ujson.Obj.from(regions)
    )
    ujson.write(o, indent = 2)
  }
}
