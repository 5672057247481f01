package dgp

import chisel3._
import chisel3.util._

/** The DGP core's constant tables, laid out as the sequencer and the row units read them: the issue slots' bits
  * (DgpParams.slots with the pass ends), and per unit the bounds' constant parts, the dual box and the shifted warm
  * start's live words by round; the shifted warm start's word of a row. */
class DgpLayout(p: DgpParams) {
  import p.{mc, rK, rG}
  private val P = p.units
  private val W = p.dataW

  // ---- issue slots
  val chunkW: Int = log2Ceil(Seq(p.cF, p.cK, p.cG).max + 1)
  /** the slots that end a pass: the last of the first pass, of pass K and of pass G */
  private val passEnds = Set(p.baseK - 1, p.baseG - 1, p.matRows - 1)
  /** per slot: its chunk, whether it is its round's first and last, whether it ends its pass */
  val slotBits: Seq[(Int, Boolean, Boolean, Boolean)] =
    p.slots.zipWithIndex.map { case ((c, f, l), a) => (c, f, l, passEnds(a)) }
  /** a slot's bits (past the last: a lone chunk 0 that ends its pass) */
  def bitsOf(a: Int): UInt = {
    val (c, f, l, e) = slotBits.lift(a).getOrElse((0, true, true, true))
    Cat(c.U(chunkW.W), f.B, l.B, e.B)
  }

  // ---- per unit, by round: the first pass's rounds rK.. are the bounds' rows, pass G's rounds the dual rows
  def lo0U: Seq[Vec[SInt]] = (0 until P).map(u => VecInit((0 until rK + rG).map(k => p.ofUnit(p.lo0, u, k - rK).S(W.W))))
  def hi0U: Seq[Vec[SInt]] = (0 until P).map(u => VecInit((0 until rK + rG).map(k => p.ofUnit(p.hi0, u, k - rK).S(W.W))))
  private def udHalf(h: Int) = p.ud.slice(h * mc, (h + 1) * mc)
  /** the dual box by pass G's round, per half and unit */
  def udU: Seq[Seq[Vec[SInt]]] =
    Seq.tabulate(2, P)((h, u) => VecInit((0 until rG).map(k => p.ofUnit(udHalf(h), u, k).S(W.W))))
  /** the dual box by the first pass's round (a zero start's element stage) */
  def udZ: Seq[Seq[Vec[SInt]]] =
    Seq.tabulate(2, P)((h, u) => VecInit((0 until rK + rG).map(k => p.ofUnit(udHalf(h), u, k - rK).S(W.W))))
  private def liveOf(h: Int, u: Int, k: Int): Bool = (k >= 0 && k * P + u < mc && p.shiftLive(h * mc + k * P + u)).B
  /** the shifted warm start: per half and unit, whether a row's word is live (p.shiftLive) by pass G's round */
  def liveU: Seq[Seq[Vec[Bool]]] =
    if (p.shift) Seq.tabulate(2, P)((h, u) => VecInit((0 until rG).map(k => liveOf(h, u, k)))) else Nil
  /** the same by the first pass's round (a zero start's element stage) */
  def liveZ: Seq[Seq[Vec[Bool]]] =
    if (p.shift) Seq.tabulate(2, P)((h, u) => VecInit((0 until rK + rG).map(k => liveOf(h, u, k - rK)))) else Nil

  /** the shifted warm start's word of half h, unit u, element k (row k P + u): the previous final dual's word at
    * its shift source (y, per half, unit and element), clipped to the row's dual box where the source's box is
    * wider (else it lies in it already), or zero */
  def shifted(y: Seq[Seq[Vec[SInt]]], h: Int, u: Int, k: Int): SInt = {
    val i = h * mc + k * P + u
    val src = if (k * P + u < mc) p.shiftSrc(i) else -1
    if (src < 0) 0.S(W.W)
    else {
      val x = y(src / mc)(src % mc % P)(src % mc / P)
      if (p.ud(i) < p.ud(src)) Mux(x > p.ud(i).S(W.W), p.ud(i).S(W.W), x) else x
    }
  }
}
