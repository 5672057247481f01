package float

import chisel3._
import chisel3.util._

/** The floating-point operators by name, with their step counts and default latencies. */
object FloatOp {
  val names: Seq[String] = Seq("add", "mul", "div", "sqrt", "cmp")

  def check(op: String): Unit =
    require(names.contains(op), s"operator must be one of ${names.mkString(", ")}: got '$op'")

  def steps(op: String, fmt: FloatFormat): Int = op match {
    case "add"  => FAdd.steps(fmt)
    case "mul"  => FMul.steps(fmt)
    case "div"  => FDiv.steps(fmt)
    case "sqrt" => FSqrt.steps(fmt)
    case "cmp"  => FCompare.steps
  }

  def defaultLatency(op: String, fmt: FloatFormat): Int = op match {
    case "add"  => FAdd.defaultLatency(fmt)
    case "mul"  => FMul.defaultLatency(fmt)
    case "div"  => FDiv.defaultLatency(fmt)
    case "sqrt" => FSqrt.defaultLatency(fmt)
    case "cmp"  => FCompare.defaultLatency(fmt)
  }
}

/** Test wrapper with the same ports for every operator, so one testbench drives them all:
  * `op` is `sub` for add and `signaling` for cmp (ignored otherwise; sqrt ignores b);
  * `out` is the result, or for cmp [0] lt, [1] eq, [2] le, [3] unordered;
  * `flags` is [0] invalid, [1] divByZero, [2] overflow, [3] underflow, [4] inexact.
  */
class FloatTop(val opName: String, val fmt: FloatFormat, val latency: Int,
               val target: dsp.Target = dsp.Target.Generic) extends Module {
  FloatOp.check(opName)
  require(latency >= 0, s"latency must be >= 0: got latency=$latency")
  val outW = math.max(fmt.width, 4)

  val in_valid  = IO(Input(Bool()))
  val a         = IO(Input(UInt(fmt.width.W)))
  val b         = IO(Input(UInt(fmt.width.W)))
  val op        = IO(Input(Bool()))
  val out_valid = IO(Output(Bool()))
  val out       = IO(Output(UInt(outW.W)))
  val flags     = IO(Output(UInt(5.W)))

  override def desiredName = s"FloatTop_${opName}_${fmt.tag}_l$latency" +
    (if (opName == "mul" && FMul.onDsp(fmt, target)) s"_${target.name}" else "")

  opName match {
    case "cmp" =>
      val u = Module(new FCompare(fmt, latency))
      u.in_valid  := in_valid
      u.a         := a
      u.b         := b
      u.signaling := op
      out_valid   := u.out_valid
      out         := Cat(u.unordered, u.le, u.eq, u.lt)
      flags       := u.invalid.asUInt
    case "sqrt" =>
      val u = Module(new FSqrt(fmt, latency))
      u.in_valid := in_valid
      u.a        := a
      out_valid  := u.out_valid
      out        := u.out
      flags      := u.flags.bits
    case "add" =>
      val u = Module(new FAdd(fmt, latency))
      u.in_valid := in_valid
      u.a        := a
      u.b        := b
      u.sub      := op
      out_valid  := u.out_valid
      out        := u.out
      flags      := u.flags.bits
    case "mul" =>
      val u = Module(new FMul(fmt, latency, target))
      u.in_valid := in_valid
      u.a        := a
      u.b        := b
      out_valid  := u.out_valid
      out        := u.out
      flags      := u.flags.bits
    case "div" =>
      val u = Module(new FDiv(fmt, latency))
      u.in_valid := in_valid
      u.a        := a
      u.b        := b
      out_valid  := u.out_valid
      out        := u.out
      flags      := u.flags.bits
  }
}
