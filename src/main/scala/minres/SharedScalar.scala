package minres

import chisel3._
import chisel3.util.{Cat, Mux1H, RegEnable}
import float.{FAdd, FDiv, FMul, FSqrt, FloatFormat}

/** A static schedule of a small dataflow graph of float operations on one operator per kind: `ops` in program
  * order, each (name, kind, operand names), kind "mul", "add", "sub" (one FAdd for both), "div" or "sqrt";
  * operands are other operations or sources (valid at time 0). Each operation issues at the first cycle at which
  * its operands are ready and its operator is free (ASAP list scheduling in program order): its operands are
  * selected on that cycle into the operator's operand registers (StaticSchedule.OperandReg), and `ready` is the
  * cycle its result appears, OperandReg + the operator's latency later. mpc_cores/minres/schedule.py computes the
  * same schedule.
  */
case class StaticSchedule(ops: Seq[(String, String, Seq[String])], lat: Map[String, Int], sources: Set[String]) {
  private def unit(kind: String): String = if (kind == "sub") "add" else kind
  val (issue, ready): (Map[String, Int], Map[String, Int]) = {
    val busy  = scala.collection.mutable.Set[(String, Int)]()
    val ready = scala.collection.mutable.Map[String, Int]() ++ sources.map(_ -> 0)
    val issue = scala.collection.mutable.Map[String, Int]()
    for ((name, kind, args) <- ops) {
      require(args.forall(ready.contains), s"operation $name reads an operand not computed before it: $args")
      var t = args.map(ready).max
      while (busy((unit(kind), t))) t += 1
      busy += ((unit(kind), t))
      issue(name) = t
      ready(name) = t + StaticSchedule.OperandReg + lat(unit(kind))
    }
    (issue.toMap, ready.toMap)
  }
  /** cycles from the trigger to the last result */
  val latency: Int = ops.map(o => ready(o._1)).max
  def units: Seq[String] = ops.map(o => unit(o._2)).distinct
}

object StaticSchedule {
  /** the register between an operator's operand select and the operator */
  val OperandReg = 1
}

/** The hardware of a StaticSchedule: one FMul, FAdd, FDiv and FSqrt (those the graph uses), their operands
  * selected (AND-OR) by a one-hot cycle count started by `trigger` into a register ahead of the operator (no select
  * before an operator's first step). The sources are read on the trigger cycle;
  * every value is kept in a register from its ready cycle until the next trigger, which must come at least
  * `latency` cycles later. Each operation is rounded as on an operator of its own, so the results equal a fully pipelined
  * evaluation of the graph word for word.
  */
class SharedScalar(fmt: FloatFormat, s: StaticSchedule, trigger: Bool, sources: Map[String, UInt],
                   target: dsp.Target) {
  require(sources.keySet == s.ready.keySet -- s.issue.keySet, "the sources must be the schedule's")
  private val L = s.latency
  require(L >= 2, s"SharedScalar: a schedule of at least 2 cycles: got $L")
  // cycles since the trigger, one-hot (bit t: t cycles since the trigger, t in 1..L; none: idle), so that every
  // select below is a register bit. A plain shift register: as triggers come at least L cycles apart, a trigger
  // finds bits 1 .. L - 1 clear, and only bit 1 depends on it
  private val hot = RegInit(0.U((L + 1).W))
  hot := Cat(hot(L - 1, 1), trigger, 0.U(1.W))
  assert(!(trigger && hot(L - 1, 1).orR), "SharedScalar: a trigger within %d cycles of the previous one", L.U)
  private def at(t: Int): Bool = if (t == 0) trigger else hot(t)
  private val lat = s.lat

  private class Unit(kind: String) {
    val (in_valid, a, b, out, sub) = kind match {
      case "mul" =>
        val u = Module(new FMul(fmt, lat("mul"), target)); (u.in_valid, u.a, u.b, u.out, None)
      case "add" =>
        val u = Module(new FAdd(fmt, lat("add"))); (u.in_valid, u.a, u.b, u.out, Some(u.sub))
      case "div" =>
        val u = Module(new FDiv(fmt, lat("div"))); (u.in_valid, u.a, u.b, u.out, None)
      case "sqrt" =>
        val u = Module(new FSqrt(fmt, lat("sqrt"))); (u.in_valid, u.a, u.a, u.out, None)
    }
  }
  private val units = s.units.map(u => u -> new Unit(u)).toMap
  private def unitOf(kind: String): String = if (kind == "sub") "add" else kind
  private val raw: Map[String, UInt] =
    sources ++ s.ops.map { case (name, kind, _) => name -> units(unitOf(kind)).out }
  private val held: Map[String, UInt] = raw.map { case (name, v) => name -> RegEnable(v, at(s.ready(name))) }

  /** the value of `name` at cycle t (at or after its ready cycle) */
  def value(name: String, t: Int): UInt = {
    require(t >= s.ready(name), s"$name is ready at ${s.ready(name)}, needed at $t")
    if (t == s.ready(name)) raw(name) else held(name)
  }

  for ((u, hw) <- units) {
    val mine = s.ops.filter(o => unitOf(o._2) == u)
    // one operation issues on the unit per cycle at most (the schedule's), so the selects are one-hot
    def operand(i: Int): UInt = Mux1H(mine.map { case (name, _, args) =>
      at(s.issue(name)) -> value(args(math.min(i, args.length - 1)), s.issue(name))
    })
    require(StaticSchedule.OperandReg == 1)
    hw.in_valid := true.B
    hw.a := RegNext(operand(0))
    if (u != "sqrt") hw.b := RegNext(operand(1))
    hw.sub.foreach(_ := RegNext(mine.filter(_._2 == "sub").map(o => at(s.issue(o._1))).foldLeft(false.B)(_ || _)))
  }
}
