package admm

import chisel3._
import chisel3.util._
import fixed.FixedOps

/** The accelerated step for one component (AdmmParams.accelerated; Goldstein et al., fast AMA and fast ADMM with
  * restart): for each extrapolated state x of the method (AMA nu; ADMM z, nu; Vu-Condat y, z, nu), from the row's
  * new x (cur), the last iteration's (prev) and the one the iteration read (hat), 1 + l_M cycles later,
  *   cand_x = cur + mom (cur - prev)             (rounded like the products, saturated to the x word, with its flag)
  * and the component's share of the restart test:
  *   AMA (gradient):      floor(d (nu - prev) / 2^b)                  (<nu - nu^, nu - prev>_(1/rho), nu - nu^ = rho d)
  *   ADMM, Vu-Condat:     sum_x floor((cur - hat)^2 / 2^b) 2^(+-k)    (the combined residual; k the row's shift,
  *                                                                     negative for nu; right shifts floor)
  * mpc_cores.admm.model.AdmmFixed is its bit-exact model. */
class MomentumLane(p: AdmmParams) extends Module {
  val keys: Seq[String] = p.accStates
  val io = IO(new Bundle {
    val cur  = Input(MixedVec(keys.map(k => SInt(p.accCurW(k).W))))
    val prev = Input(MixedVec(keys.map(k => SInt(p.accCurW(k).W))))
    val hat  = Input(MixedVec(keys.map(k => SInt(p.accCurW(k).W))))
    val d    = Input(SInt(p.dW.W))
    val code = Input(UInt(math.max(1, log2Ceil(p.shifts.length)).W))
    val mom  = Input(SInt(p.momW.W))
    val cand = Output(MixedVec(keys.map(k => SInt(p.accW0(k).W))))
    val candOvf = Output(Bool())
    val term = Output(SInt(p.termW.W))
  })
  private def reg(x: SInt, w: Int): SInt = { val r = Reg(SInt(w.W)); r := x; r }
  private def delay(x: SInt, w: Int): SInt = ShiftRegister(reg(x, w), p.latMul)
  val momR  = reg(io.mom, p.momW)
  val codeD = ShiftRegister(RegNext(io.code), p.latMul)
  val ovfs = for ((k, i) <- keys.zipWithIndex) yield {
    val w    = p.accW0(k)
    val diff = reg(io.cur(i) -& io.prev(i), p.accCurW(k) + 1)
    val e    = FixedOps.mulRoundPipelined(momR, diff, p.latMul, p.fracBits, p.rounding, p.target)
    val (c, of) = FixedOps.satAdd(delay(io.cur(i), p.accCurW(k)), e, w)
    io.cand(i) := c
    of
  }
  io.candOvf := ovfs.reduce(_ || _)
  /** a 2^(sign k_code), a >= 0 (left shifts, or floor right shifts) */
  private def weighted(a: SInt, neg: Boolean): SInt = {
    val opts = p.shifts.map { k0 => val k = if (neg) -k0 else k0; if (k >= 0) (a << k).asSInt else (a >> -k).asSInt }
    VecInit(opts.map(_.pad(p.termW))).apply(codeD)
  }
  val term: SInt =
    if (p.method == "ama") {
      val diff = reg(io.cur(0) -& io.prev(0), p.accCurW("nu") + 1)
      (FixedOps.mulPipelined(reg(io.d, p.dW), diff, p.latMul, 0, p.target) >> p.fracBits).asSInt
    } else keys.zipWithIndex.map { case (k, i) =>
      val dx = reg(io.cur(i) -& io.hat(i), p.accCurW(k) + 1)
      weighted((FixedOps.mulPipelined(dx, dx, p.latMul, 0, p.target) >> p.fracBits).asSInt, k == "nu")
    }.reduce(_ +& _)
  io.term := term.pad(p.termW)(p.termW - 1, 0).asSInt
}
