package minres

import chisel3._
import chisel3.util._
import float.{FAdd, FloatFormat, Stages}

/** Sum of a stream of `nTerms` words arriving one per cycle (indices 0..nTerms-1 without gaps: the adder's operand
  * select relies on it), with one
  * pipelined adder of latency L = latAdd: term k is added to the partial sum of bucket k mod L, which the adder
  * returns exactly L cycles later (the first L terms are added to +0). The last L outputs (terms nTerms-L ..
  * nTerms-1, in arrival order) are captured and reduced pairwise: pairs (0,1), (2,3), ... at each level, an odd
  * last element passed on (the order of linalg.FAddTree and of the golden model). `sum` is valid with `done`,
  * `latency` cycles after the last term entered.
  *
  * `shareTree`: the reduction runs on one more adder by a static schedule (SharedScalar) instead of a tree of
  * L - 1 adders, the same words a few cycles later; the next stream's last term must come at least `latency`
  * cycles later (FStreamAcc.shares says when a stream is long enough).
  */
class FStreamAcc(fmt: FloatFormat, nTerms: Int, latAdd: Int, shareTree: Boolean = false) extends Module {
  require(latAdd >= 1 && nTerms > latAdd, s"FStreamAcc: need latAdd >= 1 and nTerms > latAdd: got $latAdd, $nTerms")
  private val L = latAdd
  val latency: Int = FStreamAcc.latency(latAdd, shareTree)
  override def desiredName = s"FStreamAcc_${fmt.tag}_n${nTerms}_la$latAdd" + (if (shareTree) "_s" else "")
  val io = IO(new Bundle {
    val valid = Input(Bool())
    val index = Input(UInt(log2Ceil(nTerms + 1).W))
    val term  = Input(UInt(fmt.width.W))
    val done  = Output(Bool())
    val sum   = Output(UInt(fmt.width.W))
  })
  val add = Module(new FAdd(fmt, latAdd))
  add.in_valid := io.valid
  add.a        := io.term
  // terms 0 .. L-1 are added to +0: the flag is known a cycle ahead, as a stream is gapless (after term
  // k < nTerms - 1 comes term k + 1; after the last term or an idle cycle, term 0 of the next stream), so the
  // operand is a register beside the adder's output register, loaded with the sum or cleared (no reset: the
  // first term after reset is term 0, added to +0)
  private val zeroNext = !io.valid || io.index < (L - 1).U || io.index === (nTerms - 1).U
  add.b        := RegNext(Mux(zeroNext, 0.U, add.outEarly.get))
  add.sub      := false.B
  val idxOut = Stages.delay(io.index, latAdd)
  val vOut   = Stages.delayValid(io.valid, latAdd)
  val parts  = Reg(Vec(L, UInt(fmt.width.W)))
  when(vOut && idxOut >= (nTerms - L).U) { parts(idxOut - (nTerms - L).U) := add.out }
  val captured = RegNext(vOut && idxOut === (nTerms - 1).U, false.B)

  if (shareTree && L > 1) {
    require(FStreamAcc.shares(nTerms, latAdd), s"FStreamAcc: $nTerms terms are too few for the shared reduction")
    val s  = FStreamAcc.treeSchedule(latAdd)
    val sh = new SharedScalar(fmt, s, captured, parts.zipWithIndex.map { case (v, i) => s"p$i" -> v }.toMap,
      dsp.Target.Generic)
    io.sum  := sh.value(s.ops.last._1, s.latency)
    io.done := Stages.delayValid(captured, s.latency)
  } else {
    io.sum  := linalg.FAddTree(parts, fmt, latAdd)
    io.done := Stages.delayValid(captured, latAdd * log2Ceil(L))
  }
}

object FStreamAcc {
  /** the pairwise reduction of the L partial sums as a graph in program order, level by level */
  def treeSchedule(latAdd: Int): StaticSchedule = {
    var level: Seq[String] = (0 until latAdd).map(i => s"p$i")
    val ops   = scala.collection.mutable.ArrayBuffer[(String, String, Seq[String])]()
    while (level.length > 1) {
      level = level.grouped(2).toSeq.map {
        case Seq(x, y) => val nm = s"t${ops.length}"; ops += ((nm, "add", Seq(x, y))); nm
        case Seq(x)    => x
      }
    }
    StaticSchedule(ops.toSeq, Map("add" -> latAdd), (0 until latAdd).map(i => s"p$i").toSet)
  }
  /** cycles from the last term entering to `done` */
  def latency(latAdd: Int, shareTree: Boolean): Int =
    latAdd + 1 + (if (shareTree && latAdd > 1) treeSchedule(latAdd).latency else latAdd * log2Ceil(latAdd))
  /** a stream of nTerms terms leaves the shared reduction enough cycles before the next stream's last term */
  def shares(nTerms: Int, latAdd: Int): Boolean = latAdd > 1 && nTerms > treeSchedule(latAdd).latency + 1
}
