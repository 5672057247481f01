package dsp

import chisel3._
import chisel3.util.HasBlackBoxInline

/** One ECP5 MULT18X18D, 18 x 18 signed (or unsigned: `signed` false, SIGNEDA = SIGNEDB = 0), with its input (A,
  * B), pipeline and output registers on: p = a * b three cycles after a and b (the words as bits). Synthesis (Yosys defines SYNTHESIS) sees the primitive; simulation (Verilator) sees a
  * cycle-exact model with the same three registers. The registers use CLK0, CE0 (tied high) and RST0 (tied low,
  * synchronous reset mode); GSR is off, so they hold data, like the fabric pipeline registers they replace.
  *
  * The wrapper keeps its hierarchy in Yosys: flattened, the primitive's parameterised cell lands in a module that
  * Yosys's final `hierarchy` pass re-elaborates from its source, undoing the flattening (and the wrapper it then
  * refers to is gone). Kept, only the wrapper is re-elaborated, which yields the same primitive; nextpnr flattens.
  */
class Ecp5Mult18(signed: Boolean = true) extends BlackBox with HasBlackBoxInline {
  val io = IO(new Bundle {
    val clk = Input(Clock())
    val a   = Input(UInt(18.W))
    val b   = Input(UInt(18.W))
    val p   = Output(UInt(36.W))
  })
  override def desiredName = Ecp5Mult18.module(signed)
  setInline(s"${Ecp5Mult18.module(signed)}.v", Ecp5Mult18.verilog(signed))
}

object Ecp5Mult18 {
  def module(signed: Boolean): String = "mpc_ecp5_mult18x18" + (if (signed) "" else "u")

  private def bus(port: String, sig: String, n: Int) = (0 until n).map(i => s".$port$i($sig[$i])")
  private def tie(port: String, n: Int, v: String) = (0 until n).map(i => s".$port$i($v)")

  private val regs = Seq("INPUTA", "INPUTB", "PIPELINE", "OUTPUT").flatMap { r =>
    Seq(s""".REG_${r}_CLK("CLK0")""", s""".REG_${r}_CE("CE0")""", s""".REG_${r}_RST("RST0")""")
  }
  private val params = regs ++ Seq(""".GSR("DISABLED")""", """.RESETMODE("SYNC")""")
  private def ports(signed: Boolean) = bus("A", "a", 18) ++ bus("B", "b", 18) ++ tie("C", 18, "1'b0") ++
    Seq(s".SIGNEDA(1'b${if (signed) 1 else 0})", s".SIGNEDB(1'b${if (signed) 1 else 0})", ".SOURCEA(1'b0)", ".SOURCEB(1'b0)", ".CLK0(clk)", ".CLK1(1'b0)",
      ".CLK2(1'b0)", ".CLK3(1'b0)", ".CE0(1'b1)", ".CE1(1'b0)", ".CE2(1'b0)", ".CE3(1'b0)", ".RST0(1'b0)",
      ".RST1(1'b0)", ".RST2(1'b0)", ".RST3(1'b0)") ++ bus("P", "p", 36)

  def verilog(signed: Boolean): String = {
    val (kind, sg) = if (signed) ("signed", "signed ") else ("unsigned", "")
    s"""// ECP5 MULT18X18D with input, pipeline and output registers: p = a * b ($kind) three cycles later.
       |(* keep_hierarchy *)
       |module ${module(signed)} (
       |  input         clk,
       |  input  [17:0] a,
       |  input  [17:0] b,
       |  output [35:0] p
       |);
       |`ifdef SYNTHESIS
       |  MULT18X18D #(
       |    ${params.mkString(",\n    ")}
       |  ) dsp (
       |    ${ports(signed).grouped(6).map(_.mkString(", ")).mkString(",\n    ")}
       |  );
       |`else
       |  reg $sg[17:0] ra, rb;
       |  reg $sg[35:0] rm, rp;
       |  always @(posedge clk) begin
       |    ra <= a;
       |    rb <= b;
       |    rm <= ra * rb;
       |    rp <= rm;
       |  end
       |  assign p = rp;
       |`endif
       |endmodule
       |""".stripMargin
  }
}
