package shell

import chisel3._

/** A word picked from several by a one-hot select, in two registered steps: groups of `group` words AND-ORed into
  * registers, then the OR of those registers. `hot` and `xs` are of the cycle before the result; `hot` must be
  * one-hot (an all-zero select gives 0). Two or three LUT levels a step, where one step would take five for twenty
  * words. */
object OneHotSelect {
  def registered(hot: Seq[Bool], xs: Seq[SInt], width: Int, group: Int = 4): SInt = {
    require(hot.length == xs.length && hot.nonEmpty, s"OneHotSelect: ${hot.length} selects for ${xs.length} words")
    val parts = hot.zip(xs).grouped(group).toSeq.map { g =>
      val r = Reg(UInt(width.W))
      // AND-OR written out: Mux1H passes a lone input through whatever its select
      r := g.map { case (h, x) => Mux(h, x.pad(width).asUInt, 0.U) }.reduce(_ | _)
      r
    }
    WireInit(SInt(width.W), parts.reduce(_ | _).asSInt)
  }
}
