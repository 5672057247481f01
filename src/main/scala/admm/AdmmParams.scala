package admm

import chisel3.util.log2Ceil
import dsp.Target
import fixed.{FixedOps, Rounding}

/** Everything the ADMM generator needs (Algorithm 2 of 002, mpc_cores/admm/design.py writes it): sizes, word widths,
  * the penalty shifts rho_j = 2^k_j and the quantised data. Integers are words with `fracBits` fraction bits.
  *
  * Components are numbered as in the sparse form (8) of 002: z = (du_0..du_{N-1}, x~_0, delta_0, ..., x~_N,
  * delta_N). `kind` says how each is projected: 0 free, 1 box [lo, hi], 2 the state and 3 the slack of a soft pair
  * (softX(i), softD(i)) with centre softC(i) and radius softR(i).
  *
  * Rows are placed on P row units, K per unit (`slots`): a soft pair sits on one unit in consecutive slots, state
  * first, so that its projection sees both (the pair's results leave with the slack row).
  */
case class AdmmParams(
    name: String,
    n: Int,
    nu: Int,
    N: Int,
    nw: Int,
    P: Int,
    Kp: Int,
    /** the splitting method (004) on this datapath: "admm", "ama" (v = -nu) or "vucondat" (v = sigma (y + z) - nu) */
    method: String,
    fracBits: Int,
    latAdd: Int,
    latMul: Int,
    rounding: Rounding,
    target: Target,
    widths: Map[String, Int],
    imaxDefault: Int,
    warmDefault: Boolean,
    outAllDefault: Boolean,
    shift: Seq[Int],
    m11: Seq[Seq[BigInt]],
    g: Seq[Seq[BigInt]],
    kind: Seq[Int],
    lo: Seq[BigInt],
    hi: Seq[BigInt],
    softX: Seq[Int],
    softD: Seq[Int],
    softC: Seq[BigInt],
    softR: Seq[BigInt],
    wlo: Seq[BigInt],
    whi: Seq[BigInt],
    /** fast AMA with the gradient restart (method ama, one problem): AdmmCore's momentum lanes */
    accelerated: Boolean = false,
    /** accelerated: the momentum words (a_i - 1) / a_(i+1), i = iterations since the (re)start (the last repeats) */
    momentum: Seq[BigInt] = Seq(),
    /** chunks per row (a power of two): the row unit has lanes = ceil(m / chunks) multipliers and takes a row's dot
      * product in `chunks` cycles, accumulating the chunks' tree sums (one row unit, one problem) */
    chunks: Int = 1) {
  import AdmmParams._
  require(!accelerated || Kp == 1, s"accelerated needs problems = 1")

  require(n >= 1, s"n_A must be >= 1, got $n")
  require(nu >= 1 && N >= 1 && N * nu < n, s"need nu >= 1, N >= 1 and N*nu < n_A: got nu=$nu, N=$N, n_A=$n")
  require((n - N * nu) % (N + 1) == 0, s"the state part of z (n_A - N*nu = ${n - N * nu}) must split into N+1 = ${N + 1} stages")
  require(nw >= 1, s"nw must be >= 1, got $nw")
  require(P >= 1 && P <= n, s"P must be in [1, n_A] (one row unit per variable at most): got P=$P, n_A=$n")
  require(Kp >= 1 && Kp <= 16, s"problems must be in [1, 16]: got $Kp")
  require(latAdd >= 0 && latMul >= 0, s"latencies must be >= 0: got lat_add=$latAdd, lat_mul=$latMul")
  require(fracBits >= 1, s"frac_bits must be >= 1, got $fracBits")
  for (k <- Seq("v", "y", "q", "z", "d", "nu", "sum", "coef", "w", "stream"))
    require(widths.contains(k), s"widths.$k missing")
  val Seq(vW, yW, qW, zW, dW, nuW, sumW, coefW, wW, streamW) =
    Seq("v", "y", "q", "z", "d", "nu", "sum", "coef", "w", "stream").map(widths)
  for ((nm, w) <- Seq("coef" -> coefW, "w" -> wW, "z" -> zW))
    require(w >= 2 && w <= 32, s"$nm width must be in [2, 32] (one AXI4-Lite word): got $w")
  for ((nm, w) <- Seq("v" -> vW, "y" -> yW, "q" -> qW, "d" -> dW, "nu" -> nuW, "sum" -> sumW))
    require(w >= 2 && w <= 64, s"$nm width must be in [2, 64]: got $w")
  require(streamW % 8 == 0 && streamW >= math.max(wW, zW) && streamW <= 64,
    s"stream width must be a multiple of 8 in [max(w, z width), 64]: got $streamW, w=$wW, z=$zW")
  require(imaxDefault >= 1 && imaxDefault <= 65535, s"iterations must be in [1, 65535], got $imaxDefault")
  require(shift.length == n && shift.forall(k => k >= -fracBits && k <= 16),
    s"penalty shifts k_j (rho_j = 2^k_j) must number n_A=$n and lie in [-frac_bits, 16] = [${-fracBits}, 16]")
  require(m11.length == n && m11.forall(_.length == n), s"M11 must be $n x $n")
  require(g.length == n && g.forall(_.length == nw + 1), s"G must be $n x ${nw + 1}")
  require(kind.length == n && kind.forall(k => k >= Free && k <= SoftD), s"kind must hold $n entries in 0..3")
  require(lo.length == n && hi.length == n, s"lo/hi must have $n entries")
  require(wlo.length == nw && whi.length == nw, s"wlo/whi must have $nw entries")
  require(Seq(softX, softD, softC, softR).forall(_.length == softX.length), "soft_x, soft_d, soft_c, soft_r must have equal lengths")
  require(softX.forall(kind(_) == SoftX) && softD.forall(kind(_) == SoftD) && kind.count(_ == SoftX) == softX.length &&
    kind.count(_ == SoftD) == softD.length, "soft pairs must list every soft state (kind 2) and slack (kind 3) once")
  require(softX.zip(softD).forall { case (x, d) => shift(x) == shift(d) },
    "both members of a soft pair must share their penalty shift (the projection onto the cone stays Euclidean)")
  require((0 until n).forall(j => kind(j) != Box || lo(j) <= hi(j)), "box bounds: lo <= hi required for every box component")
  require(wlo.zip(whi).forall { case (l, h) => l <= h }, "parameter box: wlo <= whi required for every word")
  require(softR.forall(_ > 0), "soft-constraint radii must be > 0")

  private def fits(v: BigInt, w: Int) = v >= FixedOps.minOf(w) && v <= FixedOps.maxOf(w)
  require((m11.flatten ++ g.flatten).forall(fits(_, coefW)), s"a matrix entry does not fit the coefficient width $coefW")
  require((0 until n).filter(kind(_) == Box).forall(j => fits(lo(j), zW) && fits(hi(j), zW)), s"a box bound does not fit the z width $zW")
  require((softC ++ softR).forall(fits(_, zW)), s"a soft centre or radius does not fit the z width $zW")
  require((wlo ++ whi).forall(fits(_, wW)), s"a parameter bound does not fit the w width $wW")
  require(fits(BigInt(1) << fracBits, wW), s"the constant word 2^frac_bits must fit the w width $wW")

  /** Columns of a row: the G~ (w, 1) pass shares the multipliers, so max(n_A, nw + 1). */
  val m: Int     = math.max(n, nw + 1)
  require(chunks >= 1 && (chunks & (chunks - 1)) == 0 && chunks <= m,
    s"chunks must be a power of two in [1, max(n_A, nw + 1) = $m]: got $chunks")
  require(chunks == 1 || (P == 1 && Kp == 1), s"chunks > 1 needs one row unit and one problem: got P=$P, problems=$Kp")
  /** multipliers per row unit: chunk c of a row holds its columns c lanes .. (c + 1) lanes - 1 */
  val lanes: Int = (m + chunks - 1) / chunks
  /** bits of the chunk index, the low bits of a slot */
  val chunkBits: Int = log2Ceil(chunks)
  val depth: Int = log2Ceil(lanes)
  val opW: Int   = math.max(vW, wW)
  val hasSoft: Boolean = softX.nonEmpty

  /** Distinct penalty shifts, and each component's index among them (a row unit selects its row's shift). */
  val shifts: Seq[Int]    = shift.distinct.sorted
  val shiftCode: Seq[Int] = shift.map(shifts.indexOf(_))

  /** Row placement: rows(u)(k) = component in slot k of unit u (None: an idle slot). */
  val rows: Seq[Seq[Option[Int]]] = place(n, P, softX.zip(softD))
  val K: Int = rows.head.length
  /** Slots per unit and pass: a row's chunks take consecutive slots (slot = k chunks + c). */
  val slots: Int = K * chunks
  val unitOf: Map[Int, Int] = (for (u <- 0 until P; (Some(j), _) <- rows(u).zipWithIndex) yield j -> u).toMap
  val slotOf: Map[Int, Int] = (for (u <- 0 until P; (Some(j), k) <- rows(u).zipWithIndex) yield j -> k).toMap
  /** soft state placed in the slot before each slack */
  val partnerOf: Map[Int, Int] = softD.zip(softX).toMap

  // ---- pipeline stages from the row fetch (see AdmmCore) and the cycle contract
  val projLat: Int  = if (hasSoft) 2 * latAdd else latAdd
  /** chunks > 1: the chunk sums accumulate in a register (one cycle) and the row's total saturates (one more) */
  val accLat: Int   = if (chunks > 1) 2 else 0
  val stageTree: Int = 1 + latMul + latAdd * depth
  val stageSum: Int = stageTree + accLat
  val stageQ: Int   = stageSum + latAdd
  val stageP: Int   = stageQ + latAdd
  val stageZ: Int   = stageP + projLat
  val stageN: Int   = stageZ + latAdd
  val stageW: Int   = stageN + latAdd
  /** accelerated: the momentum lanes after the write stage (a register, l_M of the multipliers) */
  val momLat: Int = if (accelerated) 1 + latMul else 0
  /** Cycles per iteration: the last row's write (accelerated: its momentum lane), then the operand update
    * v = rho z - nu in the next cycle. */
  val cyclesPerIteration: Int = slots + stageW + momLat
  require(!accelerated || momentum.nonEmpty, "accelerated needs the momentum words")
  require(momentum.forall(w => w >= 0 && w <= (BigInt(1) << fracBits)), "momentum words must be in [0, 2^frac_bits]")
  val momW: Int = fracBits + 2
  /** accelerated: the states the method extrapolates (mpc_cores.admm.model.ACC_STATES), their words, the width of
    * their new value in the row pipeline (y: the y register's, which holds z after a cold start) */
  val accStates: Seq[String] = method match { case "ama" => Seq("nu"); case "admm" => Seq("z", "nu"); case _ => Seq("y", "z", "nu") }
  def accW0(k: String): Int = k match { case "y" => yW; case "z" => zW; case _ => nuW }
  def accCurW(k: String): Int = if (k == "y") math.max(yW, zW) else accW0(k)
  /** the restart test's term per component and the sum over all n components and lanes */
  val termW: Int =
    if (method == "ama") math.max(2, dW + nuW + 1 - fracBits)
    else 2 * (accStates.map(accCurW).max + 1) - fracBits + shift.map(math.abs).max + 3
  val accW: Int  = termW + log2Ceil(n + 1) + 1
  /** L_A of eq. (24) of 002. */
  val cyclesEq24: Int =
    if (chunks == 1) (n + P - 1) / P + latAdd * log2Ceil(n) + latMul + 6 * latAdd + 2
    else n * chunks + latAdd * depth + latMul + 6 * latAdd + 2 + accLat
  /** From the handshake of the last input word to the first output word: 4 + (Imax + 1) L (the start two cycles
    * after the frame's last word, shell.PassSequencer; the first pass, G~ (w, 1) and the start iterate, takes one
    * iteration's time; the answer's output queue, shell.AnswerQueue). */
  /** Cycles between two passes of one problem: L alone, a round of Kp turns of K cycles when interleaving
    * (shell.TurnSequencer; then the overhead is the least latency's: taken, loaded, the last pass's drain, the
    * answer queue and the output register, and a frame waits up to periodCycles - 1 more for its turn). */
  val periodCycles: Int = if (Kp == 1) cyclesPerIteration else math.max(cyclesPerIteration, Kp * K)
  val solveOverhead: Int = if (Kp == 1) 4 + cyclesPerIteration else 3 + cyclesPerIteration + 2
  def cyclesPerSolve(imax: Int): Int = solveOverhead + imax * periodCycles
  /** P m for the row products; accelerated: two per extrapolated state and momentum lane (two lanes with soft pairs) */
  val multipliers: Int = P * lanes + (if (accelerated) 2 * accStates.length * P * (if (hasSoft) 2 else 1) else 0)

  require(Seq("admm", "ama", "vucondat").contains(method), s"method must be admm, ama or vucondat: got $method")
  val moduleName: String =
    s"AdmmCore_${name}_n${n}_p${P}_b${fracBits}" + (if (Kp > 1) s"_k$Kp" else "") + (if (chunks > 1) s"_c$chunks" else "") +
      (if (method == "admm") "" else s"_$method") + (if (target == Target.Generic) "" else s"_${target.name}")

  // ---- register map: data regions addressed by component index
  val cBits: Int = log2Ceil(m)
  val (regionSizes: Seq[(String, Int)], regionBase: Map[String, Int], addrWords: Int) =
    shell.SolverRegs.layout(Seq("WBOX" -> 2 * nw, "BND" -> 2 * n, "MAT_M" -> (n << cBits), "MAT_G" -> (n << cBits)))
  val axiAddrW: Int = log2Ceil(addrWords) + 2

  private def pad(r: Seq[BigInt]) = r ++ Seq.fill(lanes * chunks - r.length)(BigInt(0))
  /** Words per block of a unit's matrix memory (the second block starts there): 2^ceil(log2 slots), at least 2. */
  lazy val K2: Int = 1 << math.max(1, log2Ceil(slots))
  def matInit(u: Int): Seq[Seq[BigInt]] = {
    val zero = Seq.fill(lanes * chunks)(BigInt(0))
    def block(of: Int => Seq[BigInt]) =
      rows(u).flatMap(r => r.map(j => pad(of(j))).getOrElse(zero).grouped(lanes).toSeq)
    // slots 0..slots-1: the M11 rows' chunks; K2..K2+slots-1: the G~ rows'
    block(m11) ++ Seq.fill(K2 - slots)(Seq.fill(lanes)(BigInt(0))) ++ block(g)
  }
  /** Per row unit: (lo, hi) of a box row, (c, r) of a slack row, the z word range for a free row. */
  def boundInit(u: Int): Seq[Seq[BigInt]] = rows(u).map {
    case Some(j) if kind(j) == Box   => Seq(lo(j), hi(j))
    case Some(j) if kind(j) == SoftD => val i = softD.indexOf(j); Seq(softC(i), softR(i))
    case _                           => Seq(FixedOps.minOf(zW), FixedOps.maxOf(zW))
  }
  def kindAt(u: Int, k: Int): Int = rows(u)(k).map(kind).getOrElse(Free)
  def codeAt(u: Int, k: Int): Int = rows(u)(k).map(shiftCode).getOrElse(0)

  /** Warm start: z and nu shifted by one stage, the last stage repeated (Fig. 2b of 002). */
  def warmSource(j: Int): Int = {
    val du = N * nu
    val stage = (n - du) / (N + 1)
    if (j < du) (if (j < du - nu) j + nu else j) else (if (j < n - stage) j + stage else j)
  }
}

object AdmmParams {
  import gen.ConfigJson.{ints, mat, small}

  /** accelerated ADMM and Vu-Condat: the residual restart's eta = 1 - 2^-EtaShift (mpc_cores.admm.model.ETA_SHIFT) */
  val EtaShift = 10
  val Free = 0
  val Box = 1
  val SoftX = 2
  val SoftD = 3

  /** Place the rows on P units of K slots, K the smallest >= ceil(n/P) that works: units are filled in turn with
    * soft pairs (two consecutive slots) while two slots remain, then with single rows; a slot left at a unit's
    * end stays idle only when no single row is left for it. */
  def place(n: Int, P: Int, pairs: Seq[(Int, Int)]): Seq[Seq[Option[Int]]] = {
    val inPair  = pairs.flatMap { case (x, d) => Seq(x, d) }.toSet
    val singles = (0 until n).filterNot(inPair)
    def attempt(K: Int): Option[Seq[Seq[Option[Int]]]] = {
      var ps = pairs.toList
      var ss = singles.toList
      val units = (0 until P).map { _ =>
        val slots = scala.collection.mutable.ArrayBuffer[Option[Int]]()
        while (ps.nonEmpty && K - slots.length >= 2) { slots += Some(ps.head._1); slots += Some(ps.head._2); ps = ps.tail }
        while (ss.nonEmpty && slots.length < K) { slots += Some(ss.head); ss = ss.tail }
        slots ++= Seq.fill(K - slots.length)(None)
        slots.toSeq
      }
      if (ps.isEmpty && ss.isEmpty) Some(units) else None
    }
    Iterator.from((n + P - 1) / P).map(attempt).collectFirst { case Some(u) => u }.get
  }


  /** Read the config.json written by the Python front end (mpc_cores/admm/design.py). */
  def fromJson(text: String): AdmmParams = {
    val j = ujson.read(text)
    require(j("core").str == "admm", s"not an ADMM configuration: core=${j("core").str}")
    AdmmParams(
      name = j("name").str,
      n = j("n").num.toInt,
      nu = j("nu").num.toInt,
      N = j("N").num.toInt,
      nw = j("nw").num.toInt,
      P = j("P").num.toInt,
      Kp = j.obj.get("problems").map(_.num.toInt).getOrElse(1),
      method = j.obj.get("method").map(_.str).getOrElse("admm"),
      accelerated = j.obj.get("accelerated").exists(_.bool),
      momentum = j.obj.get("momentum").map(ints).getOrElse(Seq()),
      chunks = j.obj.get("chunks").map(_.num.toInt).getOrElse(1),
      fracBits = j("frac_bits").num.toInt,
      latAdd = j("lat_add").num.toInt,
      latMul = j("lat_mul").num.toInt,
      rounding = Rounding(j("rounding").str),
      target = Target(j.obj.get("target").map(_.str).getOrElse("generic")),
      widths = j("widths").obj.map { case (k, v) => k -> v.num.toInt }.toMap,
      imaxDefault = j("iterations").num.toInt,
      warmDefault = j("warm_start").bool,
      outAllDefault = j.obj.get("output_all").exists(_.bool),
      shift = small(j("shift")),
      m11 = mat(j("M11")),
      g = mat(j("G")),
      kind = small(j("kind")),
      lo = ints(j("lo")),
      hi = ints(j("hi")),
      softX = small(j("soft_x")),
      softD = small(j("soft_d")),
      softC = ints(j("soft_c")),
      softR = ints(j("soft_r")),
      wlo = ints(j("wlo")),
      whi = ints(j("whi"))
    )
  }
}
