package fgm

import chisel3.util.log2Ceil
import dsp.Target
import fixed.{FixedOps, Rounding}

/** Everything the FGM generator needs: sizes, word widths (from the overflow bounds, Prop. 1 of 002, computed by
  * the Python front end) and the quantised problem data that initialises the memories.
  * Integers are fixed-point words with `fracBits` fraction bits.
  *
  * @param n      decision variables N*nu
  * @param nu     inputs per stage (the warm start shifts by nu)
  * @param nw     parameter words per solve: state x then reference r
  * @param P      parallelism: row units working on rows p, p+P, p+2P, ...
  * @param Kp     problems interleaved on the row units (shell.TurnSequencer), 1: one at a time
  * @param a      (I - H_n), n x n
  * @param f      Phi_n, n x nw
  * @param earlyExit  build the exit test: a solve ends after the first iteration i with ||z_i - z_(i-1)||_inf and
  *                   ||z_(i-1) - z_(i-2)||_inf below EXIT_TOL (z_(-1) = z_0), else at Imax (one problem only)
  * @param exitTol    EXIT_TOL's reset value, a word of z's format (0: the test never holds)
  */
case class FgmParams(
    name: String,
    n: Int,
    nu: Int,
    nw: Int,
    P: Int,
    Kp: Int,
    fracBits: Int,
    latAdd: Int,
    latMul: Int,
    rounding: Rounding,
    target: Target,
    coefW: Int,
    xW: Int,
    yW: Int,
    zW: Int,
    sumW: Int,
    tW: Int,
    betaW: Int,
    streamW: Int,
    imaxDefault: Int,
    warmDefault: Boolean,
    outAllDefault: Boolean,
    a: Seq[Seq[BigInt]],
    f: Seq[Seq[BigInt]],
    lo: Seq[BigInt],
    hi: Seq[BigInt],
    xlo: Seq[BigInt],
    xhi: Seq[BigInt],
    beta: BigInt,
    onePlusBeta: BigInt,
    earlyExit: Boolean = false,
    exitTol: BigInt = 0) {

  require(n >= 1, s"n must be >= 1, got n=$n")
  require(nu >= 1 && n % nu == 0, s"nu must divide n: got nu=$nu, n=$n")
  require(nw >= 1, s"nw (state + reference words) must be >= 1, got nw=$nw")
  require(P >= 1, s"P must be >= 1: got P=$P")
  require(P <= n, s"P must not exceed n (one row unit per variable at most): got P=$P, n=$n")
  require(Kp >= 1 && Kp <= 16, s"problems must be in [1, 16]: got $Kp")
  require(latAdd >= 0 && latMul >= 0, s"latencies must be >= 0: got lat_add=$latAdd, lat_mul=$latMul")
  require(fracBits >= 1, s"frac_bits must be >= 1, got $fracBits")
  for ((nm, w) <- Seq("coef" -> coefW, "x" -> xW, "z" -> zW, "beta" -> betaW))
    require(w >= 2 && w <= 32, s"$nm width must be in [2, 32] (one AXI4-Lite word): got $w")
  for ((nm, w) <- Seq("y" -> yW, "sum" -> sumW, "t" -> tW))
    require(w >= 2 && w <= 64, s"$nm width must be in [2, 64]: got $w")
  require(streamW % 8 == 0 && streamW >= math.max(xW, zW) && streamW <= 64,
    s"stream width must be a multiple of 8 in [max(x, z width), 64]: got $streamW, x=$xW, z=$zW")
  require(imaxDefault >= 1 && imaxDefault <= 65535, s"iterations must be in [1, 65535], got $imaxDefault")
  require(a.length == n && a.forall(_.length == n), s"A must be $n x $n")
  require(f.length == n && f.forall(_.length == nw), s"F must be $n x $nw")
  require(lo.length == n && hi.length == n, s"lo/hi must have $n entries")
  require(xlo.length == nw && xhi.length == nw, s"xlo/xhi must have $nw entries")
  require(lo.zip(hi).forall { case (l, h) => l <= h }, "input bounds: lo <= hi required for every component")
  require(xlo.zip(xhi).forall { case (l, h) => l <= h }, "state box: xlo <= xhi required for every component")

  private def fits(v: BigInt, w: Int) = v >= FixedOps.minOf(w) && v <= FixedOps.maxOf(w)
  require((a.flatten ++ f.flatten).forall(fits(_, coefW)), s"a matrix entry does not fit the coefficient width $coefW")
  require((lo ++ hi).forall(fits(_, zW)), s"an input bound does not fit the z width $zW")
  require((xlo ++ xhi).forall(fits(_, xW)), s"a state bound does not fit the x width $xW")
  require(fits(beta, betaW) && fits(onePlusBeta, betaW), s"beta does not fit the beta width $betaW")
  require(!earlyExit || Kp == 1, s"the early exit needs one problem (interleaved problems share fixed turns): got problems=$Kp")
  require(exitTol >= 0 && fits(exitTol, tolW), s"exit_tol must be in [0, ${FixedOps.maxOf(tolW)}]: got $exitTol")

  /** Rows per unit ceil(n/P). */
  val K: Int = (n + P - 1) / P
  /** Multipliers per dot product: the h = Phi_n x pass shares them, so max(n, nw). */
  val m: Int = math.max(n, nw)
  val depth: Int = log2Ceil(m)
  /** Operand width: the multiplexer of Fig. 1 feeds y (iterations) or x (first pass). */
  val opW: Int = math.max(xW, yW)
  /** Stages from the matrix-row fetch: operands, tree sum, t, z, y (see FgmCore). */
  val stageSum: Int = 1 + latMul + latAdd * depth
  val stageT:   Int = stageSum + latAdd
  val stageZ:   Int = stageT + latAdd
  val stageY:   Int = stageZ + latMul + latAdd
  /** EXIT_TOL's width: the step z+ - z has zW + 1 bits */
  lazy val tolW: Int = zW + 1
  /** Cycles the exit test adds to an iteration: its decision (the step, its comparison, the OR over the row units)
    * reaches the sequencer 5 cycles after the last row's z, which the y update's latMul + latAdd cover in part. */
  val exitExtra: Int = if (earlyExit) math.max(0, 5 - latMul - latAdd) else 0
  /** Cycles per iteration, eq. (23) of 002 with ceil(log2 max(n, nw)) levels, and the exit test's extra cycles. */
  val cyclesPerIteration: Int = K + latAdd * depth + 2 * latMul + 3 * latAdd + 1 + exitExtra
  /** Cycles between two passes of one problem: L alone, a round of Kp turns of K cycles when interleaving. */
  val periodCycles: Int = if (Kp == 1) cyclesPerIteration else math.max(cyclesPerIteration, Kp * K)
  val cyclesEq23: Int = K + latAdd * log2Ceil(n) + 2 * latMul + 3 * latAdd + 1
  /** From the handshake of the last input word to the first output word valid: 5 + K + Imax * L (the start two
    * cycles after the frame's last word, shell.PassSequencer; the first pass issues K rows and leaves one cycle, in
    * which the cold start's last registers are written; the answer's output queue, shell.AnswerQueue). */
  val solveOverhead: Int = if (Kp == 1) 5 + K else 3 + cyclesPerIteration + 2
  /** Interleaving (shell.TurnSequencer): the least latency, when the frame arrives just before its slot's turn
    * (it waits up to periodCycles - 1 more): taken, loaded, Imax + 1 turns, the last pass's drain, the answer
    * queue and the output register. */
  def cyclesPerSolve(imax: Int): Int = solveOverhead + imax * periodCycles
  val multipliers: Int = P * m + 2 * P

  val moduleName: String =
    s"FgmCore_${name}_n${n}_p${P}_b${fracBits}" + (if (Kp > 1) s"_k$Kp" else "") + (if (target == Target.Generic) "" else s"_${target.name}")

  // ---- register map (word addresses; byte address = 4 * word) ----
  val pBits: Int = log2Ceil(P)
  val cBits: Int = log2Ceil(m)
  val slots: Int = K << pBits
  val (regionSizes: Seq[(String, Int)], regionBase: Map[String, Int], addrWords: Int) =
    shell.SolverRegs.layout(Seq("XBOX" -> 2 * nw, "UBOX" -> 2 * slots, "MAT_A" -> (slots << cBits), "MAT_F" -> (slots << cBits)))
  /** Byte-address width of the AXI4-Lite port. */
  val axiAddrW: Int = log2Ceil(addrWords) + 2

  /** Rows per block of a unit's matrix memory (the second block starts there): 2^ceil(log2 K), at least 2. */
  lazy val K2: Int = 1 << math.max(1, log2Ceil(K))
  def matInit(p: Int): Seq[Seq[BigInt]] = {
    val zero = Seq.fill(m)(BigInt(0))
    def pad(r: Seq[BigInt]) = r ++ Seq.fill(m - r.length)(BigInt(0))
    val rows = (0 until K).map(_ * P + p)
    // rows 0..K-1: (I - H_n) rows kP+p; rows K2..K2+K-1: the Phi_n rows
    rows.map(r => if (r < n) pad(a(r)) else zero) ++ Seq.fill(K2 - K)(zero) ++ rows.map(r => if (r < n) pad(f(r)) else zero)
  }
  def boundInit(p: Int): Seq[Seq[BigInt]] =
    (0 until K).map(_ * P + p).map(r => if (r < n) Seq(lo(r), hi(r)) else Seq(BigInt(0), BigInt(0)))
}

object FgmParams {
  import gen.ConfigJson.{ints, mat}

  /** Read the config.json written by the Python front end (mpc_cores/fgm/design.py). */
  def fromJson(text: String): FgmParams = {
    val j = ujson.read(text)
    val w = j("widths")
    FgmParams(
      name = j("name").str,
      n = j("n").num.toInt,
      nu = j("nu").num.toInt,
      nw = j("nw").num.toInt,
      P = j("P").num.toInt,
      Kp = j.obj.get("problems").map(_.num.toInt).getOrElse(1),
      fracBits = j("frac_bits").num.toInt,
      latAdd = j("lat_add").num.toInt,
      latMul = j("lat_mul").num.toInt,
      rounding = Rounding(j("rounding").str),
      target = Target(j.obj.get("target").map(_.str).getOrElse("generic")),
      coefW = w("coef").num.toInt,
      xW = w("x").num.toInt,
      yW = w("y").num.toInt,
      zW = w("z").num.toInt,
      sumW = w("sum").num.toInt,
      tW = w("t").num.toInt,
      betaW = w("beta").num.toInt,
      streamW = w("stream").num.toInt,
      imaxDefault = j("iterations").num.toInt,
      warmDefault = j("warm_start").bool,
      outAllDefault = j("output_all").bool,
      a = mat(j("A")),
      f = mat(j("F")),
      lo = ints(j("lo")),
      hi = ints(j("hi")),
      xlo = ints(j("xlo")),
      xhi = ints(j("xhi")),
      beta = BigInt(j("beta").num.toLong),
      onePlusBeta = BigInt(j("one_plus_beta").num.toLong),
      earlyExit = j.obj.get("early_exit").exists(_.bool),
      exitTol = j.obj.get("exit_tol").map(v => BigInt(v.num.toLong)).getOrElse(BigInt(0))
    )
  }
}
