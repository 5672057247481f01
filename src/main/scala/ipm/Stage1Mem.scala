package ipm

import chisel3._
import chisel3.util.{isPow2, log2Ceil}

/** The slot memory: `copies` memories of `depth` words, each with one read port and one write port, all written
  * with the same word on the same cycle, copy k read only by operand k (a, b). Two operands are read on the same
  * cycle without a second read port on any memory, so Yosys maps every copy to DP16KD (ECP5) block RAM in simple
  * dual-port mode. The engine never reads a word on the cycle it writes it (an instruction reads three cycles
  * after the previous one issues its last write, which lands a cycle after its issue), so read-under-write is left
  * undefined.
  *
  * Each copy is split into banks of at most `bankWords` words, each a mem.InitRam with its output register
  * (read-first, starting at zero): Yosys maps the bank's read register into its block RAMs and keeps the output
  * register in the fabric next to them, which the ECP5 block RAM cannot absorb. A read then selects the bank
  * after that register, so no path runs from a block RAM's output (about 4.3 ns after the clock on the ECP5
  * without its output register) through the multiplexer of a deep memory.
  *
  * With `ecp5`, the banks are mem.Ecp5SdpRam: the output register is the DP16KD's own.
  *
  * A bank's word is registered once more in the fabric (next to its block RAMs, which lie far from the units that
  * take the word), and the bank is selected after that register.
  *
  * Read timing: the address of cycle t gives its word on cycle t + 3 (SlotMem.ReadLatency).
  */
class SlotMem(prefix: String, depth: Int, width: Int, copies: Int, bankWords: Int = SlotMem.BankWords,
    ecp5: Boolean = false) {
  require(depth >= 1 && copies >= 1 && bankWords >= 2 && isPow2(bankWords))
  private val aw    = math.max(1, log2Ceil(depth))
  private val lowW  = math.min(aw, log2Ceil(bankWords))
  private val banks = (depth + bankWords - 1) / bankWords
  /** a bank's ports: its address width, (en, addr, data) => unit, addr => word */
  private class Bank(val addrW: Int, val write: (Bool, UInt, UInt) => Unit, val read: UInt => UInt)
  private val rams = Seq.tabulate(copies, banks) { (k, b) =>
    val words = math.min(bankWords, depth - b * bankWords)
    val name  = s"${prefix}_slotmem_${k}_b$b"
    if (ecp5) {
      val ram = Module(new mem.Ecp5SdpRam(name, words, width))
      ram.io.clock := Module.clock
      new Bank(ram.addrW, (en, a, d) => { ram.io.wen := en; ram.io.waddr := a; ram.io.wdata := d },
        a => { ram.io.raddr := a; ram.io.rdata })
    } else {
      val ram = Module(new mem.InitRam(name, words, 1, width, Seq(), outReg = true))
      ram.io.clock := Module.clock
      ram.io.wmask := 1.U
      new Bank(ram.addrW, (en, a, d) => { ram.io.wen := en; ram.io.waddr := a; ram.io.wdata := d },
        a => { ram.io.raddr := a; ram.io.rdata })
    }
  }
  private def low(addr: UInt, ram: Bank): UInt = addr(lowW - 1, 0).pad(ram.addrW)(ram.addrW - 1, 0)
  private def bank(addr: UInt): UInt = if (aw > lowW) addr(aw - 1, lowW) else 0.U

  /** The write of cycle t lands at the end of t + 1: its enables (one per bank), address and word are registered
    * first, so that the unit's result select does not reach across the device to every bank. */
  def write(en: Bool, addr: UInt, data: UInt): Unit = {
    val (a, d) = (RegNext(addr), RegNext(data))
    for (copy <- rams; (ram, b) <- copy.zipWithIndex)
      ram.write(RegNext(en && bank(addr) === b.U, false.B), low(a, ram), d)
  }

  def read(copy: Int, addr: UInt): UInt = {
    val words = rams(copy).map(ram => RegNext(ram.read(low(addr, ram))))
    if (banks == 1) words.head else VecInit(words)(float.Stages.delay(bank(addr), SlotMem.ReadLatency))
  }
}

object SlotMem {
  /** words per bank: 2048 x 26 bits (e8m17) is three DP16KD in the 2048 x 9 mode */
  val BankWords   = 2048
  val ReadLatency = 3
}

/** A read-only memory with its words written into the emitted Verilog (mem.InitRam without writes): one
  * registered read port, the word of the address of cycle t on cycle t + 1. Maps to block RAM or LUT ROM.
  * `registered`: the word registered once more (cycle t + 2), in the block RAM's output register on the ECP5
  * (`ecp5`, mem.InitRam), so that it leaves the block from a register.
  */
object Rom {
  private def signed(v: BigInt, w: Int): BigInt = if (v >= (BigInt(1) << (w - 1))) v - (BigInt(1) << w) else v

  def apply(name: String, words: Seq[BigInt], width: Int, addr: UInt, clock: Clock): UInt =
    read(name, words, width, addr, clock, outReg = false, ecp5 = false)

  def registered(name: String, words: Seq[BigInt], width: Int, addr: UInt, clock: Clock, ecp5: Boolean): UInt =
    read(name, words, width, addr, clock, outReg = true, ecp5 = ecp5)

  private def read(name: String, words: Seq[BigInt], width: Int, addr: UInt, clock: Clock, outReg: Boolean,
      ecp5: Boolean): UInt = {
    val depth = math.max(1, words.length)
    val ram   = Module(new mem.InitRam(name, depth, 1, width, words.map(w => Seq(signed(w, width))), outReg = outReg,
      ecp5 = ecp5))
    ram.io.clock := clock
    ram.io.raddr := addr.pad(ram.addrW)(ram.addrW - 1, 0)
    ram.io.wen   := false.B
    ram.io.waddr := 0.U
    ram.io.wmask := 0.U
    ram.io.wdata := 0.U
    ram.io.rdata
  }
}
