package minres

import chisel3._
import chisel3.util.log2Ceil

/** A vector memory of the MINRES core as block RAM: `copies` simple-dual-port memories (SyncReadMem with one
  * write port and one registered read port each, and an output register) of `depth` words of `width` bits. Every copy is written with the
  * same word on the same cycle (one `write` call per core), and copy i serves exactly one reader, so Yosys maps
  * each copy to DP16KD (ECP5) or RAMB (7-series) without read multiplexing or transparency logic.
  *
  * Read timing: the address given to `read` on cycle t returns the word on cycle t + 2 (VecRam.ReadLatency): the
  * block RAM reads at the end of cycle t, and its word is registered once more, so that no logic follows the
  * block RAM's output (about 4.3 ns after the clock on an ECP5 without its output register). The core never
  * reads and writes one address on the same cycle, so the read-under-write behaviour is left undefined. (firtool emits the
  * read as a registered address, which Yosys takes for a transparent port and emulates on the DP16KD with a
  * bypass register and an address comparator, a few dozen FF and LUT4 per memory that the schedule never uses.)
  */
class VecRam(name: String, val depth: Int, width: Int, copies: Int = 1) {
  require(depth >= 1 && copies >= 1, s"VecRam $name: need depth >= 1 and copies >= 1: got $depth, $copies")
  private val aw = math.max(1, log2Ceil(depth))
  private val mems = Seq.tabulate(copies) { i =>
    val m = SyncReadMem(depth, UInt(width.W))
    m.suggestName(if (copies == 1) name else s"${name}_$i")
    m
  }
  private var written = false
  private val readers = scala.collection.mutable.Set[Int]()
  /** the address bits of the memory (addresses are computed wider; an out-of-range one only occurs on cycles
    * whose data is not used) */
  private def fit(a: UInt): UInt = a.pad(aw)(aw - 1, 0)

  /** The single write port of every copy. */
  def write(en: Bool, addr: UInt, data: UInt): Unit = {
    require(!written, s"VecRam $name: one write port only")
    written = true
    val a = fit(addr)
    for (m <- mems) when(en) { m.write(a, data) }
  }

  /** The read port of copy `copy` (call once per copy): data VecRam.ReadLatency cycles later. */
  def read(copy: Int, addr: UInt): UInt = {
    require(readers.add(copy), s"VecRam $name: copy $copy has one read port only")
    RegNext(mems(copy).read(fit(addr)))
  }
}

object VecRam {
  /** cycles from a read address to its word */
  val ReadLatency = 2
}
