package ipm

import chisel3._
import chisel3.util.log2Ceil

/** The slot memory: `copies` SyncReadMems of `depth` words, each with one read port and one write port, all
  * written with the same word on the same cycle, copy k read only by operand k (a, b). Two operands are read on
  * the same cycle without a second read port on any memory, so Yosys maps every copy to DP16KD (ECP5)
  * block RAM in simple dual-port mode. The engine never reads a word on the cycle it writes it (an instruction
  * starts reading after the previous one's last write), so read-under-write is left undefined.
  *
  * Read timing: the address of cycle t gives its word on cycle t + 1.
  */
class SlotMem(depth: Int, width: Int, copies: Int) {
  require(depth >= 1 && copies >= 1)
  private val aw   = math.max(1, log2Ceil(depth))
  private val mems = Seq.tabulate(copies) { k =>
    val m = SyncReadMem(depth, UInt(width.W))
    m.suggestName(s"slotmem_$k")
    m
  }

  def write(en: Bool, addr: UInt, data: UInt): Unit =
    for (m <- mems) when(en) { m.write(addr(aw - 1, 0), data) }

  def read(copy: Int, addr: UInt): UInt = mems(copy).read(addr(aw - 1, 0))
}

/** A read-only memory with its words written into the emitted Verilog (mem.InitRam without writes): one
  * registered read port, the word of the address of cycle t on cycle t + 1. Maps to block RAM or LUT ROM.
  */
object Rom {
  private def signed(v: BigInt, w: Int): BigInt = if (v >= (BigInt(1) << (w - 1))) v - (BigInt(1) << w) else v

  def apply(name: String, words: Seq[BigInt], width: Int, addr: UInt, clock: Clock): UInt = {
    val depth = math.max(1, words.length)
    val ram   = Module(new mem.InitRam(name, depth, 1, width, words.map(w => Seq(signed(w, width)))))
    ram.io.clock := clock
    ram.io.raddr := addr.pad(ram.addrW)(ram.addrW - 1, 0)
    ram.io.wen   := false.B
    ram.io.waddr := 0.U
    ram.io.wmask := 0.U
    ram.io.wdata := 0.U
    ram.io.rdata
  }
}
