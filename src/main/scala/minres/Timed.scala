package minres

import chisel3._
import float.{FAdd, FDiv, FMul, FSqrt, FloatFormat, Stages}

/** A word and the cycle (relative to its pipeline's reference) at which it is valid. Operators delay the
  * earlier operand so that both meet, so a dataflow graph is written as plain expressions and its latency is
  * known at elaboration. Constants are valid at any time.
  */
case class Timed(v: UInt, t: Int) {
  def isConst: Boolean = t == Timed.Always
}

object Timed {
  val Always: Int = Int.MinValue
  def const(v: UInt): Timed = Timed(v, Always)
}

/** Float operators on Timed values, one operator instance per operation (fully pipelined, no handshake). Each
  * operation registers its operands (TimedOps.OperandReg) before the operator, so that whatever selects them is
  * never in series with the operator's first step: its result is valid OperandReg + the operator's latency after
  * its operands. */
class TimedOps(fmt: FloatFormat, latAdd: Int, latMul: Int, latDiv: Int, latSqrt: Int, target: dsp.Target) {
  def at(x: Timed, t: Int): UInt =
    if (x.isConst) x.v
    else {
      require(t >= x.t, s"value needed at $t but valid only at ${x.t}")
      Stages.delay(x.v, t - x.t)
    }
  private def meet(xs: Timed*): Int = {
    val ts = xs.filterNot(_.isConst).map(_.t)
    require(ts.nonEmpty, "an operation on constants only")
    ts.max
  }

  private val R = TimedOps.OperandReg
  /** an operand of an operation whose operands meet at t, through the operand register */
  private def in(x: Timed, t: Int): UInt = if (x.isConst) x.v else at(x, t + R)

  def mul(a: Timed, b: Timed): Timed = {
    val t = meet(a, b)
    val u = Module(new FMul(fmt, latMul, target))
    u.in_valid := true.B
    u.a        := in(a, t)
    u.b        := in(b, t)
    Timed(u.out, t + R + latMul)
  }
  private def addsub(a: Timed, b: Timed, sub: Boolean): Timed = {
    val t = meet(a, b)
    val u = Module(new FAdd(fmt, latAdd))
    u.in_valid := true.B
    u.a        := in(a, t)
    u.b        := in(b, t)
    u.sub      := sub.B
    Timed(u.out, t + R + latAdd)
  }
  def add(a: Timed, b: Timed): Timed = addsub(a, b, sub = false)
  def sub(a: Timed, b: Timed): Timed = addsub(a, b, sub = true)
  def div(a: Timed, b: Timed): Timed = {
    val t = meet(a, b)
    val u = Module(new FDiv(fmt, latDiv))
    u.in_valid := true.B
    u.a        := in(a, t)
    u.b        := in(b, t)
    Timed(u.out, t + R + latDiv)
  }
  def sqrt(a: Timed): Timed = {
    val t = meet(a)
    val u = Module(new FSqrt(fmt, latSqrt))
    u.in_valid := true.B
    u.a        := in(a, t)
    Timed(u.out, t + R + latSqrt)
  }
  /** sign flip (exact) */
  def neg(a: Timed): Timed = Timed(a.v ^ (BigInt(1) << (fmt.width - 1)).U, a.t)
  /** a word valid at the time of x */
  def delayTo[T <: Data](x: T, from: Int, to: Int): T = { require(to >= from); Stages.delay(x, to - from) }
}

object TimedOps {
  /** the register between an operation's operands and its operator */
  val OperandReg = 1
}
