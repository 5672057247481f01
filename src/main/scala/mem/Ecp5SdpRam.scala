package mem

import chisel3._
import chisel3.util.{log2Ceil, HasBlackBoxInline}

/** A simple dual-port RAM with one write port and one read port of read latency 2, for the ECP5: DP16KD primitives
  * with the output register on (REGMODE_B "OUTREG"), so that the word leaves the block RAM from a register.
  * Yosys infers DP16KD only without it (NOREG: the word arrives about 4.3 ns after the clock on a speed-8 part, and
  * the fabric register behind it cannot be packed into the block).
  *
  * Port A writes (the write is not registered: a word written on cycle t is in the array at the end of t), port B
  * reads: the address of cycle t is read at the end of t and its word leaves the output register on cycle t + 2.
  * No initial contents, no resets, GSR off, chip selects unused. The data width mode follows the depth (1024 x 18,
  * 2048 x 9, 4096 x 4, 8192 x 2, 16384 x 1, `Ecp5SdpRam.mode`), ceil(width / mode) primitives side by side.
  *
  * Synthesis (Yosys defines SYNTHESIS) sees the primitives, simulation a behavioural model with the same timing.
  * Read-under-write of one address is left undefined (read-first in the model).
  */
class Ecp5SdpRam(val ramName: String, val depth: Int, val width: Int) extends BlackBox with HasBlackBoxInline {
  require(Ecp5SdpRam.fits(depth), s"Ecp5SdpRam $ramName: depth $depth outside [1, ${Ecp5SdpRam.maxDepth}]")
  require(width >= 1, s"Ecp5SdpRam $ramName: width must be >= 1: got $width")
  val addrW: Int = math.max(1, log2Ceil(depth))
  override def desiredName = ramName

  val io = IO(new Bundle {
    val clock = Input(Clock())
    val raddr = Input(UInt(addrW.W))
    val rdata = Output(UInt(width.W))
    val wen   = Input(Bool())
    val waddr = Input(UInt(addrW.W))
    val wdata = Input(UInt(width.W))
  })

  setInline(s"$ramName.sv",
    s"""// Simple dual-port RAM, read latency 2: on ECP5 DP16KD block RAMs with their output register (mem.Ecp5SdpRam),
       |// in simulation a behavioural model.
       |module $ramName (
       |  input                  clock,
       |  input      [${addrW - 1}:0] raddr,
       |  output     [${width - 1}:0] rdata,
       |  input                  wen,
       |  input      [${addrW - 1}:0] waddr,
       |  input      [${width - 1}:0] wdata
       |);
       |`ifdef SYNTHESIS
       |${Ecp5SdpRam.primitives(depth, width, addrW)}
       |`else
       |  reg [${width - 1}:0] mem [0:${depth - 1}];
       |  reg [${width - 1}:0] rd, rq;
       |  always @(posedge clock) begin
       |    if (wen) mem[waddr] <= wdata;
       |    rd <= mem[raddr];
       |    rq <= rd;
       |  end
       |  assign rdata = rq;
       |`endif
       |endmodule
       |""".stripMargin)
}

object Ecp5SdpRam {
  val maxDepth = 16384
  /** cycles from a read address to its word */
  val ReadLatency = 2

  def fits(depth: Int): Boolean = depth >= 1 && depth <= maxDepth

  /** the DP16KD's data width modes and their words */
  val modes: Seq[(Int, Int)] = Seq(18 -> 1024, 9 -> 2048, 4 -> 4096, 2 -> 8192, 1 -> 16384)

  /** the data width mode of a DP16KD holding `depth` words (the widest that does) */
  def mode(depth: Int): Int = modes.find(_._2 >= depth).get._1

  /** DP16KD primitives a depth x width memory takes */
  def primitives(depth: Int, width: Int): Int = (width + mode(depth) - 1) / mode(depth)

  /** the primitives' text: slice s holds bits [s w, s w + w) */
  def primitives(depth: Int, width: Int, addrW: Int): String = {
    val w = mode(depth)
    (0 until primitives(depth, width)).map { s =>
      val n = math.min(w, width - s * w)
      dp16kd(s"bram_s$s", w, modes.find(_._1 == w).get._2, addrW, "waddr", "raddr", "wen", Seq(),
        i => s"wdata[${s * w + i}]", i => s"rdata[${s * w + i}]", n)
    }.mkString("\n")
  }

  /** One DP16KD in a `w`-bit mode of `words` words, output register on: port A writes `din(i)` (i < n) at `waddr`
    * when `wen`, port B reads `raddr` into `dout(i)`; `params` adds INITVAL_xx. The word address is on the top
    * address pins; below it, the x18 mode's byte enables (on for writes) and zeros. */
  def dp16kd(inst: String, w: Int, words: Int, addrW: Int, waddr: String, raddr: String, wen: String,
      params: Seq[String], din: Int => String, dout: Int => String, n: Int): String = {
    val low = 14 - log2Ceil(words)
    def pins(p: String, k: Int)(f: Int => String) = (0 until k).map(i => s".$p$i(${f(i)})").mkString(", ")
    def addr(sig: String, enables: String)(i: Int) =
      if (i < low) (if (w == 18 && i < 2) enables else "1'b0")
      else if (i - low < addrW) s"$sig[${i - low}]"
      else "1'b0"
    val init = if (params.isEmpty) "" else ",\n    " + params.grouped(2).map(_.mkString(", ")).mkString(",\n    ")
    s"""  DP16KD #(
       |    .DATA_WIDTH_A($w), .DATA_WIDTH_B($w), .REGMODE_A("NOREG"), .REGMODE_B("OUTREG"),
       |    .RESETMODE("SYNC"), .ASYNC_RESET_RELEASE("SYNC"), .CSDECODE_A("0b000"), .CSDECODE_B("0b000"),
       |    .WRITEMODE_A("NORMAL"), .WRITEMODE_B("NORMAL"), .GSR("DISABLED")$init
       |  ) $inst (
       |    ${pins("DIA", 18)(i => if (i < n) din(i) else "1'b0")},
       |    ${pins("ADA", 14)(addr(waddr, "1'b1"))},
       |    .CLKA(clock), .CEA(1'b1), .OCEA(1'b1), .WEA($wen), .RSTA(1'b0), .CSA0(1'b0), .CSA1(1'b0), .CSA2(1'b0),
       |    ${pins("DIB", 18)(_ => "1'b0")},
       |    ${pins("ADB", 14)(addr(raddr, "1'b0"))},
       |    .CLKB(clock), .CEB(1'b1), .OCEB(1'b1), .WEB(1'b0), .RSTB(1'b0), .CSB0(1'b0), .CSB1(1'b0), .CSB2(1'b0),
       |    ${pins("DOB", n)(dout)}
       |  );""".stripMargin
  }
}
