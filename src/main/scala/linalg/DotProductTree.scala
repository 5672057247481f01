package linalg

import chisel3._
import chisel3.util._
import dsp.Target
import fixed.{FixedOps, Rounding}

/** Parameters of a fixed-point dot product w^T v of length m (Fig. 2a of 002).
  *
  * @param m        vector length (number of multipliers)
  * @param coefW    width of the coefficient words w_j
  * @param opW      width of the operand words v_j
  * @param sumW     width of every product and partial sum (sized from the overflow bounds, Prop. 1 of 002)
  * @param fracBits fraction bits dropped after each product (both operands carry fracBits)
  * @param latMul   pipeline registers after each multiplier (l_M)
  * @param latAdd   pipeline registers after each adder level (l_A)
  * @param target   the FPGA family the multipliers are built for (dsp.Target)
  */
case class DotProductParams(
    m: Int,
    coefW: Int,
    opW: Int,
    sumW: Int,
    fracBits: Int,
    latMul: Int,
    latAdd: Int,
    rounding: Rounding,
    target: Target = Target.Generic) {
  require(m >= 1, s"DotProductTree: m must be >= 1, got m=$m")
  require(latMul >= 0 && latAdd >= 0, s"DotProductTree: latencies must be >= 0, got lM=$latMul lA=$latAdd")
  require(sumW >= 2, s"DotProductTree: sumW must be >= 2, got $sumW")
  /** Adder-tree depth ceil(log2 m). */
  val depth: Int = log2Ceil(m)
  /** Cycles from operands in to sum out: l_M + l_A ceil(log2 m). */
  val latency: Int = latMul + latAdd * depth
}

/** m parallel multipliers and a pairwise adder-reduction tree. Products are rounded back to fracBits fraction
  * bits; every product and partial sum saturates to sumW bits and raises `overflow` (aligned with `outValid`)
  * instead of wrapping. The tree pairs (0,1), (2,3), ... at each level and passes an odd last element on: the
  * golden model reduces in the same order.
  */
class DotProductTree(val p: DotProductParams) extends Module {
  override def desiredName = s"DotProductTree_m${p.m}_c${p.coefW}_o${p.opW}_s${p.sumW}_b${p.fracBits}_" +
    s"lm${p.latMul}_la${p.latAdd}_${p.rounding.name}" +
    (if (p.target == Target.Generic) "" else s"_${p.target.name}")

  val io = IO(new Bundle {
    /** operands valid this cycle */
    val inValid = Input(Bool())
    val coef    = Input(Vec(p.m, SInt(p.coefW.W)))
    val op      = Input(Vec(p.m, SInt(p.opW.W)))
    /** high `latency` cycles after inValid */
    val outValid = Output(Bool())
    val sum      = Output(SInt(p.sumW.W))
    /** a product or partial sum of this result saturated */
    val overflow = Output(Bool())
  })

  private def delay[T <: Data](x: T, n: Int): T = ShiftRegister(x, n)

  // Multipliers (l_M stages, FixedOps.mulRoundPipelined: the product rounded back to fracBits), then narrowed.
  val level0 = (0 until p.m).map { j =>
    FixedOps.mulRoundSatPipelined(io.coef(j), io.op(j), p.latMul, p.fracBits, p.rounding, p.target, p.sumW)
  }

  // Adder tree, l_A registers per level (from l_A = 2 the first sits between the carry chain and the saturation).
  var level: Seq[(SInt, Bool)] = level0
  while (level.length > 1) {
    level = level.grouped(2).toSeq.map {
      case Seq((a, fa), (b, fb)) =>
        val (s, of) = FixedOps.satAddPipelined(a, b, p.sumW, p.latAdd)
        (s, delay(fa || fb, p.latAdd) || of)
      case Seq((a, fa)) => (delay(a, p.latAdd), delay(fa, p.latAdd))
    }
  }
  io.sum      := level.head._1
  io.overflow := level.head._2
  io.outValid := ShiftRegister(io.inValid, p.latency, false.B, true.B)
}
