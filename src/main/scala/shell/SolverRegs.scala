package shell

import chisel3._
import chisel3.util._
import bus.{AxiLiteIO, AxiLiteResp, AxiLiteSlave}
import fixed.FixedOps

/** Register word addresses shared by the solver cores (byte address = 4 x word address), their descriptions for
  * hw.json, and the placement of the data regions above them.
  */
object SolverRegs {
  val ID              = 0
  val CONFIG0         = 1
  val CONFIG1         = 2
  val CTRL            = 3
  val IMAX            = 4
  val STATUS          = 5
  val SOLVES          = 6
  val LAST_CYCLES     = 7
  val CYCLES_PER_ITER = 8
  /** First core-specific register; every address from here on reads as DECERR (the data are write-only). */
  val FirstCoreReg = 9
  /** Data regions start at this word address. */
  val RegionStart = 16

  /** (name, word offset, access, description) of the shared registers; `config` describes CONFIG0/1. */
  def descriptions(idText: String, config0: String, config1: String, what: String): Seq[(String, Int, String, String)] =
    Seq(
      ("ID", ID, "RO", idText),
      ("CONFIG0", CONFIG0, "RO", config0),
      ("CONFIG1", CONFIG1, "RO", config1),
      ("CTRL", CTRL, "RW", s"[0] WARM_START, [1] HOLD (finish the current solve, accept no new frame), [2] OUT_ALL (stream all n words of z, else $what)"),
      ("IMAX", IMAX, "RW", "iterations per solve, 1..65535 (writing 0 or more than 65535: SLVERR, ignored); latched at the start of each solve"),
      ("STATUS", STATUS, "RO/W1C", "[0] BUSY, [1] SAT (a parameter word was outside its box and saturated), [2] OVERFLOW (a datapath word saturated), [3] WRITE_REJECTED, [4] TLAST_ERROR, [5] WARM_VALID; write 1 to clear bits 1-4"),
      ("SOLVES", SOLVES, "RO", "solves completed since reset"),
      ("LAST_CYCLES", LAST_CYCLES, "RO", "cycles of the last solve, first pass to last iteration"),
      ("CYCLES_PER_ITER", CYCLES_PER_ITER, "RO", "cycles per iteration")
    )

  private def pow2(x: Int): Int = 1 << log2Ceil(math.max(1, x))

  /** Regions of the given word counts, each rounded up to a power of two and aligned to its size (largest first,
    * from RegionStart), so that a region's offset bits are the low address bits. Returns (size, base) per name
    * and the number of words of the map.
    */
  def layout(words: Seq[(String, Int)]): (Seq[(String, Int)], Map[String, Int], Int) = {
    val sizes = words.map { case (nm, w) => nm -> pow2(w) }
    var cur   = RegionStart
    val base = sizes.sortBy(-_._2).map { case (nm, sz) =>
      val b = ((cur + sz - 1) / sz) * sz
      cur = b + sz
      nm -> b
    }.toMap
    (sizes, base, sizes.map { case (nm, sz) => base(nm) + sz }.max)
  }
}

/** The control and status registers of a solver core and its AXI4-Lite register file, built inside the core's
  * module. The core drives `busy` and the status pulses; it adds its data regions through `writes`.
  *
  * Rules common to the cores: the data memories are write-only; a data write while busy gets SLVERR and sets
  * WRITE_REJECTED, a value that does not fit its word gets SLVERR, an unmapped address DECERR.
  */
class SolverRegs(
    s_axil: AxiLiteIO,
    idValue: Long,
    config0: UInt,
    config1: UInt,
    cyclesPerIteration: Int,
    imaxDefault: Int,
    warmDefault: Boolean,
    outAllDefault: Boolean) {
  import SolverRegs._

  val ctrlWarm   = RegInit(warmDefault.B)
  val ctrlHold   = RegInit(false.B)
  val ctrlOutAll = RegInit(outAllDefault.B)
  val imaxReg    = RegInit(imaxDefault.U(16.W))
  val stSat      = RegInit(false.B)
  val stOvf      = RegInit(false.B)
  val stRej      = RegInit(false.B)
  val stTlast    = RegInit(false.B)
  val warmValid  = RegInit(false.B)
  val solves     = RegInit(0.U(32.W))
  val lastCycles = RegInit(0.U(32.W))
  /** driven by the core: a frame is arriving (the handshake of its words included), a solve runs or results wait */
  val busy = Wire(Bool())
  /** `busy` a cycle later: the data-write rules and STATUS use it, so the write decode starts at a flip-flop. It is
    * high wherever `busy` is (a solve only begins with an input word's handshake, which `busy` covers) and for one
    * cycle after. */
  val busyR = RegNext(busy, false.B)

  /** A solve finished after `cycles` cycles: count it and validate the warm start. */
  def solveDone(cycles: UInt): Unit = {
    solves     := solves + 1.U
    lastCycles := cycles
    warmValid  := true.B
  }

  val axil = Module(new AxiLiteSlave(s_axil.addrW))
  axil.axi <> s_axil

  // ---- reads
  private val rdA = axil.rd.addr
  axil.rd.resp := AxiLiteResp.OKAY
  axil.rd.data := 0.U
  switch(rdA) {
    is(ID.U) { axil.rd.data := idValue.U }
    is(CONFIG0.U) { axil.rd.data := config0 }
    is(CONFIG1.U) { axil.rd.data := config1 }
    is(CTRL.U) { axil.rd.data := Cat(ctrlOutAll, ctrlHold, ctrlWarm) }
    is(IMAX.U) { axil.rd.data := imaxReg }
    is(STATUS.U) { axil.rd.data := Cat(warmValid, stTlast, stRej, stOvf, stSat, busyR) }
    is(SOLVES.U) { axil.rd.data := solves }
    is(LAST_CYCLES.U) { axil.rd.data := lastCycles }
    is(CYCLES_PER_ITER.U) { axil.rd.data := cyclesPerIteration.U }
  }
  when(rdA >= FirstCoreReg.U) { axil.rd.resp := AxiLiteResp.DECERR }

  // ---- writes
  val wA   = axil.wr.addr
  val wD   = axil.wr.data
  val wSig = wD.asSInt
  axil.wr.resp := AxiLiteResp.OKAY

  def fitsS(w: Int): Bool = wSig >= FixedOps.minOf(w).S(32.W) && wSig <= FixedOps.maxOf(w).S(32.W)
  def inRegion(base: Int, size: Int): Bool = wA >= base.U && wA < (base + size).U

  /** A write into a data memory: refused while busy, at an address `ok` rejects, or when the value does not fit
    * `fitW` signed bits; otherwise `body` runs in the cycle of the write.
    */
  def dataWrite(fitW: Int, ok: Bool)(body: => Unit): Unit = {
    when(busyR) {
      axil.wr.resp := AxiLiteResp.SLVERR
      when(axil.wr.valid) { stRej := true.B }
    }.elsewhen(!ok) {
      axil.wr.resp := AxiLiteResp.DECERR
    }.elsewhen(!fitsS(fitW)) {
      axil.wr.resp := AxiLiteResp.SLVERR
      when(axil.wr.valid) { stRej := true.B }
    }.otherwise {
      when(axil.wr.valid) { body }
    }
  }

  /** Decode the shared registers, then the core's (condition, action) cases in order; anything else is DECERR. */
  def writes(cases: (Bool, () => Unit)*): Unit = {
    val shared = when(wA === CTRL.U) {
      when(axil.wr.valid) {
        ctrlWarm   := wD(0)
        ctrlHold   := wD(1)
        ctrlOutAll := wD(2)
      }
    }.elsewhen(wA === IMAX.U) {
      when(wD === 0.U || wD > 65535.U) {
        axil.wr.resp := AxiLiteResp.SLVERR
      }.elsewhen(axil.wr.valid) { imaxReg := wD }
    }.elsewhen(wA === STATUS.U) {
      when(axil.wr.valid) {
        when(wD(1)) { stSat := false.B }
        when(wD(2)) { stOvf := false.B }
        when(wD(3)) { stRej := false.B }
        when(wD(4)) { stTlast := false.B }
      }
    }
    cases.foldLeft(shared) { case (ctx, (cond, body)) => ctx.elsewhen(cond)(body()) }.otherwise {
      axil.wr.resp := AxiLiteResp.DECERR
    }
  }
}
