package fixed

/** Two's-complement fixed-point format: 1 sign bit, `intBits` integer bits, `fracBits` fraction bits.
  * Chisel carries the bits as SInt; the format lives here, on the Scala side.
  */
case class QFormat(intBits: Int, fracBits: Int) {
  require(intBits >= 0, s"QFormat: intBits must be >= 0, got $intBits")
  require(fracBits >= 0, s"QFormat: fracBits must be >= 0, got $fracBits")
  val width: Int = 1 + intBits + fracBits
  override def toString: String = s"Q$intBits.$fracBits"
}

/** How a product with 2b fraction bits returns to b fraction bits. */
sealed trait Rounding { def name: String }
object Rounding {
  /** Floor (drop the low bits): error in (-2^-b, 0], as in the papers. */
  case object Truncate extends Rounding { val name = "truncate" }
  /** Add half an LSB, then floor: ties go towards +infinity, error in (-2^-(b+1), 2^-(b+1)]. */
  case object Nearest extends Rounding { val name = "nearest" }
  def apply(s: String): Rounding = s match {
    case "truncate" => Truncate
    case "nearest"  => Nearest
    case other      => throw new IllegalArgumentException(s"rounding must be 'truncate' or 'nearest', got '$other'")
  }
}
