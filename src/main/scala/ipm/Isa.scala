package ipm

import chisel3._

/** The Stage 1 instruction set of mpc_cores/ipm/isa.py: op codes, operand modes and the instruction word
  * (op [3:0], n [19:4], then the operands d, a, b of 22 bits each: space [0], mode [2:1], addr [18:3],
  * table [21:19]). `Isa.decode` takes a word apart at elaboration (checks, latencies, which ROMs are needed);
  * `InstrBits.decode` in hardware.
  */
object Isa {
  val ops: Seq[String] = Seq("ADD", "SUB", "MUL", "DIV", "SQRT", "MOV", "MIN", "MAX", "SELNEG", "ACC", "MINRED",
    "IN", "OUT")
  val ADD = 0; val SUB = 1; val MUL = 2; val DIV = 3; val SQRT = 4; val MOV = 5; val MIN = 6; val MAX = 7
  val SELNEG = 8; val ACC = 9; val MINRED = 10; val IN = 11; val OUT = 12
  val SLOT = 0; val CONST = 1
  val VEC = 0; val SCALAR = 1; val GATHER = 2
  val modes: Seq[String] = Seq("vec", "scalar", "gather")

  val OpW = 4; val NW = 16; val AddrW = 16; val TableW = 3
  val OperandW: Int = 1 + 2 + AddrW + TableW
  val InstrW: Int   = OpW + NW + 3 * OperandW

  case class Operand(space: Int, mode: Int, addr: Int, table: Int)
  case class Instr(op: Int, n: Int, d: Operand, a: Operand, b: Operand) {
    def name: String = ops(op)
    /** the operands the instruction reads and writes */
    def readsA: Boolean = op != IN
    def readsB: Boolean = Seq(ADD, SUB, MUL, DIV, MIN, MAX, SELNEG).contains(op)
    def writes: Boolean = op != OUT
    def reduction: Boolean = op == ACC || op == MINRED
  }

  private def field(w: BigInt, lsb: Int, width: Int): Int = ((w >> lsb) & ((BigInt(1) << width) - 1)).toInt

  private def operand(w: BigInt, k: Int): Operand = {
    val o = OpW + NW + k * OperandW
    Operand(field(w, o, 1), field(w, o + 1, 2), field(w, o + 3, AddrW), field(w, o + 3 + AddrW, TableW))
  }

  def decode(w: BigInt): Instr = {
    require(w >= 0 && w < (BigInt(1) << InstrW), s"instruction word $w outside $InstrW bits")
    Instr(field(w, 0, OpW), field(w, OpW, NW), operand(w, 0), operand(w, 1), operand(w, 2))
  }
}

class OperandBits extends Bundle {
  val space = UInt(1.W)
  val mode  = UInt(2.W)
  val addr  = UInt(Isa.AddrW.W)
  val table = UInt(Isa.TableW.W)
  def inConst: Bool  = space === Isa.CONST.U
  def isGather: Bool = mode === Isa.GATHER.U
  def isVec: Bool    = mode === Isa.VEC.U
}

class InstrBits extends Bundle {
  val op = UInt(Isa.OpW.W)
  val n  = UInt(Isa.NW.W)
  val d  = new OperandBits
  val a  = new OperandBits
  val b  = new OperandBits
  def is(codes: Int*): Bool = codes.map(c => op === c.U).reduce(_ || _)
}

object InstrBits {
  private def operand(w: UInt, k: Int): OperandBits = {
    val o = Isa.OpW + Isa.NW + k * Isa.OperandW
    val r = Wire(new OperandBits)
    r.space := w(o)
    r.mode  := w(o + 2, o + 1)
    r.addr  := w(o + 2 + Isa.AddrW, o + 3)
    r.table := w(o + 2 + Isa.AddrW + Isa.TableW, o + 3 + Isa.AddrW)
    r
  }

  def decode(w: UInt): InstrBits = {
    val r = Wire(new InstrBits)
    r.op := w(Isa.OpW - 1, 0)
    r.n  := w(Isa.OpW + Isa.NW - 1, Isa.OpW)
    r.d  := operand(w, 0)
    r.a  := operand(w, 1)
    r.b  := operand(w, 2)
    r
  }
}
