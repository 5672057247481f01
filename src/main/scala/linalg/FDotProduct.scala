package linalg

import chisel3._
import dsp.Target
import float.{FMul, FloatFormat, Stages}

/** Floating-point dot product of k terms (Fig. 1 of 001): k parallel multipliers and a pairwise adder tree,
  * pairs (0,1), (2,3), ... at each level and an odd last element passed on (delayed to stay aligned), the order
  * of DotProductTree and of the golden model. `move` plain registers carry each product to the tree: the
  * multipliers sit by their hard multipliers, spread along the device's DSP rows, and a register-to-register hop
  * takes the long route instead of a rounding step. Fixed latency move + latMul + latAdd ceil(log2 k), one dot
  * product per cycle.
  */
class FDotProduct(val fmt: FloatFormat, val k: Int, val latMul: Int, val latAdd: Int, val move: Int = 0,
                  val target: Target = Target.Generic) extends Module {
  require(k >= 1, s"FDotProduct: k must be >= 1, got k=$k")
  require(move >= 0, s"FDotProduct: move must be >= 0, got move=$move")
  val depth: Int   = chisel3.util.log2Ceil(k)
  val latency: Int = move + latMul + latAdd * depth
  override def desiredName = s"FDotProduct_${fmt.tag}_k${k}_lm${latMul}_la$latAdd" + (if (move > 0) s"_m$move" else "") +
    (if (FMul.onDsp(fmt, target)) s"_${target.name}" else "")

  val io = IO(new Bundle {
    val a   = Input(Vec(k, UInt(fmt.width.W)))
    val b   = Input(Vec(k, UInt(fmt.width.W)))
    val sum = Output(UInt(fmt.width.W))
  })

  val products: Seq[UInt] = (0 until k).map { t =>
    val mul = Module(new FMul(fmt, latMul, target))
    mul.in_valid := true.B
    mul.a        := io.a(t)
    mul.b        := io.b(t)
    Stages.delay(mul.out, move)
  }
  io.sum := FAddTree(products, fmt, latAdd)
}
