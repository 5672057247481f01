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

  /** the primitives of one InitRam: name, address width, lanes, lane width and its unsigned init rows */
  def primitives(addrW: Int, lanes: Int, laneW: Int, rows: Seq[BigInt], depth: Int): String = {
    require(fits(depth), s"Ecp5BlockRam: depth $depth > $maxDepth")
    val slices = (laneW + sliceW - 1) / sliceW
    val laneMask = (BigInt(1) << laneW) - 1
    val out = for (l <- 0 until lanes; s <- 0 until slices) yield {
      val lo    = l * laneW + s * sliceW
      val width = math.min(sliceW, laneW - s * sliceW)
      val words = rows.map(r => ((r >> (l * laneW)) & laneMask) >> (s * sliceW) & ((BigInt(1) << width) - 1))
      def pins(p: String, n: Int)(f: Int => String) = (0 until n).map(i => s".$p$i(${f(i)})").mkString(", ")
      // AD13..AD4 the word address; AD1, AD0 the byte enables of the x18 mode (on for writes), AD3, AD2 unused
      def addr(sig: String, enables: String)(i: Int) =
        if (i < 2) enables else if (i < 4) "1'b0" else if (i - 4 < addrW) s"$sig[${i - 4}]" else "1'b0"
      s"""  DP16KD #(
         |    .DATA_WIDTH_A(18), .DATA_WIDTH_B(18), .REGMODE_A("NOREG"), .REGMODE_B("OUTREG"),
         |    .RESETMODE("SYNC"), .ASYNC_RESET_RELEASE("SYNC"), .CSDECODE_A("0b000"), .CSDECODE_B("0b000"),
         |    .WRITEMODE_A("NORMAL"), .WRITEMODE_B("NORMAL"), .GSR("DISABLED"),
         |    ${initvals(words).grouped(2).map(_.mkString(", ")).mkString(",\n    ")}
         |  ) bram_l${l}_s$s (
         |    ${pins("DIA", 18)(i => if (i < width) s"wdata_q[${lo + i}]" else "1'b0")},
         |    ${pins("ADA", 14)(addr("waddr_q", "1'b1"))},
         |    .CLKA(clock), .CEA(1'b1), .OCEA(1'b1), .WEA(wen_q & wmask_q[$l]), .RSTA(1'b0), .CSA0(1'b0), .CSA1(1'b0), .CSA2(1'b0),
         |    ${pins("DIB", 18)(_ => "1'b0")},
         |    ${pins("ADB", 14)(addr("raddr", "1'b0"))},
         |    .CLKB(clock), .CEB(1'b1), .OCEB(1'b1), .WEB(1'b0), .RSTB(1'b0), .CSB0(1'b0), .CSB1(1'b0), .CSB2(1'b0),
         |    ${pins("DOB", width)(i => s"rdata[${lo + i}]")}
         |  );""".stripMargin
    }
    out.mkString("\n")
  }
}
