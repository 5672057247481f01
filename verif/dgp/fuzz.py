"""The protocol fuzz's adapter of the DGP core (verif/fuzz/kinds.py): its frames, answers and the scenarios of
verif/fuzz/violations.py forced into its small core."""
from __future__ import annotations

from verif.fuzz.kinds import Family, FixedKind


class DgpKind(FixedKind):
    """DGP (src/main/scala/dgp/DgpCore.scala): frames w (nw words); the answer u0 (or z with CTRL.OUT_ALL) then a
    status word with tlast (iterations, test met, saturated, overflow: verif/dgp/tb.py's expect), in order. The
    output is held in the core's own `out` state, not a queue; its solve counts in SOLVES at its decision cycle,
    before the answer leaves, while the next frame waits in the input buffer."""
    short = {"IMAX": 2}

    def held_solves(self, dut, jobs):
        return min(1, len(jobs))

    @staticmethod
    def queue_checks(core):
        return {"input frame"}

    def force_valid_drop(self, dut):
        dut.st.value = 0          # St.idle: m_axis.tvalid is st === St.out && ...

    def force_payload_change(self, dut):
        dut.outIdx.value = self.tb.n   # the status word now: tdata changes, tlast rises


FAMILY = Family(DgpKind, "verif.dgp.tb:DgpTB", ("stream_valid_dropped", "stream_data_changed"))
