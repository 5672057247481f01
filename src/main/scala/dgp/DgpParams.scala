package dgp

import chisel3.util.log2Ceil
import dsp.Target
import fixed.FixedOps

/** Everything the DGP generator needs (mpc_cores/dgp/design.py writes it): sizes, word widths from (36)/(37) of 003,
  * and the quantised data of iteration (35). Integers are words with `fracBits` fraction bits.
  *
  * @param mc     two-sided constraint rows (the dual has 2 mc words: upper rows, then lower rows)
  * @param units  row units P: unit u takes the rows u, u + P, ... of every pass (rK = ceil(n / P) rows of pass K
  *               and rG = ceil(mc / P) of pass G each; the last rounds' missing rows are zero rows)
  * @param lanes  multipliers of each row unit: a row of c columns takes at most ceil(c / lanes) cycles (the chunks
  *               with a nonzero coefficient in one of its round's rows)
  * @param k      K = -Q^-1 G', n x mc (z = K v + e)
  * @param g      G, mc x n (s = G (z - e))
  * @param fe     Fe, n x nw (e = Fe w)
  * @param lb     the bound rows Lb = Lw - G Fe, mc x nw (lo = lo0 + Lb w, hi = hi0 + Lb w: the bounds relative to
  *               G e, so that a zero start's first iteration, z = e, has s = 0)
  * @param outLo  the quantised input box the n output words are clamped to (z = (u_0, ..., u_N-1), data words)
  * @param shiftSrc the shifted warm start (design.shift_sources; empty: none): dual word i (upper rows, then lower
  *               rows) starts a warm solve from word shiftSrc(i) of the previous final dual, clipped to ud(i), or
  *               from zero where shiftSrc(i) < 0
  * @param ramState the accelerated form's dual and bounds in block RAM (DgpCore): per unit, memories of y, of the
  *               extrapolated dual's candidate and of the bounds, read and written row by row; pass K's operand from
  *               the differences wy+ - wy- of y and of the candidate, kept flat (two rotating FIFOs of op words per
  *               unit). With the shifted warm start, a row's shift source must be the same unit's (the rows per stage
  *               a multiple of P) and lie in the row's dual box (design.stage_envelope)
  */
case class DgpParams(
    name: String,
    n: Int,
    nu: Int,
    nw: Int,
    mc: Int,
    units: Int,
    lanes: Int,
    accelerated: Boolean,
    fracBits: Int,
    latAdd: Int,
    latMul: Int,
    target: Target,
    coefW: Int,
    xW: Int,
    dataW: Int,
    opW: Int,
    accW: Int,
    sumW: Int,
    betaW: Int,
    streamW: Int,
    imaxDefault: Int,
    warmDefault: Boolean,
    outAllDefault: Boolean,
    k: Seq[Seq[BigInt]],
    g: Seq[Seq[BigInt]],
    fe: Seq[Seq[BigInt]],
    lb: Seq[Seq[BigInt]],
    lo0: Seq[BigInt],
    hi0: Seq[BigInt],
    ud: Seq[BigInt],
    eg: BigInt,
    eV: BigInt,
    beta: Seq[BigInt],
    xlo: Seq[BigInt],
    xhi: Seq[BigInt],
    outLo: Seq[BigInt],
    outHi: Seq[BigInt],
    shiftSrc: Seq[Int] = Nil,
    ramState: Boolean = false) {

  require(n >= 1 && nw >= 1 && mc >= 1, s"sizes must be >= 1: n=$n nw=$nw mc=$mc")
  require(nu >= 1 && n % nu == 0, s"nu must divide n: got nu=$nu, n=$n")
  require(lanes >= 1 && lanes <= math.max(n, math.max(mc, nw)), s"lanes must be in [1, longest row]: got $lanes")
  require(units >= 1 && units <= math.max(n, mc), s"units P must be in [1, max(n, mc)]: got $units")
  require(fracBits >= 1, s"frac_bits must be >= 1, got $fracBits")
  require(latAdd >= 0 && latMul >= 0, s"latencies must be >= 0: got lat_add=$latAdd, lat_mul=$latMul")
  require(dataW >= 2 && dataW <= 62 && xW <= 62, s"data words must be in [2, 62] bits: got $dataW")
  require(streamW % 8 == 0 && streamW >= math.max(math.max(xW, dataW), 19) && streamW <= 64,
    s"stream width must be a multiple of 8 in [max(x, data width, 19), 64] (the status word has 19 bits): got $streamW")
  require(imaxDefault >= 1 && imaxDefault <= 65535, s"iterations must be in [1, 65535], got $imaxDefault")
  require(k.length == n && k.forall(_.length == mc), s"K must be $n x $mc")
  require(g.length == mc && g.forall(_.length == n), s"G must be $mc x $n")
  require(fe.length == n && fe.forall(_.length == nw), s"Fe must be $n x $nw")
  require(lb.length == mc && lb.forall(_.length == nw), s"Lb must be $mc x $nw")
  require(lo0.length == mc && hi0.length == mc && ud.length == 2 * mc, "lo0, hi0 (mc) and ud (2 mc) lengths")
  require(xlo.length == nw && xhi.length == nw, s"xlo/xhi must have $nw entries")
  require(outLo.length == n && outHi.length == n && outLo.zip(outHi).forall { case (l, h) => l <= h },
    s"out_lo/out_hi must have $n entries with out_lo <= out_hi")
  private def fits(v: BigInt, w: Int) = v >= FixedOps.minOf(w) && v <= FixedOps.maxOf(w)
  require((k ++ g ++ fe ++ lb).flatten.forall(fits(_, coefW)), s"a matrix entry does not fit the coefficient width $coefW")
  require((lo0 ++ hi0 ++ ud ++ outLo ++ outHi).forall(fits(_, dataW)), s"a bound does not fit the data width $dataW")
  require(beta.forall(fits(_, betaW)), s"a beta word does not fit $betaW bits")
  require(shiftSrc.isEmpty || (shiftSrc.length == 2 * mc && shiftSrc.forall(i => i >= -1 && i < 2 * mc)),
    s"shift_src must be empty or have ${2 * mc} entries in [-1, ${2 * mc - 1}]")
  require(shiftSrc.isEmpty || accelerated, "shift_src needs the accelerated form")
  require(!ramState || accelerated, "ram_state needs the accelerated form")
  require(!ramState || shiftSrc.isEmpty || shiftSrc.zipWithIndex.forall { case (s, d) =>
    s < 0 || ((s % mc) % units == (d % mc) % units && s / mc == d / mc && ud(d) >= ud(s) &&
      shiftSrc((d + mc) % (2 * mc)) == (if (d < mc) s + mc else s - mc)) },
    "ram_state with shift_src: every source must be a row of the same unit and half, the two halves shifted alike, " +
      "and the source's dual box within the row's")

  /** the shifted warm start */
  val shift: Boolean = shiftSrc.nonEmpty
  /** per dual word: a nonzero final word starts the next warm solve nonzero (it is the shift source of a word whose
    * dual box is not empty), so that the all-zero test of the shifted start looks at these words only */
  val shiftLive: Seq[Boolean] = (0 until 2 * mc).map(i => shiftSrc.zipWithIndex.exists { case (s, d) => s == i && ud(d) > 0 })

  /** ram_state with the shifted warm start: unit u's element k takes its start from the same unit's element
    * shiftElem(u)(k) of the previous final dual (-1: zero) */
  def shiftElem(u: Int, k: Int): Int = {
    val r = k * units + u
    if (r >= mc || shiftSrc(r) < 0) -1 else shiftSrc(r) / units
  }

  /** chunks per row of each pass: F (rows of Fe and Lb, nw columns), K (mc columns), G (n columns) */
  def chunks(cols: Int): Int = (cols + lanes - 1) / lanes
  val cF: Int = chunks(nw)
  val cK: Int = chunks(mc)
  val cG: Int = chunks(n)
  /** rounds of the passes: each unit's rows of pass K (rK) and pass G (rG); the first pass takes the rows of Fe
    * (rK rounds) then those of Lb (rG rounds) */
  val rK: Int = (n + units - 1) / units
  val rG: Int = (mc + units - 1) / units
  /** rows of unit u: pass K, pass G */
  def rowsK(u: Int): Int = if (u < n) (n - u + units - 1) / units else 0
  def rowsG(u: Int): Int = if (u < mc) (mc - u + units - 1) / units else 0
  /** The chunks each round of a pass issues: those in which one of the round's rows (rows r P .. r P + P - 1 of
    * `m`, one per unit) has a nonzero coefficient, ascending; a round with none issues chunk 0 (its rows pass the
    * units all the same). A chunk left out is zero in every unit's row, so the sums are the dense ones, word for
    * word: structure in the matrices (the identity of an input row of G, the triangle of a state row) costs no
    * cycles. */
  def schedule(m: Seq[Seq[BigInt]], rounds: Int): Seq[Seq[Int]] = (0 until rounds).map { r =>
    val cs = (0 until units).flatMap(u => m.lift(r * units + u).getOrElse(Nil).zipWithIndex.collect {
      case (v, c) if v != 0 => c / lanes
    }).distinct.sorted
    if (cs.isEmpty) Seq(0) else cs
  }
  val schedFe: Seq[Seq[Int]] = schedule(fe, rK)
  val schedLb: Seq[Seq[Int]] = schedule(lb, rG)
  val schedK: Seq[Seq[Int]]  = schedule(k, rK)
  val schedG: Seq[Seq[Int]]  = schedule(g, rG)
  /** issue cycles of the passes */
  val issueF: Int = (schedFe ++ schedLb).map(_.length).sum
  val issueK: Int = schedK.map(_.length).sum
  val issueG: Int = schedG.map(_.length).sum
  /** each unit's matrix memory rows (lanes words each): its Fe, Lb, K, G rows, the issued chunks of each */
  val baseF: Int = 0
  val baseK: Int = issueF
  val baseG: Int = baseK + issueK
  val matRows: Int = baseG + issueG
  /** per memory row (issue slot, in issue order): its chunk, and whether it is its round's first and last */
  val slots: Seq[(Int, Boolean, Boolean)] = (schedFe ++ schedLb ++ schedK ++ schedG).flatMap { cs =>
    cs.zipWithIndex.map { case (c, i) => (c, i == 0, i == cs.length - 1) }
  }

  val depth: Int = log2Ceil(lanes)
  /** dot-product tree: l_M + l_A ceil(log2 lanes) */
  val treeLat: Int = latMul + latAdd * depth
  /** from a chunk's issue (matrix address and chunk in the sequencer's registers) to its row's sum in the
    * accumulator register (row result stage): the chunk's copies at the lanes and the address register 1, the
    * lanes' words and their pass select 2 (the address's copies at the memories and the RAM read), the operand's
    * copies at the units and the RAM's output register 1, the tree, the accumulator 1 */
  val rowLat: Int = 4 + treeLat + 1
  /** registered levels that add the units' sums of the stopping and restart tests */
  val unitDepth: Int = log2Ceil(units)
  /** idle cycles after pass K: its last z is written a stage after its result stage (the sum registered before
    * its saturation), and pass G's first operand select reads it in the cycle after */
  val gapK: Int = rowLat
  /** stages of the element stage's products (accelerated): l_M, and where the target sums a product's partial
    * products, at least 2 beyond its DSP pipeline, so that the DSP outputs land in fabric registers before their sum
    * (FixedOps.mulStages) */
  val latMulE: Int = {
    val need = Seq(target.minLatency(dataW, dataW), target.minLatency(betaW, dataW)).max
    if (need >= 4) math.max(latMul, need + 2) else latMul
  }
  /** from a row of pass G's sum to the test's sums that count it (the element stage): s and the row's bounds (1),
    * g (1), g - ud (1), y_new and plain: Sg (1), the threshold's compare (1); accelerated: y rotated (1), dy (1),
    * the products (latMulE), their sums and the extrapolation (1), the accumulators and the extrapolated dual (1) */
  val elementLat: Int = if (accelerated) 8 + latMulE else 5
  /** idle cycles after pass G before the decision: the element stage, the sums over the units (unitDepth
    * registered levels) and the registered test flags (1, counted in the decision's cycle) */
  val gapG: Int = rowLat + elementLat + unitDepth
  /** one iteration: pass K, gap, pass G, gap, the decision cycle */
  val cyclesPerIteration: Int = issueK + gapK + issueG + gapG + 1
  /** A zero start (the starting dual all zero: every cold start) has z = e (v = 0, written to z with e in the first
    * pass) and s = G (z - e) = 0 in its first iteration, so it skips passes K and G: the first pass's bound rows
    * feed the element stage, a stage after their sums (the bounds' registers). Cycles from the first pass's last
    * issue to the decision: pass G's gap and that stage */
  val gapZ: Int = gapG + 1
  /** cycles a zero start saves: an iteration, less gapZ and the decision */
  val zeroStartSaving: Int = cyclesPerIteration - gapZ - 1
  /** the averaged primal's dividend 2 Sz + I */
  val divW: Int = sumW + 2
  /** cycles of the plain form's division of an output word (start to the word valid) */
  val divCycles: Int = if (accelerated) 0 else divW + 2
  /** from the handshake of the last input word to the first output word, besides the iterations: the frame's
    * take (3: the frame buffer's full flag, the take decided a cycle ahead), the first pass's issue (pass K follows
    * at once), and the plain form's first division; accelerated, the answer's flag and its output queue (2) */
  val solveOverhead: Int = 3 + issueF + divCycles + (if (accelerated) 2 else 0)
  /** data-dependent solve: from the handshake of the last input word to the first output word */
  def cyclesToOutput(iters: Int, zeroStart: Boolean): Int =
    solveOverhead + iters * cyclesPerIteration - (if (zeroStart) zeroStartSaving else 0)
  val multipliers: Int = units * (lanes + (if (accelerated) 6 else 0))

  val moduleName: String =
    s"DgpCore_${name}_n${n}_m${2 * mc}_l${lanes}" + (if (units > 1) s"u$units" else "") + s"_b${fracBits}" + (if (accelerated) "a" else "p") + (if (shift) "s" else "") + (if (ramState) "r" else "") +
      (if (target == Target.Generic) "" else s"_${target.name}")

  /** byte-address width of the AXI4-Lite port: the registers only (the data are fixed at generation) */
  val axiAddrW: Int = log2Ceil(shell.SolverRegs.RegionStart) + 2

  /** unit u's matrix memory: its rows of Fe, Lb, K and G, the chunks of each round's schedule (zero rows past the
    * last) */
  def matInit(u: Int): Seq[Seq[BigInt]] = {
    def chunkOf(r: Seq[BigInt], j: Int) = (0 until lanes).map(l => r.lift(j * lanes + l).getOrElse(BigInt(0)))
    def mine(m: Seq[Seq[BigInt]], sched: Seq[Seq[Int]]) =
      sched.zipWithIndex.flatMap { case (cs, r) => cs.map(j => chunkOf(m.lift(r * units + u).getOrElse(Nil), j)) }
    mine(fe, schedFe) ++ mine(lb, schedLb) ++ mine(k, schedK) ++ mine(g, schedG)
  }
  /** unit u's word of a per-row vector at round k (0 past the last row) */
  def ofUnit(v: Seq[BigInt], u: Int, k: Int): BigInt = v.lift(k * units + u).getOrElse(BigInt(0))
}

object DgpParams {
  import gen.ConfigJson.{ints, mat}

  def fromJson(text: String): DgpParams = {
    val j = ujson.read(text)
    val w = j("widths")
    DgpParams(
      name = j("name").str, n = j("n").num.toInt, nu = j("nu").num.toInt, nw = j("nw").num.toInt,
      mc = j("mc").num.toInt, units = j.obj.get("P").map(_.num.toInt).getOrElse(1), lanes = j("lanes").num.toInt, accelerated = j("accelerated").bool,
      fracBits = j("frac_bits").num.toInt, latAdd = j("lat_add").num.toInt, latMul = j("lat_mul").num.toInt,
      target = Target(j.obj.get("target").map(_.str).getOrElse("generic")),
      coefW = w("coef").num.toInt, xW = w("x").num.toInt, dataW = w("data").num.toInt, opW = w("op").num.toInt,
      accW = w("acc").num.toInt, sumW = w("sum").num.toInt, betaW = w("beta").num.toInt,
      streamW = w("stream").num.toInt, imaxDefault = j("iterations").num.toInt, warmDefault = j("warm_start").bool,
      outAllDefault = j("output_all").bool, k = mat(j("K")), g = mat(j("G")), fe = mat(j("Fe")), lb = mat(j("Lb")),
      lo0 = ints(j("lo0")), hi0 = ints(j("hi0")), ud = ints(j("ud")), eg = BigInt(j("eg").num.toLong),
      eV = BigInt(j("eV").num.toLong), beta = ints(j("beta")), xlo = ints(j("xlo")), xhi = ints(j("xhi")),
      outLo = ints(j("out_lo")), outHi = ints(j("out_hi")),
      shiftSrc = j.obj.get("shift_src").map(a => ints(a).map(_.toInt)).getOrElse(Nil),
      ramState = j.obj.get("ram_state").exists(_.bool))
  }
}
