package minres

import chisel3.util.log2Ceil

/** Everything the MINRES generator needs (mpc_cores/minres/design.py writes it): the MPC sizes (n states, m inputs,
  * horizon T, 001 notation), the float format (expW exponent and manW mantissa bits, binary32 = (8, 23); its words
  * travel in the low bits of the 32-bit stream words), the latencies of the float operators, P, and the constant
  * columns of the half-CDS band (`rom`, raw words of the format: (2n+m) rows x (M-1) columns, see
  * mpc_cores/minres/kkt.py).
  *
  * `tables` (the multiplexed interior-point core): several coefficient tables of the one band pattern (keys x K
  * each, the first is `coefs`); a problem multiplies by table (id mod 2^tableIdBits) mod tables.length, from its
  * id word (the interior-point core's channel); empty: `coefs` alone.
  *
  * The schedule (MinresCore) runs P problems in slots of S cycles; a problem's iteration is the matvec feed,
  * the matvec, the Lanczos update (pass B), the scalar part and the vector updates (pass C), at fixed offsets
  * from its slot start. P * S must cover the chain from a slot's feed to the first v_{j+1} word being written:
  * `need` cycles. P = 0 in the configuration means "the smallest P with P N >= need", eq. (15) of 001 in this
  * core's form: P = ceil((2N + M + k1 ceil(log2(K)) + k2) / N) with k1 = lat_add, k2 below.
  *
  * `target` (dsp.Target): ecp5 builds the vector memories from DP16KD primitives with their output register
  * (mem.Ecp5SdpRam); the words and cycles are those of every target.
  */
case class MinresParams(
    name: String,
    n: Int,
    m: Int,
    T: Int,
    pRequested: Int,
    latAdd: Int,
    latMul: Int,
    latDiv: Int,
    latSqrt: Int,
    imaxDefault: Int,
    flushCycles: Int,
    offsets: Seq[Seq[Option[Int]]],
    coefs: Seq[Seq[BigInt]],
    expW: Int = 8,
    manW: Int = 23,
    warm: Boolean = false,
    target: dsp.Target = dsp.Target.Generic,
    tables: Seq[Seq[Seq[BigInt]]] = Seq()) {
  /** the float format of every operator, memory and constant (FloatFormat refuses widths outside its rules) */
  val fmt: float.FloatFormat = float.FloatFormat(expW, manW)
  require(fmt.width <= 32, s"the float format must fit the 32-bit stream word (1 + expW + manW <= 32): got " +
    s"expW=$expW, manW=$manW (${fmt.width} bits)")
  require(n >= 1 && m >= 1 && T >= 1, s"need n >= 1, m >= 1, T >= 1: got n=$n, m=$m, T=$T")
  require(latAdd >= 1, s"lat_add must be >= 1 (the streaming accumulator feeds the adder's output back): got $latAdd")
  require(latMul >= 0 && latDiv >= 0 && latSqrt >= 0, s"latencies must be >= 0: got lat_mul=$latMul, lat_div=$latDiv, lat_sqrt=$latSqrt")
  float.FMul.checkLatency(fmt, target, latMul, "lat_mul")
  require(imaxDefault >= 1 && imaxDefault <= 65535, s"iterations must be in [1, 65535]: got $imaxDefault")
  require(flushCycles >= 1 && flushCycles <= 65535, s"flush_cycles must be in [1, 65535]: got $flushCycles")
  require(pRequested >= 0 && pRequested <= 64, s"P must be in [1, 64] (0: from eq. (15)): got P=$pRequested")

  /** Order and half-bandwidth of the KKT matrix, eq. (14) of 001. */
  val N: Int      = T * (2 * n + m) + 2 * n
  val M: Int      = 2 * n + m
  val period: Int = 2 * n + m
  /** words of the variable part: the diagonal of the primal rows */
  val nPrimal: Int = T * (n + m) + n
  /** the window of the band: offsets -(M-1)..M-1 around the row */
  val taps: Int    = 2 * M - 1
  /** row keys (position in the period, then the rows of the last stage) and slots per row */
  val keys: Int    = period + 2 * n
  val K: Int       = offsets.headOption.map(_.length).getOrElse(0)
  val depth: Int   = log2Ceil(K)
  require(K >= 1 && offsets.length == keys && offsets.forall(_.length == K) && coefs.length == keys &&
    coefs.forall(_.length == K), s"band_offsets and band_coefs must be $keys keys x K slots (K >= 1): got " +
    s"${offsets.length} x ${offsets.map(_.length).distinct.mkString("/")} and ${coefs.length} x " +
    s"${coefs.map(_.length).distinct.mkString("/")}")
  require(offsets.flatten.flatten.forall(o => o > -M && o < M), s"band offsets must be in (-$M, $M)")
  require(offsets.forall(r => r.flatten.distinct.length == r.flatten.length), "a key takes each offset once")
  require(coefs.flatten.forall(w => w >= 0 && w < (BigInt(1) << fmt.width)),
    s"band coefficients must be raw words of the format (0 .. 2^${fmt.width}-1)")
  require(tables.isEmpty || tables.head == coefs && tables.forall(t => t.length == keys && t.forall(_.length == K) &&
    t.flatten.forall(w => w >= 0 && w < (BigInt(1) << fmt.width))),
    s"band_tables must be tables of $keys keys x $K slots of raw words, the first equal to band_coefs")
  /** the coefficient tables, one or more */
  val coefTables: Seq[Seq[Seq[BigInt]]] = if (tables.isEmpty) Seq(coefs) else tables
  /** the id bits that choose a problem's table (the interior-point core's channels are below 2P <= 128) */
  val tableIdBits: Int = MinresParams.TableIdBits
  /** per slot, the distinct offsets it takes over all keys (its window multiplexer) */
  val candidates: Seq[Seq[Int]] = (0 until K).map(s => offsets.flatMap(_(s)).distinct.sorted)
  /** partial sums of the streaming accumulators */
  val accParts: Int = latAdd
  /** the streaming accumulators reduce their partial sums on one adder (FStreamAcc.shareTree) */
  val shareAcc: Boolean = FStreamAcc.shares(N, latAdd)
  require(N > accParts, s"N = $N must exceed lat_add = $latAdd (the accumulator's partial sums)")

  // ---- latencies of the pipelines (MinresCore checks its own against these)
  /** registers carrying each matvec product to the adder tree (linalg.FDotProduct.move) */
  val dotMove: Int = 1
  /** matvec: the registered slot operands, the products, their move to the tree, then the adder tree */
  val latMatvec: Int = 1 + dotMove + latMul + latAdd * depth
  /** from the last term entering an accumulator to its result readable in the per-problem register */
  val accTail: Int = FStreamAcc.latency(latAdd, shareAcc) + 1
  /** an operation of the passes (TimedOps): its operand register and its operator */
  val opMul: Int  = TimedOps.OperandReg + latMul
  val opAdd: Int  = TimedOps.OperandReg + latAdd
  val opDiv: Int  = TimedOps.OperandReg + latDiv
  val opSqrt: Int = TimedOps.OperandReg + latSqrt
  /** pass B: u = (y - delta v_j) - gamma v_{j-1} */
  val latB: Int = opMul + 2 * opAdd
  /** the scalar part (gamma_{j+1}, the Givens rotation, its coefficients) in program order: (name, kind, operands);
    * sources nrm = ||u||^2, delta, c, cp (c_{j-1}), s, sp (s_{j-1}), gamma, eta; mpc_cores/minres/schedule.py
    * holds the same list */
  val scalarOps: Seq[(String, String, Seq[String])] = Seq(
    ("g1", "sqrt", Seq("nrm")), ("m1", "mul", Seq("c", "delta")), ("m2", "mul", Seq("cp", "s")),
    ("m3", "mul", Seq("m2", "gamma")), ("a0", "sub", Seq("m1", "m3")), ("m4", "mul", Seq("a0", "a0")),
    ("s4", "add", Seq("m4", "nrm")), ("a1", "sqrt", Seq("s4")), ("m5", "mul", Seq("s", "delta")),
    ("m6", "mul", Seq("cp", "c")), ("m7", "mul", Seq("m6", "gamma")), ("a2", "add", Seq("m5", "m7")),
    ("a3", "mul", Seq("sp", "gamma")), ("c1", "div", Seq("a0", "a1")), ("s1", "div", Seq("g1", "a1")),
    ("ceta", "mul", Seq("c1", "eta")), ("seta", "mul", Seq("s1", "eta")))
  val scalarSchedule: StaticSchedule = StaticSchedule(scalarOps,
    Map("mul" -> latMul, "add" -> latAdd, "div" -> latDiv, "sqrt" -> latSqrt),
    Set("nrm", "delta", "c", "cp", "s", "sp", "gamma", "eta"))
  /** the scalar part on one operator per operation: its critical path */
  val latScalarParallel: Int = 4 * opMul + 2 * opAdd + opSqrt + opDiv
  /** pass C: v_{j+1} (a divide), w_{j+1} and x */
  val latCv: Int = opDiv
  val latCw: Int = opMul + 2 * opAdd + opDiv
  val latCx: Int = 2 * opMul + 3 * opAdd + opDiv

  /** the interior-point form (`warm`): the feed multiplies v_j by d (z0 in the init pass), each row's product
    * is scaled by d_i before it is stored */
  val latFeed: Int = if (warm) opMul else 0

  // ---- schedule, offsets from a slot's first feed cycle
  /** the row of the feed's first word: its read (VecRam.ReadLatency) and the window's M - 1 shifts */
  val tRow: Int   = M - 1 + VecRam.ReadLatency + latFeed
  val tDelta: Int = tRow + N - 1 + latMatvec + opMul + accTail
  val tB: Int     = tDelta
  val tNrm: Int   = tB + N - 1 + latB + opMul + accTail
  val tS: Int     = tNrm
  /** need, P and S for a scalar part of `ls` cycles: the first v_{j+1} word must be written before the slot's
    * next feed reads it */
  private def plan(ls: Int): (Int, Int, Int) = {
    val need = tS + ls + 1 + latCv + 1
    val pp   = if (pRequested == 0) (need + N - 1) / N else pRequested
    (need, pp, math.max(N, (need + pp - 1) / pp))
  }
  /** the scalar part shares one operator per kind when a slot lasts longer than its schedule (one trigger per
    * slot) */
  val sharedScalar: Boolean = plan(scalarSchedule.latency)._3 > scalarSchedule.latency
  val latScalar: Int = if (sharedScalar) scalarSchedule.latency else latScalarParallel
  val tC: Int     = tS + latScalar + 1
  val need: Int   = tC + latCv + 1
  val k1: Int     = latAdd
  val k2: Int     = need - 2 * N - M - k1 * depth
  val pAuto: Int  = (need + N - 1) / N
  val P: Int      = if (pRequested == 0) pAuto else pRequested
  /** slot length: N when P is at least pAuto, else stretched so that P S >= need */
  val S: Int = math.max(N, (need + P - 1) / P)
  require(!sharedScalar || S > latScalar, "the shared scalar part must finish within a slot")
  val cyclesPerIteration: Int = P * S
  // MinresCore's feed flag: the compare value (set on the batch's fourth cycle; later only for a P S beyond 2^17)
  // lies beyond it
  require(cyclesPerIteration >= 6, s"an iteration must take at least 6 cycles: got P S = $cyclesPerIteration")
  /** cycles of a batch of P problems: the init pass and Imax iterations, up to the last x write */
  def batchCycles(imax: Int): Int = (imax + 1) * P * S - S + tC + N + latCx + MinresParams.StartReg

  val multipliers: Int = K + 1 + 3 + (if (sharedScalar) 1 else 10) + 3 + (if (warm) 2 else 0) // matvec, delta, B, scalar, C, scaling
  /** "binary32", "binary16" or e<E>m<M> (the names of mpc_cores/minres/design.py) */
  val formatName: String = (expW, manW) match {
    case (8, 23) => "binary32"
    case (5, 10) => "binary16"
    case _       => s"e${expW}m$manW"
  }
  val moduleName: String =
    s"MinresCore_${name}_n${n}_m${m}_t${T}_p$P" + (if (formatName == "binary32") "" else s"_$formatName") +
      (if (warm) "_warm" else "") + (if (target == dsp.Target.Generic) "" else s"_${target.name}")

  // ---- storage (words): variable column double-buffered for P problems, constant columns once
  val storageVariable: Int = 2 * P * nPrimal
  /** vectors of the warm form beside the matrix: d and z0, double-buffered */
  val storageWarm: Int = if (warm) 4 * P * N else 0
  val storageConstant: Int = offsets.flatten.count(o => o.exists(_ != 0))
  val storageWords: Int    = storageVariable + storageConstant
  val storageDense: Int    = 2 * P * N * M
  val storageBound: Int    = 2 * P * (1 + T * (m + n) + n) * n + (1 + m + n) * (m + n)
  require(storageWords <= storageBound, s"structured storage $storageWords exceeds the bound of 001 $storageBound")

  /** input frame: id, variable column, (warm: d), b, (warm: z0); output frame: id, x, (warm: ||r_0||) */
  val frameWords: Int = 1 + nPrimal + (if (warm) 3 * N else N)
  val outWords: Int   = 1 + N + (if (warm) 1 else 0)
  val axiAddrW: Int   = log2Ceil(shell.SolverRegs.RegionStart) + 2
}

object MinresParams {
  val TableIdBits = 7
  /** cycles from a batch's start decision to its time 0: the decision is registered before the passes' counters */
  val StartReg = 1
  def fromJson(text: String): MinresParams = {
    val j = ujson.read(text)
    require(j("core").str == "minres", s"not a MINRES configuration: core=${j("core").str}")
    MinresParams(
      name = j("name").str,
      n = j("n").num.toInt,
      m = j("m").num.toInt,
      T = j("T").num.toInt,
      pRequested = j("P").num.toInt,
      latAdd = j("lat_add").num.toInt,
      latMul = j("lat_mul").num.toInt,
      latDiv = j("lat_div").num.toInt,
      latSqrt = j("lat_sqrt").num.toInt,
      imaxDefault = j("iterations").num.toInt,
      flushCycles = j("flush_cycles").num.toInt,
      offsets = j("band_offsets").arr.toSeq.map(_.arr.toSeq.map(v => if (v.isNull) None else Some(v.num.toInt))),
      coefs = j("band_coefs").arr.toSeq.map(_.arr.toSeq.map(v => BigInt(v.num.toLong))),
      expW = j.obj.get("exp_width").map(_.num.toInt).getOrElse(8),
      manW = j.obj.get("man_width").map(_.num.toInt).getOrElse(23),
      warm = j.obj.get("warm").exists(_.bool),
      target = dsp.Target(j.obj.get("target").map(_.str).getOrElse("generic")),
      tables = j.obj.get("band_tables").map(_.arr.toSeq.map(_.arr.toSeq.map(_.arr.toSeq.map(v => BigInt(v.num.toLong)))))
        .getOrElse(Seq())
    )
  }
}
