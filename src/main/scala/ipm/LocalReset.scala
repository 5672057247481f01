package ipm

import chisel3._

/** The module's reset registered, for a block instantiated under it (`withReset`): a register of the block's own
  * (kept apart on an FPGA target, mem.KeepReg), which placement puts beside the block's flip-flops, so that no
  * reset net crosses the device. The block enters and leaves reset a cycle after its parent.
  */
object LocalReset {
  def apply(keep: Boolean): Bool = {
    val r = Module.reset.asBool
    if (keep) mem.KeepReg(r) else RegNext(r)
  }
}
