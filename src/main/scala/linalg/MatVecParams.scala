package linalg

import chisel3.util.log2Ceil
import dsp.Target
import fixed.{FixedOps, Rounding}

/** A fixed-point matrix-vector block s = M v (MatVecCore): the linear-system step of a splitting method in hardware
  * while a CPU runs the rest (the heterogeneous split of 004, section 5). mpc_cores/admm/split.py writes it from an
  * ADMM-family design: M = M11 and the word formats of that core, so s is the core's own adder-tree sum.
  *
  * @param n   rows and columns of M
  * @param P   row units: unit u computes rows u, u + P, u + 2P, ..., one per cycle
  * @param mat M's words, n x n, fracBits fraction bits
  */
case class MatVecParams(
    name: String,
    n: Int,
    P: Int,
    fracBits: Int,
    latMul: Int,
    latAdd: Int,
    rounding: Rounding,
    target: Target,
    coefW: Int,
    opW: Int,
    sumW: Int,
    mat: Seq[Seq[BigInt]]) {
  require(n >= 1, s"n must be >= 1, got $n")
  require(P >= 1 && P <= n, s"P must be in 1..n = $n, got $P")
  require(mat.length == n && mat.forall(_.length == n), s"the matrix must be $n x $n")
  require(mat.flatten.forall(v => v >= FixedOps.minOf(coefW) && v <= FixedOps.maxOf(coefW)),
    s"a matrix entry does not fit the coefficient width $coefW")
  require(opW >= 2 && opW <= 64 && sumW >= 2 && sumW <= 64, s"operand and sum widths must be in 2..64: $opW, $sumW")

  def moduleName: String = name
  /** rows per unit */
  val K: Int = (n + P - 1) / P
  val dp: DotProductParams = DotProductParams(n, coefW, opW, sumW, fracBits, latMul, latAdd, rounding, target)
  val inW: Int  = (opW + 7) / 8 * 8
  val outW: Int = (sumW + 7) / 8 * 8
  val kW: Int   = math.max(1, log2Ceil(K))
  /** unit u's row at step k (None past the last row) */
  def row(u: Int, k: Int): Option[Int] = Some(k * P + u).filter(_ < n)
  def matInit(u: Int): Seq[Seq[BigInt]] = (0 until K).map(k => row(u, k).map(mat(_)).getOrElse(Seq.fill(n)(BigInt(0))))

  /** Cycles of a frame's run: K row reads, 2 of block-RAM read latency and the tree's l_M + l_A ceil(log2 n). */
  val runCycles: Int = K + 2 + dp.latency
  /** From the cycle of a frame's last input beat to the cycle of its first output beat (the sink ready): the frame
    * taken (2), the run, the result memory read and the output queue (2). */
  val latency: Int = 2 + runCycles + 2
  /** Frames always waiting, the sink always ready: a frame every runCycles + 1 + n cycles (the next frame loads
    * while this one's n words leave, when n <= that; a run waits for the previous frame's words to be read). */
  def periodCycles: Int = math.max(runCycles + 1 + n, n + 2 + 1 + 2)
  val multipliers: Int = P * n
}

object MatVecParams {
  import gen.ConfigJson.{mat => matOf}

  /** Read the config.json of mpc_cores/admm/split.py. */
  def fromJson(text: String): MatVecParams = {
    val j = ujson.read(text)
    require(j("core").str == "matvec", s"not a matrix-vector configuration: core=${j("core").str}")
    MatVecParams(
      name = j("module").str,
      n = j("n").num.toInt,
      P = j("P").num.toInt,
      fracBits = j("frac_bits").num.toInt,
      latMul = j("lat_mul").num.toInt,
      latAdd = j("lat_add").num.toInt,
      rounding = Rounding(j("rounding").str),
      target = Target(j("target").str),
      coefW = j("coef_width").num.toInt,
      opW = j("op_width").num.toInt,
      sumW = j("sum_width").num.toInt,
      mat = matOf(j("M")))
  }
}
