package ipm

import chisel3.util.log2Ceil
import minres.MinresParams
import shell.{Field, RegMap, Register, SolverRegs}

/** The interior-point core (mpc_cores/ipm/design.py writes its config.json): the Stage 1 engine on 2P problem
  * slots (`stage1`, a Stage1Params configuration), the MINRES solver in its warm form on P (`minres`), and the
  * core's own parameters: n states, m inputs, ny references (0 without tracking), the default Newton iterations
  * I_NW and the convergence tolerances on mu and ||r_0|| (raw words of the format). The Stage 1 programs must
  * keep the stream protocol the core wires up; it is checked here from their IN and OUT instructions.
  *
  * `multiplexed` (parallel multiplexed MPC, Algorithm 2 of 001): every channel solves one input's single-input
  * problem (m = 1 here), its constants in its Stage 1 constant bank and its MINRES coefficient table (channel c:
  * input c mod the number of banks); a frame carries x^, the steady state (x_s, u_s,i) and the known term F (n T
  * words) instead of r, and an answer the T planned moves after u0 and mu (mpc_cores/ipm/program.py).
  */
case class IpmParams(
    name: String,
    n: Int,
    m: Int,
    ny: Int,
    iNw: Int,
    muTol: BigInt,
    resTol: BigInt,
    st1: Stage1Params,
    mr: MinresParams,
    multiplexed: Boolean = false) {
  import Isa._
  val P: Int     = mr.P
  val slots: Int = 2 * P
  val N: Int     = mr.N
  val T: Int     = mr.T
  val npr: Int   = mr.nPrimal
  val fmt        = mr.fmt
  require(mr.warm, "the MINRES configuration of the interior-point core must be its warm form (warm: true)")
  require(st1.slots == slots, s"the Stage 1 engine needs 2P = $slots slots: got ${st1.slots}")
  require(slots <= 64, s"2P must be at most 64 (the channel field of the id word): got P = $P")
  require(st1.fmt == fmt, s"Stage 1 and MINRES must use one float format: got ${st1.fmt} and $fmt")
  require(n == mr.n && m == mr.m, s"n, m must match the MINRES configuration: got $n, $m and ${mr.n}, ${mr.m}")
  require(ny >= 0 && iNw >= 1 && iNw <= 65535, s"need ny >= 0 and I_NW in [1, 65535]: got ny=$ny, I_NW=$iNw")
  require(!multiplexed || ny == 0 && m == 1 && st1.constBanks == mr.coefTables.length,
    s"a multiplexed core has m = 1, ny = 0 and one Stage 1 constant bank per MINRES table: got m=$m, ny=$ny, " +
      s"${st1.constBanks} banks and ${mr.coefTables.length} tables")
  /** words of a sample's input after the id: x^ and r, or (multiplexed) x^, (x_s, u_s,i) and F */
  val inData: Int = if (multiplexed) n + (n + m) + n * T else n + ny
  /** the planned moves an answer carries after u0 and mu (multiplexed) */
  val planWords: Int = if (multiplexed) T else 0
  require(Seq(muTol, resTol).forall(w => w >= 0 && w < (BigInt(1) << fmt.width)), "tolerances are raw words of the format")

  /** program index by name */
  def prog(name: String): Int = {
    val k = st1.programs.indexWhere(_._1 == name)
    require(k >= 0, s"the Stage 1 configuration has no program '$name'")
    k
  }
  private def words(name: String, op: Int): Int =
    st1.programs(prog(name))._2.map(decode).filter(_.op == op).map(_.n).sum
  // the stream protocol of the programs (mpc_cores/ipm/program.py)
  private val protocol = Seq(("sample", IN, inData), ("sample", OUT, 0), ("cold", IN, 0), ("cold", OUT, 0),
    ("warm", IN, 0), ("warm", OUT, 0), ("linearise", IN, 0), ("linearise", OUT, npr + 3 * N), ("receive", IN, N),
    ("receive", OUT, 0), ("update", IN, 0), ("update", OUT, 0), ("output", IN, 0), ("output", OUT, m + 1 + planWords),
    ("output_all", IN, 0), ("output_all", OUT, m + 1 + planWords + N + n + m))
  for ((pr, op, w) <- protocol) require(words(pr, op) == w,
    s"program $pr must ${ops(op)} $w words (the core's stream protocol): got ${words(pr, op)}")

  /** frames: in id, x (n), r (ny) (multiplexed: inData); out id, u0 (m), mu, (multiplexed: the plan, T), (CTRL.OUT_ALL:
    * z (N), x_s (n), u_s (m)), ||r_0||, status */
  val inWords: Int     = 1 + inData
  val outWords: Int    = m + 4 + planWords
  val outWordsAll: Int = outWords + N + n + m
  val axiAddrW: Int = log2Ceil(SolverRegs.RegionStart) + 2
  val moduleName: String =
    s"IpmCore_${name}_n${n}_m${m}_t${T}_p$P" + (if (mr.formatName == "binary32") "" else s"_${mr.formatName}") +
      (if (mr.target == dsp.Target.Generic) "" else s"_${mr.target.name}")
}

object IpmParams {
  def fromJson(text: String): IpmParams = {
    val j = ujson.read(text)
    require(j("core").str == "ipm", s"not an interior-point configuration: core=${j("core").str}")
    // the Stage 1 engine's slots are 2P, P the MINRES core's (eq. (15) when the configuration says 0)
    val mr = MinresParams.fromJson(ujson.write(j("minres")))
    IpmParams(
      name = j("name").str,
      n = j("n").num.toInt,
      m = j("m").num.toInt,
      ny = j("ny").num.toInt,
      iNw = j("i_nw").num.toInt,
      muTol = BigInt(j("mu_tol").num.toLong),
      resTol = BigInt(j("res_tol").num.toLong),
      st1 = Stage1Params.fromJson(ujson.write(j("stage1"))).copy(slots = 2 * mr.P),
      mr = mr,
      multiplexed = j.obj.get("multiplexed").exists(_.bool)
    )
  }
}

/** The register map of the interior-point core: the shared registers (IMAX is I_MR, the MINRES iterations per
  * Newton iteration), the core's I_NW and tolerances, and its STATUS flags. */
object IpmRegs {
  val INW = SolverRegs.FirstCoreReg
  val MU_TOL = INW + 1
  val RES_TOL = INW + 2

  def map(p: IpmParams): RegMap = {
    val regs = SolverRegs.registers("IPM1",
      config0 = Seq(Field.const("N", 0, 16, p.N, "order of the KKT matrix"),
        Field.const("P", 16, 16, p.P, "problems per MINRES batch (2P in flight)")),
      config1 = Seq(Field.const("n", 0, 8, p.n, "states"), Field.const("m", 8, 8, p.m, "inputs"),
        Field.const("T", 16, 16, p.T, "horizon")),
      ctrl = SolverRegs.ctrlFields(warmDefault = true, outAllDefault = false, "",
        warmText = "start each sample from its channel's previous iterate (001, unshifted, (lambda, s) raised to " +
          "the floor); else, and on a channel's first sample or after a non-finite one, the cold start",
        outText = "after u0 and mu, the answer also carries the whole iterate z (N words in the KKT order, lambda_k, " +
          "x_k, u_k per stage, the primal words as deviations from the steady state) and the steady state (x_s, " +
          "u_s); read when a problem's answer starts"),
      status = SolverRegs.statusFields(warm = false, unused = Set("SAT", "OVERFLOW", "WRITE_REJECTED"),
        extra = Seq(
          Field.w1c("NONFINITE", 6, "an answer had a non-finite input word or result (its status word bit 0)"),
          Field.w1c("NOT_CONVERGED", 7, "an answer missed MU_TOL or RES_TOL (its status word bit 1)"),
          Field.w1c("CHANNEL", 8, "an id word's channel field was 2P or more (taken modulo 2P)"))),
      cyclesPerIteration = p.mr.cyclesPerIteration, imaxDefault = p.mr.imaxDefault,
      lastCycles = "cycles of the last answer, from its id word's handshake to its status word's",
      solves = "answers sent since reset") ++ Seq(
      Register("INW", INW, "Newton iterations per sample (I_NW); writing 0 or more than 65535: SLVERR, ignored",
        Seq(Field.ctrl("INW", 0, 16, p.iNw, "I_NW, 1..65535, latched when a batch of problems starts"))),
      Register("MU_TOL", MU_TOL, "convergence tolerance on mu (a word of the format)",
        Seq(Field.ctrl("VALUE", 0, 32, p.muTol, "an answer with mu above it is flagged NOT_CONVERGED"))),
      Register("RES_TOL", RES_TOL, "convergence tolerance on ||r_0|| of the last Newton system (a word of the format)",
        Seq(Field.ctrl("VALUE", 0, 32, p.resTol, "an answer with ||r_0|| above it is flagged NOT_CONVERGED"))))
    RegMap(p.moduleName, s"Interior-point core ${p.moduleName}: control and status, 32-bit registers on AXI4-Lite, " +
      "no data memories; an unmapped address: DECERR.", regs, Nil)
  }
}
