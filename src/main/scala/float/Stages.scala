package float

import chisel3._

/** Where the registers of a fixed-latency pipeline go. An operator is written as combinational steps, each with a
  * weight (its estimated delay, in LUT levels with their routes); `latency` registers are spread over the cuts
  * after them: with latency <= steps, one register after each of `latency` distinct steps, the last one always
  * the output, chosen so that the heaviest run of steps between two registers is as light as it can be (the
  * earliest such placement); with more, every step gets one and the rest are added at the output.
  * latency = 0 is purely combinational. `forced` steps always get a register after them (a hard block's own
  * registers: the placement balances the runs between them).
  */
case class Stages(latency: Int, weights: Seq[Int], forced: Set[Int] = Set.empty) {
  require(latency >= 0, s"latency must be >= 0: got latency=$latency")
  require(weights.nonEmpty, s"a pipeline needs at least one step: got steps=${weights.length}")
  require(weights.forall(_ >= 1), s"step weights must be >= 1: got ${weights.mkString(", ")}")
  val steps: Int = weights.length
  require(forced.forall(i => i >= 0 && i < steps), s"forced steps must be in [0, $steps): got ${forced.mkString(", ")}")
  /** the fewest registers that hold the forced ones and the output's */
  val minLatency: Int = (forced + (steps - 1)).size
  require(forced.isEmpty || latency >= minLatency,
    s"latency must be >= $minLatency (registers after steps ${forced.toSeq.sorted.mkString(", ")} and the output): got latency=$latency")

  /** Registers after step i, i in [0, steps). */
  val after: IndexedSeq[Int] = {
    val a = Array.fill(steps)(0)
    if (latency == 0) ()
    else if (latency <= steps) Stages.balanced(weights, latency, forced).foreach(i => a(i) = 1)
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
  /** The steps after which `regs` (1 to weights.length) registers go, the last step among them and every `forced`
    * one, minimising the heaviest run of steps between registers (dynamic programme over the last register's
    * step; a run may not pass a forced step; ties go to the earliest cuts).
    */
  def balanced(weights: Seq[Int], regs: Int, forced: Set[Int] = Set.empty): Seq[Int] = {
    val n   = weights.length
    val pre = weights.scanLeft(0L)(_ + _).toIndexedSeq // pre(i) = weight of steps [0, i)
    def run(from: Int, to: Int): Long = pre(to + 1) - pre(from) // steps from..to
    def open(from: Int, to: Int): Boolean = !forced.exists(f => f >= from && f < to) // no forced cut inside
    // cost(j)(i): the lightest heaviest run with j + 1 registers, the last after step i; prev: the one before it
    val cost = Array.fill(regs, n)(Long.MaxValue)
    val prev = Array.fill(regs, n)(-1)
    for (i <- 0 until n if open(0, i)) cost(0)(i) = run(0, i)
    for (j <- 1 until regs; i <- j until n; k <- j - 1 until i if cost(j - 1)(k) < Long.MaxValue && open(k + 1, i)) {
      val c = math.max(cost(j - 1)(k), run(k + 1, i))
      if (c < cost(j)(i)) { cost(j)(i) = c; prev(j)(i) = k }
    }
    (regs - 1 to 0 by -1).scanLeft(n - 1)((i, j) => prev(j)(i)).take(regs).reverse
  }

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
