package minres

import chisel3._
import chisel3.util.log2Ceil

/** A vector memory of the MINRES core as block RAM: `copies` simple-dual-port memories of `depth` words of `width`
  * bits, each with one write port and one read port with an output register. Generic: a SyncReadMem and a fabric
  * register, which Yosys maps to DP16KD (ECP5) or RAMB (7-series); with `ecp5` (a module name prefix):
  * mem.Ecp5SdpRam, whose output register is the DP16KD's own. Every copy is written with the same word on the same
  * cycle (one `write` call per core), and copy i serves exactly one reader, so no memory needs read multiplexing
  * or transparency logic.
  *
  * Read timing: the address given to `read` on cycle t returns the word on cycle t + 2 (VecRam.ReadLatency): the
  * block RAM reads at the end of cycle t, and its word is registered once more, so that no logic follows the
  * block RAM's output (about 4.3 ns after the clock on an ECP5 without its output register). The core never
  * reads and writes one address on the same cycle, so the read-under-write behaviour is left undefined. (firtool
  * emits the read as a registered address, which Yosys takes for a transparent port and emulates on the DP16KD
  * with a bypass register and an address comparator, a few dozen FF and LUT4 per memory that the schedule never
  * uses.)
  */
class VecRam(name: String, val depth: Int, width: Int, copies: Int = 1, ecp5: Option[String] = None) {
  require(depth >= 1 && copies >= 1, s"VecRam $name: need depth >= 1 and copies >= 1: got $depth, $copies")
  private val aw = math.max(1, log2Ceil(depth))
  private def copyName(i: Int) = if (copies == 1) name else s"${name}_$i"
  /** the copies' write and read ports: (en, addr, data) => unit, addr => word */
  private val ports: Seq[((Bool, UInt, UInt) => Unit, UInt => UInt)] = Seq.tabulate(copies) { i =>
    ecp5 match {
      case Some(prefix) =>
        val r = Module(new mem.Ecp5SdpRam(s"${prefix}_${copyName(i)}", depth, width))
        r.io.clock := Module.clock
        ((en: Bool, a: UInt, d: UInt) => { r.io.wen := en; r.io.waddr := a; r.io.wdata := d },
          (a: UInt) => { r.io.raddr := a; r.io.rdata })
      case None =>
        val m = SyncReadMem(depth, UInt(width.W))
        m.suggestName(copyName(i))
        ((en: Bool, a: UInt, d: UInt) => when(en) { m.write(a, d) }, (a: UInt) => RegNext(m.read(a)))
    }
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
    for ((w, _) <- ports) w(en, fit(addr), data)
  }

  /** The read port of copy `copy` (call once per copy): data VecRam.ReadLatency cycles later. */
  def read(copy: Int, addr: UInt): UInt = {
    require(readers.add(copy), s"VecRam $name: copy $copy has one read port only")
    ports(copy)._2(fit(addr))
  }
}

object VecRam {
  /** cycles from a read address to its word */
  val ReadLatency = 2
  require(ReadLatency == mem.Ecp5SdpRam.ReadLatency)
}
