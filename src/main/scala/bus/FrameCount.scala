package bus

import chisel3._
import chisel3.util.log2Ceil

/** A word's position in a frame of `words` words, counted on handshakes, with its compares kept as flags beside
  * the count (registers): `at0` (the first word) and `atLast` (the last), so that a ready, a valid or a word's kind
  * decided from them has no compare of the count in front of it. Registers of the module it is built in. */
class FrameCount(words: Int) {
  require(words >= 1, s"a frame has at least one word: got $words")
  val value: UInt  = RegInit(0.U(log2Ceil(words + 1).W))
  val at0: Bool    = RegInit(true.B)
  val atLast: Bool = RegInit((words == 1).B)

  /** a word's handshake: the next position (0 after the last) */
  def step(): Unit = {
    val nxt = Mux(atLast, 0.U, value + 1.U)
    value  := nxt
    at0    := nxt === 0.U
    atLast := nxt === (words - 1).U
  }
}
