package bus

import chisel3._

/** Protocol assertions on the ports a core drives and on its internal queues, shared by every core: chisel3
  * `assert`, checked in simulation on every clock edge out of reset (Verilator with --assert; see
  * docs/verification.md) and left out of synthesis.
  *
  *  - a handshake source (m_axis, the B and R channels of the AXI4-Lite subordinate): once valid is high without
  *    ready, valid stays high and the payload stays unchanged until the cycle ready is high;
  *  - a queue: nothing is enqueued while it is full.
  */
object Protocol {
  /** `valid` and the payload words of a channel this module drives, `ready` the other side's. */
  def source(what: String, valid: Bool, ready: Bool, payload: Data*): Unit = {
    val waiting = RegNext(valid && !ready, false.B)
    assert(!waiting || valid, s"$what: valid dropped before ready")
    for (d <- payload) {
      val prev = RegNext(d.asUInt)
      assert(!waiting || d.asUInt === prev, s"$what: payload changed while valid and not ready")
    }
  }

  /** An AXI4-Stream output port. */
  def streamOut(what: String, s: AxiStreamIO): Unit = source(what, s.tvalid, s.tready, s.tdata, s.tlast)

  /** The response channels of an AXI4-Lite subordinate port. */
  def axiLiteResponses(what: String, a: AxiLiteIO): Unit = {
    source(s"$what B", a.bvalid, a.bready, a.bresp)
    source(s"$what R", a.rvalid, a.rready, a.rdata, a.rresp)
  }

  /** A queue: `push` only while `room`. */
  def noOverflow(what: String, push: Bool, room: Bool): Unit =
    assert(!push || room, s"$what: enqueue while full")
}
