package ipm

import chisel3.util.log2Ceil
import float.FloatFormat

/** Everything the Stage 1 generator needs (mpc_cores/ipm/stage1_config.py writes it): the float format, the
  * problem slots and the words of each slot's private region, the constant region (raw words), the index tables,
  * the programs (encoded instruction words, in order; program k starts where k-1 ends) and the latencies of the
  * float operators. Every instruction is checked here: a destination in slot space, operands and destinations
  * inside their region (gather and scatter through the table's first n entries), tables that exist, ACC longer
  * than lat_add (the streaming accumulator's partial sums). `target` (dsp.Target): ecp5 builds the slot memory
  * from DP16KD primitives with their output register (SlotMem); the words and cycles are those of every target.
  *
  * `constBanks` (the multiplexed interior-point core): the constant region is that many banks of the same layout,
  * one per channel's problem, and slot s reads bank s mod constBanks (constant addresses are within a bank).
  */
case class Stage1Params(
    name: String,
    fmt: FloatFormat,
    slots: Int,
    slotWords: Int,
    constWords: Seq[BigInt],
    tables: Seq[Seq[Int]],
    programs: Seq[(String, Seq[BigInt])],
    latAdd: Int,
    latMul: Int,
    latDiv: Int,
    latSqrt: Int,
    latCmp: Int,
    target: dsp.Target = dsp.Target.Generic,
    constBanks: Int = 1) {
  import Isa._

  require(fmt.width <= 32, s"the stream words are 32 bits: the format must fit them: got width ${fmt.width}")
  require(slots >= 1 && slots <= 256, s"slots must be in [1, 256]: got $slots")
  require(slotWords >= 1 && slots * slotWords <= (1 << 20),
    s"slot_words must be >= 1 and slots * slot_words <= 2^20: got $slotWords words x $slots slots")
  require(constWords.nonEmpty && constWords.length <= (1 << AddrW), s"const words must be 1 .. 2^16: got ${constWords.length}")
  require(constWords.forall(w => w >= 0 && w < (BigInt(1) << fmt.width)), s"const words must be raw ${fmt.width}-bit words")
  require(tables.length <= (1 << TableW), s"at most ${1 << TableW} index tables: got ${tables.length}")
  require(tables.flatten.forall(v => v >= 0 && v < (1 << AddrW)), "table entries must be in [0, 2^16)")
  require(programs.nonEmpty && programs.forall(_._2.nonEmpty), "need at least one program, each of one instruction or more")
  require(latAdd >= 1, s"lat_add must be >= 1 (the streaming accumulator feeds the adder's output back): got $latAdd")
  float.FMul.checkLatency(fmt, target, latMul, "lat_mul")
  require(latMul >= 0 && latDiv >= 0 && latSqrt >= 0 && latCmp >= 0,
    s"latencies must be >= 0: got lat_mul=$latMul, lat_div=$latDiv, lat_sqrt=$latSqrt, lat_cmp=$latCmp")

  val code: Seq[BigInt]  = programs.flatMap(_._2)
  val instrs: Seq[Instr] = code.map(decode)
  require(programs.forall(_._2.nonEmpty),
    s"Stage 1 programs must not be empty: ${programs.filter(_._2.isEmpty).map(_._1).mkString(", ")}")
  val entries: Seq[Int]  = programs.map(_._2.length).scanLeft(0)(_ + _)
  require(constBanks >= 1 && constWords.length % constBanks == 0,
    s"const_banks must divide the ${constWords.length} const words: got $constBanks")
  /** the words of one bank of the constant region (the programs' constant addresses are within it) */
  val constLen: Int      = constWords.length / constBanks

  /** the streaming accumulator's latency: lat_add + 1 + lat_add ceil(log2 lat_add) (minres.FStreamAcc) */
  val latAcc: Int = latAdd + 1 + latAdd * log2Ceil(latAdd)

  /** cycles from an element entering its unit to its result written; mpc_cores.ipm.isa.latency */
  def latency(op: Int): Int = op match {
    case ADD | SUB            => latAdd
    case MUL                  => latMul
    case DIV                  => latDiv
    case SQRT                 => latSqrt
    case MOV                  => 1
    case MINRED               => 2
    case MIN | MAX | SELNEG   => latCmp
    case ACC                  => latAcc
    case IN | OUT             => 0
  }

  /** cycles of an instruction without stream stalls: n elements, the unit's latency, the issue gap */
  def cycles(i: Instr): Int = i.n + latency(i.op) + Stage1Params.IssueGap
  val programCycles: Seq[Int] = programs.map(p => Stage1Params.ProgramStart + p._2.map(w => cycles(decode(w))).sum)

  private def size(space: Int): Int = if (space == SLOT) slotWords else constLen

  /** the words an operand reaches over n elements (offsets from the region's start) */
  private def span(o: Operand, n: Int, what: String, k: Int): Seq[Int] = {
    require(o.mode <= GATHER, s"instruction $k: $what has mode ${o.mode}")
    o.mode match {
      case VEC    => Seq(o.addr, o.addr + n - 1)
      case SCALAR => Seq(o.addr)
      case GATHER =>
        require(o.table < tables.length, s"instruction $k: $what uses table ${o.table} of ${tables.length}")
        require(n <= tables(o.table).length, s"instruction $k: $what gathers $n words through table ${o.table} of ${tables(o.table).length}")
        tables(o.table).take(n).map(o.addr + _)
    }
  }

  for ((i, k) <- instrs.zipWithIndex) {
    require(i.op < ops.length, s"instruction $k: op code ${i.op}")
    require(i.n >= 1, s"instruction $k: n must be >= 1")
    if (i.op == ACC) require(i.n > latAdd, s"instruction $k: ACC needs more than lat_add=$latAdd terms: got n=${i.n}")
    def check(o: Operand, n: Int, what: String): Unit =
      span(o, n, what, k).foreach(a => require(a < size(o.space), s"instruction $k (${i.name}): $what reaches word $a of ${size(o.space)}"))
    if (i.writes) {
      require(i.d.space == SLOT, s"instruction $k (${i.name}): the destination must be in slot space")
      val mode = if (i.d.mode == SCALAR) VEC else i.d.mode  // a scalar destination is written as a vector
      check(i.d.copy(mode = mode), if (i.reduction) 1 else i.n, "destination")
    }
    if (i.readsA) check(i.a, i.n, "operand a")
    if (i.readsB) check(i.b, i.n, "operand b")
  }

  // ---- what the engine needs: table ROMs per role, constant ROMs per role, the second slot copy, accumulators
  val gatherD: Boolean = instrs.exists(i => i.writes && i.d.mode == GATHER)
  val gatherA: Boolean = instrs.exists(i => i.readsA && i.a.mode == GATHER)
  val gatherB: Boolean = instrs.exists(i => i.readsB && i.b.mode == GATHER)
  val constA: Boolean  = instrs.exists(i => i.readsA && i.a.space == CONST)
  val constB: Boolean  = instrs.exists(i => i.readsB && i.b.space == CONST)
  val slotB: Boolean   = instrs.exists(i => i.readsB && i.b.space == SLOT)
  /** one streaming accumulator per ACC length (minres.FStreamAcc has its length built in) */
  val accLengths: Seq[Int] = instrs.filter(_.op == ACC).map(_.n).distinct.sorted

  val tableBase: Seq[Int]   = tables.map(_.length).scanLeft(0)(_ + _)
  val tableWords: Seq[Int]  = tables.flatten
  val tableW: Int           = math.max(1, log2Ceil((tableWords :+ 1).max + 1))
  val slotMemWords: Int     = slots * slotWords
  val memAddrW: Int         = math.max(1, log2Ceil(slotMemWords))
  val constAddrW: Int       = math.max(1, log2Ceil(constWords.length))
  val progW: Int            = math.max(1, log2Ceil(programs.length))
  val slotW: Int            = math.max(1, log2Ceil(slots))
  val pcW: Int              = log2Ceil(code.length + 1)
  val maxTap: Int           = Seq(latAdd, latMul, latDiv, latSqrt, latCmp, 1).max

  val moduleName: String =
    s"Stage1Engine_${name}_s$slots" + (if (target == dsp.Target.Generic) "" else s"_${target.name}")
}

object Stage1Params {
  /** cycles an instruction adds beyond its n elements and its unit's latency: Stage1Engine's table register (G),
    * address register (M), memory read (A), memory word registers (R, Q), operand select register (S) and the
    * units' operand registers (D), less the write that overlaps the next instruction's launch */
  val IssueGap = 7
  /** cycles a program adds beyond its instructions: its first instruction word is decoded into a register */
  val ProgramStart = 1

  def fromJson(text: String): Stage1Params = {
    val j = ujson.read(text)
    require(j("core").str == "ipm_stage1", s"not a Stage 1 configuration: core=${j("core").str}")
    def big(v: ujson.Value): BigInt = v match {
      case ujson.Str(s) if s.startsWith("0x") => BigInt(s.drop(2), 16)
      case ujson.Str(s)                       => BigInt(s)
      case n                                  => BigInt(n.num.toLong)
    }
    Stage1Params(
      name = j("name").str,
      fmt = FloatFormat(j("exp_w").num.toInt, j("man_w").num.toInt),
      slots = j("slots").num.toInt,
      slotWords = j("slot_words").num.toInt,
      constWords = j("const").arr.toSeq.map(big),
      tables = j("tables").arr.toSeq.map(_.arr.toSeq.map(_.num.toInt)),
      programs = j("programs").arr.toSeq.map(p => p("name").str -> p("code").arr.toSeq.map(big)),
      latAdd = j("lat_add").num.toInt,
      latMul = j("lat_mul").num.toInt,
      latDiv = j("lat_div").num.toInt,
      latSqrt = j("lat_sqrt").num.toInt,
      latCmp = j("lat_cmp").num.toInt,
      target = dsp.Target(j.obj.get("target").map(_.str).getOrElse("generic")),
      constBanks = j.obj.get("const_banks").map(_.num.toInt).getOrElse(1)
    )
  }
}
