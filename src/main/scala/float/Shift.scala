package float

import chisel3._
import chisel3.util._

/** Shifters built one level per bit of the shift amount (a move by 2^k per level), each doing a second job on
  * the way: the left normaliser finds the leading-zero count itself, the right shifter gathers the bits it
  * drops into a sticky bit. Both cost about one LUT4 per bit per level, without a separate priority encoder
  * or a double-width shifter for the sticky bit.
  */
object Shift {
  /** (x << n, n) with n the number of leading zeros of a nonzero x, at most `cap` if given. From the widest
    * level down, the value moves up by 2^k when its top 2^k bits are zero (after the wider levels fewer than
    * 2^(k+1) leading zeros remain); `levels` = log2Ceil(maxLz + 1) levels serve an x known to have at most maxLz
    * leading zeros. With a cap, a level also needs bit k of the cap unless the cap has stopped binding: while
    * it binds, the moves made so far are exactly its bits above k; it stops binding at a level whose cap bit is
    * set but whose top bits are not all zero (fewer than 2^k leading zeros remain), or when it is >= 2^levels.
    * x = 0 (without a cap) gives 0 and an all-ones count.
    */
  def normalise(x: UInt, levels: Int, cap: Option[UInt]): (UInt, UInt) = {
    val w = x.getWidth
    require(levels >= 0 && (1 << levels) < 2 * w, s"Shift.normalise: $levels levels for $w bits")
    val (v, _, bits) = normaliseLevels(x, capFree(cap, levels), cap, (levels - 1) to 0 by -1)
    (v, if (bits.isEmpty) 0.U(1.W) else Cat(bits))
  }

  /** Whether a cap stops binding before the first of `levels` levels (it is >= 2^levels); true without a cap. */
  def capFree(cap: Option[UInt], levels: Int): Bool =
    cap.map(c => if (c.getWidth > levels) c >> levels =/= 0.U else false.B).getOrElse(true.B)

  /** The levels `ks` (descending, a contiguous run of normalise's levels) applied to x, the cap's state `free`
    * before them: (x moved, free after them, the move of each level in the order of ks). A pipelined normaliser
    * runs its levels in groups (`groups`), its value, `free` and the moves so far registered between them.
    */
  def normaliseLevels(x: UInt, free0: Bool, cap: Option[UInt], ks: Seq[Int]): (UInt, Bool, Seq[Bool]) =
    if (ks.length > 1) normaliseGroup(x, free0, cap, ks) else normaliseSerial(x, free0, cap, ks)

  /** The levels `ks` (contiguous, descending) at once, the same result as one level after another. Without a cap
    * they move the value by c chunks of 2^ks.last bits, c the number of leading zero chunks among the top
    * 2^ks.length - 1 (the zeros a move shifts in count as zero bits): the greedy levels' binary search for it.
    * With a cap that binds (not `free0`) the levels move min(c, g), g the cap's bits of these levels, and the cap
    * stops binding when g > c. The chunks' zero tests are parallel and one select moves the value, instead of a
    * zero test on each level's moved value. */
  private def normaliseGroup(x: UInt, free0: Bool, cap: Option[UInt], ks: Seq[Int]): (UInt, Bool, Seq[Bool]) = {
    require(ks.zip(ks.tail).forall { case (a, b) => a == b + 1 }, s"levels ${ks.mkString(", ")} not contiguous descending")
    val w      = x.getWidth
    val chunk  = 1 << ks.last
    val chunks = (1 << ks.length) - 1
    val pad    = math.max(0, chunks * chunk - w)
    val xp     = if (pad > 0) Cat(x, 0.U(pad.W)) else x
    val wp     = w + pad
    val zero   = (0 until chunks).map(j => xp(wp - 1 - j * chunk, wp - (j + 1) * chunk) === 0.U)
    // the thermometer c >= i (chunks 0 .. i - 1 zero) and c in binary
    val c      = PopCount((1 to chunks).map(i => zero.take(i).reduce(_ && _)))
    val (m, free) = cap match {
      case None     => (c, free0)
      case Some(cp) =>
        val g = Cat(ks.map(k => if (k < cp.getWidth) cp(k) else false.B))
        (Mux(free0 || c <= g, c, g), free0 || g > c)
    }
    val moved  = (0 to chunks).map(i => if (i * chunk >= w) 0.U(w.W) else (x << (i * chunk))(w - 1, 0))
    (VecInit(moved)(m), free, ks.map(k => m(k - ks.last)))
  }

  private def normaliseSerial(x: UInt, free0: Bool, cap: Option[UInt], ks: Seq[Int]): (UInt, Bool, Seq[Bool]) = {
    val w    = x.getWidth
    var v    = x
    var free = free0
    val bits = for (k <- ks) yield {
      val n    = 1 << k // < w
      val zero = v(w - 1, w - n) === 0.U
      val move = cap.map(c => zero && (free || (if (k < c.getWidth) c(k) else false.B))).getOrElse(zero)
      cap.foreach(c => free = free || ((if (k < c.getWidth) c(k) else false.B) && !zero))
      v = Mux(move, Cat(v(w - n - 1, 0), 0.U(n.W)), v)
      move
    }
    (v, free, bits)
  }

  /** A leading-zero count so far, `lz`, with the moves of the levels `ks` (from normaliseLevels) set in it. */
  def addMoves(lz: UInt, ks: Seq[Int], moves: Seq[Bool]): UInt =
    ks.zip(moves).map { case (k, b) => b.asUInt << k }.foldLeft(lz)(_ | _)

  /** The levels of a `levels`-level shifter, widest first, in groups of at most `per` (one pipeline step each:
    * two levels, a zero test and a 2:1 select each, fit a step at 150 MHz on an ECP5). */
  def groups(levels: Int, per: Int = 2): Seq[Seq[Int]] = ((levels - 1) to 0 by -1).grouped(per).map(_.toSeq).toSeq

  /** normalise(x, every level, no cap). */
  def normalise(x: UInt): (UInt, UInt) = normalise(x, log2Ceil(x.getWidth), None)

  /** (x >> s, sticky): sticky is the OR of every bit shifted out. Any s is accepted; a level of 2^k >= width
    * clears the value (the caller may cap s to save those levels).
    */
  def rightSticky(x: UInt, s: UInt): (UInt, Bool) = rightStickyLevels(x, s, 0 until s.getWidth, false.B)

  /** The levels `ks` of rightSticky (any subset, any order: the moves commute and the dropped bits only matter
    * through their OR), with the sticky bit so far `st0`: (x moved, sticky). A pipelined shifter runs them in
    * groups, the value, the shift and the sticky bit registered between them.
    */
  def rightStickyLevels(x: UInt, s: UInt, ks: Seq[Int], st0: Bool): (UInt, Bool) = {
    val w  = x.getWidth
    var v  = x
    var st = st0
    for (k <- ks) {
      val n = 1 << k
      val (dropped, moved) =
        if (n >= w) (v.orR, 0.U(w.W)) else (v(n - 1, 0).orR, Cat(0.U(n.W), v(w - 1, n)))
      st = st || (s(k) && dropped)
      v = Mux(s(k), moved, v)
    }
    (v, st)
  }
}
