package admm

import chisel3._
import chisel3.util._
import fixed.FixedOps

/** Fast AMA's step for one component (AdmmParams.accelerated): from the row's new multiplier nu (cur), the last
  * iteration's (prev), d = y - z and the iteration's momentum word, 1 + l_M cycles later,
  *   cand = cur + mom (cur - prev)            (rounded like the products, saturated to the nu word, with its flag)
  *   term = floor(d (cur - prev) / 2^b)       (the component's share of the gradient test <nu - nu^, nu - prev>_(1/rho),
  *                                              since nu - nu^ = rho d)
  * mpc_cores.admm.model.AdmmFixed is its bit-exact model. */
class MomentumLane(p: AdmmParams) extends Module {
  val io = IO(new Bundle {
    val cur  = Input(SInt(p.nuW.W))
    val prev = Input(SInt(p.nuW.W))
    val d    = Input(SInt(p.dW.W))
    val mom  = Input(SInt(p.momW.W))
    val cand = Output(SInt(p.nuW.W))
    val candOvf = Output(Bool())
    val term = Output(SInt(p.termW.W))
  })
  private def reg(x: SInt, w: Int): SInt = { val r = Reg(SInt(w.W)); r := x; r }
  val diff = reg(io.cur -& io.prev, p.nuW + 1)
  val dR   = reg(io.d, p.dW)
  val curR = reg(io.cur, p.nuW)
  val momR = reg(io.mom, p.momW)
  val e    = FixedOps.mulRoundPipelined(momR, diff, p.latMul, p.fracBits, p.rounding, p.target)
  val t    = FixedOps.mulPipelined(dR, diff, p.latMul, 0, p.target) >> p.fracBits
  val (cand, of) = FixedOps.satAdd(ShiftRegister(curR, p.latMul), e, p.nuW)
  io.cand    := cand
  io.candOvf := of
  io.term    := t.asSInt.pad(p.termW)(p.termW - 1, 0).asSInt
}
