package float

import chisel3._

/** Where the registers of a fixed-latency pipeline go. An operator is written as combinational steps, each with a
  * weight (its estimated delay, in LUT levels with their routes); `latency` registers are spread over the cuts
  * after them: with latency <= steps, the k-th register goes after the first step at which the running weight
  * reaches k / latency of the total (so the last one always registers the output, and with equal weights it is
  * step ceil(k * steps / latency)); with more, every step gets one and the rest are added at the output.
  * latency = 0 is purely combinational.
  */
case class Stages(latency: Int, weights: Seq[Int]) {
  require(latency >= 0, s"latency must be >= 0: got latency=$latency")
  require(weights.nonEmpty, s"a pipeline needs at least one step: got steps=${weights.length}")
  require(weights.forall(_ >= 1), s"step weights must be >= 1: got ${weights.mkString(", ")}")
  val steps: Int = weights.length

  /** Registers after step i, i in [0, steps). */
  val after: IndexedSeq[Int] = {
    val a     = Array.fill(steps)(0)
    val run   = weights.scanLeft(0L)(_ + _).tail // running weight after each step
    val total = run.last
    if (latency <= steps) for (k <- 1 to latency) a(run.indexWhere(_ * latency >= k * total)) += 1
    else {
      for (i <- 0 until steps) a(i) = 1
      a(steps - 1) += latency - steps
    }
    a.toIndexedSeq
  }

  /** `x` delayed by the registers that follow step `i`. */
  def cut[T <: Data](i: Int, x: T): T = {
    require(i >= 0 && i < steps, s"step $i outside [0, $steps)")
    Stages.delay(x, after(i))
  }

  /** The registers from step `from` on, for a sub-block (RoundPack) that owns the last steps. */
  def from(first: Int): IndexedSeq[Int] = after.drop(first)
}

object Stages {
  /** Steps of equal weight. */
  def apply(latency: Int, steps: Int): Stages = {
    require(steps >= 1, s"a pipeline needs at least one step: got steps=$steps")
    Stages(latency, Seq.fill(steps)(1))
  }

  /** `x` through `n` plain registers (no enable, no reset: the valid bit travels beside it). */
  def delay[T <: Data](x: T, n: Int): T =
    (0 until n).foldLeft(x) { (v, _) =>
      val r = Reg(chiselTypeOf(v))
      r := v
      r
    }

  /** The valid bit through `n` registers with reset. */
  def delayValid(v: Bool, n: Int): Bool =
    (0 until n).foldLeft(v) { (x, _) =>
      val r = RegInit(false.B)
      r := x
      r
    }
}
