package minres

import chisel3._
import chisel3.util._
import float.{FAdd, FloatFormat, Stages}

/** Sum of a stream of `nTerms` words arriving one per cycle (indices 0..nTerms-1 without gaps), with one
  * pipelined adder of latency L = latAdd: term k is added to the partial sum of bucket k mod L, which the adder
  * returns exactly L cycles later (the first L terms are added to +0). The last L outputs (terms nTerms-L ..
  * nTerms-1, in arrival order) are captured and reduced by a pairwise tree. `sum` is valid with `done`,
  * latAdd + 1 + latAdd ceil(log2 L) cycles after the last term entered.
  */
class FStreamAcc(fmt: FloatFormat, nTerms: Int, latAdd: Int) extends Module {
  require(latAdd >= 1 && nTerms > latAdd, s"FStreamAcc: need latAdd >= 1 and nTerms > latAdd: got $latAdd, $nTerms")
  private val L = latAdd
  val latency: Int = latAdd + 1 + latAdd * log2Ceil(L)
  override def desiredName = s"FStreamAcc_${fmt.tag}_n${nTerms}_la$latAdd"
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
  add.b        := Mux(io.index < L.U, 0.U, add.out)
  add.sub      := false.B
  val idxOut = Stages.delay(io.index, latAdd)
  val vOut   = Stages.delayValid(io.valid, latAdd)
  val parts  = Reg(Vec(L, UInt(fmt.width.W)))
  when(vOut && idxOut >= (nTerms - L).U) { parts(idxOut - (nTerms - L).U) := add.out }
  val captured = RegNext(vOut && idxOut === (nTerms - 1).U, false.B)

  io.sum  := linalg.FAddTree(parts, fmt, latAdd)
  io.done := Stages.delayValid(captured, latAdd * log2Ceil(L))
}
