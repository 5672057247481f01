package float

import chisel3.util.log2Ceil

/** Binary interchange format: 1 sign bit, `expW` exponent bits (bias 2^(expW-1) - 1), `manW` stored mantissa
  * bits (hidden bit implicit). binary32 is (8, 23), binary16 (5, 10); any reduced format is allowed.
  * Subnormals are supported (gradual underflow, as IEEE 754); NaN results are the canonical quiet NaN
  * (sign 0, exponent all ones, mantissa MSB 1, other mantissa bits 0).
  */
case class FloatFormat(expW: Int = 8, manW: Int = 23) {
  require(expW >= 2 && expW <= 16, s"FloatFormat: exponent width expW must be in [2, 16]: got expW=$expW")
  require(manW >= 1 && manW <= 62, s"FloatFormat: mantissa width manW must be in [1, 62]: got manW=$manW")
  require(1 + expW + manW <= 64,
    s"FloatFormat: 1 + expW + manW must be <= 64 (one 64-bit word): got expW=$expW, manW=$manW")

  val width: Int  = 1 + expW + manW
  val sigW: Int   = manW + 1 // significand with the hidden bit
  val bias: Int   = (1 << (expW - 1)) - 1
  val maxExpField: Int = (1 << expW) - 1
  /** Signed width of unbiased exponents inside the operators: enough for a product of two subnormals, a
    * quotient of extremes and the normalisation shift of a double-width significand, with margin.
    */
  val expIntW: Int = expW + 2 + log2Ceil(manW + 2)
  /** Canonical quiet NaN. */
  val qNaN: BigInt = (BigInt(maxExpField) << manW) | (BigInt(1) << (manW - 1))
  def inf(neg: Boolean): BigInt = (BigInt(if (neg) 1 else 0) << (width - 1)) | (BigInt(maxExpField) << manW)

  /** Suffix for module names, so that formats do not collide. */
  def tag: String = s"e${expW}_m$manW"
  /** the name users write (binary32, or e<expW>m<manW>) */
  def name: String = if (expW == 8 && manW == 23) "binary32" else s"e${expW}m$manW"
  override def toString: String = s"float(e=$expW, m=$manW)"
}

object FloatFormat {
  val binary32: FloatFormat = FloatFormat(8, 23)
  val binary16: FloatFormat = FloatFormat(5, 10)
}
