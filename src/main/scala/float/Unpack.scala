package float

import chisel3._
import chisel3.util._

/** An operand taken apart. For finite values, value = (-1)^sign * sig * 2^(exp - manW): `sig` carries the hidden
  * bit (0 for subnormals and zero), `exp` is the unbiased exponent of the hidden bit, 1 - bias for subnormals.
  */
class Unpacked(fmt: FloatFormat) extends Bundle {
  val sign   = Bool()
  val exp    = SInt(fmt.expIntW.W)
  val sig    = UInt(fmt.sigW.W)
  val isZero = Bool()
  val isInf  = Bool()
  val isNaN  = Bool()
  val isSNaN = Bool() // signalling NaN: mantissa MSB clear
}

object Unpack {
  def apply(fmt: FloatFormat, bits: UInt): Unpacked = {
    val u     = Wire(new Unpacked(fmt))
    val eF    = bits(fmt.width - 2, fmt.manW)
    val man   = bits(fmt.manW - 1, 0)
    val eZero = eF === 0.U
    val eOnes = eF.andR
    u.sign   := bits(fmt.width - 1)
    u.exp    := (Mux(eZero, 1.U, eF).zext - fmt.bias.S).pad(fmt.expIntW)
    u.sig    := Cat(!eZero, man)
    u.isZero := eZero && man === 0.U
    u.isInf  := eOnes && man === 0.U
    u.isNaN  := eOnes && man =/= 0.U
    u.isSNaN := eOnes && man =/= 0.U && !man(fmt.manW - 1)
    u
  }

  /** Leading zeros of x (x.getWidth when x = 0). */
  def clz(x: UInt): UInt = {
    val w = x.getWidth
    Mux(x === 0.U, w.U, PriorityEncoder(Reverse(x)))
  }

  /** A significand on its way through a pipelined normaliser (`normaliseSteps`): the value moved so far and the
    * moves made (its leading-zero count once every level has run).
    */
  class NormSig(fmt: FloatFormat) extends Bundle {
    val sig = UInt(fmt.sigW.W)
    val lz  = UInt(log2Ceil(fmt.sigW).W)
  }

  /** The normaliser's levels of a significand in pipeline steps, two levels a step (Shift.groups). */
  def normaliseSteps(fmt: FloatFormat): Seq[Seq[Int]] = Shift.groups(log2Ceil(fmt.sigW))

  def startNormalise(fmt: FloatFormat, sig: UInt): NormSig = {
    val n = Wire(new NormSig(fmt))
    n.sig := sig
    n.lz  := 0.U
    n
  }

  /** The levels `ks` of one step applied: subnormal operands of divide and square root become normalised (hidden
    * bit set) after every step; their exponent is exp - lz. */
  def normaliseStep(fmt: FloatFormat, r: NormSig, ks: Seq[Int]): NormSig = {
    val (v, _, bits) = Shift.normaliseLevels(r.sig, true.B, None, ks)
    val n = Wire(new NormSig(fmt))
    n.sig := v
    n.lz  := Shift.addMoves(r.lz, ks, bits)
    n
  }
}
