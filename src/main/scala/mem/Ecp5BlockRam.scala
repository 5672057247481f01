package mem

/** The ECP5 text of an InitRam with its output register (read latency 2): DP16KD primitives in the 1024 x 18 mode
  * with the output register on (REGMODE_B "OUTREG"), so that the data leaves the block RAM from a register. Yosys
  * infers DP16KD only without it (its mapping always sets NOREG, the read data then arrives about 4.3 ns after the
  * clock on a speed-8 part, and the fabric register behind it cannot be packed into the block).
  *
  * The write port's inputs (wen_q, waddr_q, wmask_q, wdata_q) are InitRam's registered ones.
  *
  * Layout: every lane of a row gets its own ceil(laneW / 18) primitives (slice s holds lane bits 18 s ..), so a
  * lane-masked write is a write enable per primitive. Port A writes (both byte enables on), port B reads; GSR off,
  * no resets, chip selects unused. INITVAL_xx holds the 18-bit words 16 xx .. 16 xx + 15, word j in bits
  * [20 j, 20 j + 18). Synthesis (Yosys defines SYNTHESIS) sees the primitives, simulation the same behavioural
  * model as every InitRam: both read the address registered at one clock edge out of a register at the next.
  */
object Ecp5BlockRam {
  val maxDepth = 1024
  val sliceW   = 18

  def fits(depth: Int): Boolean = depth <= maxDepth

  /** INITVAL_00 .. INITVAL_3F of one slice: its 18-bit words, rows beyond `words` zero */
  def initvals(words: Seq[BigInt]): Seq[String] = (0 until 64).map { k =>
    val v = (0 until 16).foldLeft(BigInt(0)) { (acc, j) =>
      val i = 16 * k + j
      acc | ((if (i < words.length) words(i) else BigInt(0)) << (20 * j))
    }
    f".INITVAL_$k%02X(320'h${v.toString(16)})"
  }

  /** primitives per lane of laneW bits */
  def slices(laneW: Int): Int = (laneW + sliceW - 1) / sliceW
  /** the name of a primitive: lane l, slice s */
  def name(l: Int, s: Int): String = s"bram_l${l}_s$s"

  /** the primitives of one InitRam: address width, lanes, lane width, its unsigned init rows, depth, and the read
    * address of each primitive (by lane and slice) */
  def primitives(addrW: Int, lanes: Int, laneW: Int, rows: Seq[BigInt], depth: Int,
      raddrOf: (Int, Int) => String = (_, _) => "raddr"): String = {
    require(fits(depth), s"Ecp5BlockRam: depth $depth > $maxDepth")
    val slices = this.slices(laneW)
    val laneMask = (BigInt(1) << laneW) - 1
    val out = for (l <- 0 until lanes; s <- 0 until slices) yield {
      val lo    = l * laneW + s * sliceW
      val width = math.min(sliceW, laneW - s * sliceW)
      val words = rows.map(r => ((r >> (l * laneW)) & laneMask) >> (s * sliceW) & ((BigInt(1) << width) - 1))
      Ecp5SdpRam.dp16kd(name(l, s), sliceW, maxDepth, addrW, "waddr_q", raddrOf(l, s), s"wen_q & wmask_q[$l]",
        initvals(words), i => s"wdata_q[${lo + i}]", i => s"rdata[${lo + i}]", width)
    }
    out.mkString("\n")
  }
}
