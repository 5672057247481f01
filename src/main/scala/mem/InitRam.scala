package mem

import chisel3._
import chisel3.util._

/** A RAM with one synchronous read port and one lane-masked write port, whose power-on contents are written
  * into the emitted Verilog (no side files): Yosys and Vivado infer block or distributed RAM with the
  * initial values from it. Contents survive reset, as block RAM does.
  *
  * @param name   Verilog module name (unique per instance: each carries its own contents)
  * @param lanes  words per row; a write updates the lanes whose mask bit is set
  * @param laneW  bits per lane
  * @param init   init(row)(lane), signed; rows beyond init.length start at zero
  * @param outReg register the read data once more (read latency 2; maps to the block RAM output register)
  * @param ecp5   with outReg and at most 1024 rows: DP16KD primitives with their output register for synthesis
  *               (Ecp5BlockRam), the same behavioural model for simulation
  * @param raddrAhead `raddr` is the read address a cycle ahead, registered here: with ecp5, in a kept register per
  *               primitive beside it (so that the address's route across the device is split by a register, and
  *               synthesis does not merge the copies); the read's timing from that register is as without it
  * @param broadcast every write carries one word for all its lanes (wdata is lane 0's word repeated): with ecp5,
  *               the write data's first register is one lane wide and its second copies it to every lane, so the
  *               word's source drives one register per memory, not one per lane
  */
class InitRam(
    val ramName: String,
    val depth: Int,
    val lanes: Int,
    val laneW: Int,
    init: Seq[Seq[BigInt]],
    val outReg: Boolean = false,
    val ecp5: Boolean = false,
    val raddrAhead: Boolean = false,
    val broadcast: Boolean = false)
    extends BlackBox
    with HasBlackBoxInline {
  require(depth >= 1 && lanes >= 1 && laneW >= 1, s"InitRam $ramName: depth, lanes, laneW must be >= 1")
  require(init.length <= depth, s"InitRam $ramName: ${init.length} init rows for depth $depth")
  val addrW: Int = math.max(1, log2Ceil(depth))
  val rowW:  Int = lanes * laneW
  override def desiredName = ramName

  val io = IO(new Bundle {
    val clock = Input(Clock())
    val raddr = Input(UInt(addrW.W))
    val rdata = Output(UInt(rowW.W))
    val wen   = Input(Bool())
    val waddr = Input(UInt(addrW.W))
    val wmask = Input(UInt(lanes.W))
    val wdata = Input(UInt(rowW.W))
  })

  private def rowHex(row: Seq[BigInt]): String = {
    require(row.length == lanes, s"InitRam $ramName: row of ${row.length} lanes, expected $lanes")
    val mask = (BigInt(1) << laneW) - 1
    val bits = row.zipWithIndex.foldLeft(BigInt(0)) { case (acc, (v, i)) =>
      require(v >= -(BigInt(1) << (laneW - 1)) && v < (BigInt(1) << (laneW - 1)),
        s"InitRam $ramName: value $v does not fit $laneW signed bits")
      acc | ((v & mask) << (i * laneW))
    }
    s"$rowW'h${bits.toString(16)}"
  }

  private val initLines = init.zipWithIndex.map { case (row, i) => s"    mem[$i] = ${rowHex(row)};" }
  private val zeroLines =
    if (init.length < depth) Seq(s"    for (i = ${init.length}; i < $depth; i = i + 1) mem[i] = {$rowW{1'b0}};")
    else Seq()

  /** the rows as unsigned row words (lane i in bits [i laneW, (i + 1) laneW)) */
  private def rowBits(row: Seq[BigInt]): BigInt = {
    val mask = (BigInt(1) << laneW) - 1
    row.zipWithIndex.foldLeft(BigInt(0)) { case (acc, (v, i)) => acc | ((v & mask) << (i * laneW)) }
  }
  val primitive: Boolean = ecp5 && outReg && Ecp5BlockRam.fits(depth)

  // raddrAhead: the registered address, of the behavioural model (ra) and of each primitive (ra_<primitive>)
  private val blocks = for (l <- 0 until lanes; s <- 0 until Ecp5BlockRam.slices(laneW)) yield Ecp5BlockRam.name(l, s)
  private def raddrOf(block: String): String = if (raddrAhead) s"ra_$block" else "raddr"
  private val raddrSim = if (raddrAhead) "ra" else "raddr"
  private def aheadDecl(perBlock: Boolean): String = if (!raddrAhead) "" else {
    val copies = if (perBlock) blocks.map(b => s"ra_$b") else Nil
    (s"  reg [${addrW - 1}:0] ra;\n  always @(posedge clock) ra <= raddr;" +:
      copies.map(r => s"  reg [${addrW - 1}:0] $r;\n  (* keep *) always @(posedge clock) $r <= raddr;")).mkString("\n")
  }

  if (primitive) setInline(
    s"$ramName.sv",
    s"""// Initialised RAM: 1 synchronous read port (read-first), 1 lane-masked write port, read latency 2; on ECP5
       |// DP16KD block RAMs with their output register (mem.Ecp5BlockRam), in simulation a behavioural model. The
       |// write port passes two registers (a write lands two cycles later): the block RAM inputs start at registers,
       |// and the route from the write's decode to blocks across the device has a register halfway. The registers
       |// are kept (not merged by synthesis with the equal ones of memories written together), so that each
       |// memory's write port has its own, placed near its blocks.
       |module $ramName (
       |  input                  clock,
       |  input      [${addrW - 1}:0] raddr,
       |  output     [${rowW - 1}:0] rdata,
       |  input                  wen,
       |  input      [${addrW - 1}:0] waddr,
       |  input      [${lanes - 1}:0] wmask,
       |  input      [${rowW - 1}:0] wdata
       |);
${aheadDecl(true)}
       |  reg wen_p, wen_q;
       |  reg [${addrW - 1}:0] waddr_p, waddr_q;
       |  reg [${lanes - 1}:0] wmask_p, wmask_q;
       |  reg [${(if (broadcast) laneW else rowW) - 1}:0] wdata_p;
       |  reg [${rowW - 1}:0] wdata_q;
       |  (* keep *) always @(posedge clock) begin
       |    wen_p <= wen;
       |    waddr_p <= waddr;
       |    wmask_p <= wmask;
       |    wdata_p <= ${if (broadcast) s"wdata[${laneW - 1}:0]" else "wdata"};
       |    wen_q <= wen_p;
       |    waddr_q <= waddr_p;
       |    wmask_q <= wmask_p;
       |    wdata_q <= ${if (broadcast) s"{$lanes{wdata_p}}" else "wdata_p"};
       |  end
       |`ifdef SYNTHESIS
       |${Ecp5BlockRam.primitives(addrW, lanes, laneW, init.map(rowBits), depth, (l, sl) => raddrOf(Ecp5BlockRam.name(l, sl)))}
       |`else
       |  reg [${rowW - 1}:0] mem [0:${depth - 1}];
       |  reg [${rowW - 1}:0] rd, rq;
       |  integer i;
       |  initial begin
       |${(initLines ++ zeroLines).mkString("\n")}
       |  end
       |  always @(posedge clock) begin
       |    for (i = 0; i < $lanes; i = i + 1)
       |      if (wen_q && wmask_q[i]) mem[waddr_q][i*$laneW +: $laneW] <= wdata_q[i*$laneW +: $laneW];
       |    rd <= mem[$raddrSim];
       |    rq <= rd;
       |  end
       |  assign rdata = rq;
       |`endif
       |endmodule
       |""".stripMargin
  ) else setInline(
    s"$ramName.sv",
    s"""// Initialised RAM: 1 synchronous read port (read-first), 1 lane-masked write port.
       |module $ramName (
       |  input                  clock,
       |  input      [${addrW - 1}:0] raddr,
       |  output reg [${rowW - 1}:0] rdata,
       |  input                  wen,
       |  input      [${addrW - 1}:0] waddr,
       |  input      [${lanes - 1}:0] wmask,
       |  input      [${rowW - 1}:0] wdata
       |);
       |  reg [${rowW - 1}:0] mem [0:${depth - 1}];
       |  reg [${rowW - 1}:0] rd;
       |${aheadDecl(false)}
       |  integer i;
       |  initial begin
       |${(initLines ++ zeroLines).mkString("\n")}
       |  end
       |  always @(posedge clock) begin
       |    for (i = 0; i < $lanes; i = i + 1)
       |      if (wen && wmask[i]) mem[waddr][i*$laneW +: $laneW] <= wdata[i*$laneW +: $laneW];
       |    rd <= mem[$raddrSim];
       |    ${if (outReg) "rdata <= rd;" else ""}
       |  end
       |  ${if (outReg) "" else "always @(*) rdata = rd;"}
       |endmodule
       |""".stripMargin
  )
}
