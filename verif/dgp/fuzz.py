"""The protocol fuzz's adapter of the DGP core (verif/fuzz/kinds.py): its frames, answers and the scenarios of
verif/fuzz/violations.py forced into its small core."""
from __future__ import annotations

from verif.fuzz.kinds import Family, FixedKind


class DgpKind(FixedKind):
    """DGP (src/main/scala/dgp/DgpCore.scala): frames w (nw words); the answer u0 (or z with CTRL.OUT_ALL) then a
    status word with tlast (iterations, test met, saturated, overflow: verif/dgp/tb.py's expect), in order. A solve
    counts in SOLVES at its decision cycle, before its answer leaves. The accelerated form's answer leaves through
    an output queue (shell.AnswerQueue, as the FGM's), the plain form's from its own `out` state."""
    short = {"IMAX": 2}

    def held_solves(self, dut, jobs):
        """The answers that fit the output queue whole (accelerated), and the solve after them, counted at its
        decision while its answer waits"""
        return min(len(jobs), super().held_solves(dut, jobs) + 1)

    @staticmethod
    def queue_checks(core):
        return {"input frame"}

    def force_valid_drop(self, dut):
        if hasattr(dut, "ansQ"):
            super().force_valid_drop(dut)
        else:
            dut.st.value = 0          # St.idle: m_axis.tvalid is st === St.out && ...

    def force_payload_change(self, dut):
        if hasattr(dut, "ansQ"):
            super().force_payload_change(dut)
        else:
            dut.outIdx.value = self.tb.n   # the status word now: tdata changes, tlast rises


FAMILY = Family(DgpKind, "verif.dgp.tb:DgpTB", ("stream_valid_dropped", "stream_data_changed"))
