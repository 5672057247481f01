package dgp

import chisel3._
import mem.KeepReg

/** The DGP core's per-unit vector plumbing: flat views of the units' FIFOs, their rotation by groups of rows, the
  * kept copies of a control per unit and per group of rows, and the registered reduction over the units. */
trait DgpUnitOps {
  /** row units */
  def P: Int
  /** per unit, FPGA target, P > 1: kept copies per unit */
  def split: Boolean
  /** an FPGA target: kept copies per group of rows */
  def fpga: Boolean

  /** flat views: row i is unit i mod P's element i / P */
  def flat(f: Seq[Vec[SInt]], len: Int): Seq[SInt] = (0 until len).map(i => f(i % P)(i / P))
  /** rows per group of a FIFO that takes its enables from copies of its own */
  val rowGroup = 8
  def groups(len: Int): Int = (len + rowGroup - 1) / rowGroup
  /** one step of a rotating FIFO: the head leaves, `in` enters at the tail; each group of rowGroup rows where its
    * enable (`en`, one per group) is high */
  def rotate(q: Vec[SInt], in: SInt, en: Seq[Bool]): Unit =
    for (i <- 0 until q.length) when(en(i / rowGroup)) { q(i) := (if (i + 1 < q.length) q(i + 1) else in) }
  /** per unit, `d` registered: a kept copy each when split, else one register for all */
  def unitRegs[T <: Data](d: T): Seq[T] = KeepReg.copies(d, P, split)
  /** per unit and group of rows of a FIFO of `len`, `x` (a unit's register) registered once more: kept copies per
    * group (FPGA targets), so that no register drives a whole vector */
  def groupRegs(x: Seq[Bool], len: Int): Seq[Seq[Bool]] =
    x.map(r => if (fpga) Seq.fill(groups(len))(KeepReg(r)) else Seq.fill(groups(len))(RegNext(r, false.B)))
  /** the units' values added (or ORed) in registered levels of two */
  def reduce[T <: Data](xs: Seq[T], f: (T, T) => T): T =
    if (xs.length == 1) xs.head else reduce(xs.grouped(2).map(g => RegNext(if (g.length == 2) f(g(0), g(1)) else g(0))).toSeq, f)
}
