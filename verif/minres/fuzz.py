"""The protocol fuzz's adapter of the MINRES core (verif/fuzz/kinds.py): its frames, answers and the scenarios of
verif/fuzz/violations.py forced into its small core."""
from __future__ import annotations

from verif.fuzz.kinds import Family, Job, Kind


class MinresKind(Kind):
    """MINRES: frames (id, diag, b), answers matched by id."""
    ordered = False
    short = {"IMAX": 2}

    def __init__(self, tb):
        super().__init__(tb)
        self.hold_frames = tb.P
        self.next_id = tb.rng.getrandbits(20) << 8

    def job(self) -> Job:
        tb = self.tb
        self.next_id = (self.next_id + 1 + tb.rng.randrange(5)) & 0x7FFFFFFF
        data = tb.random_problem()
        r, res = tb.expect(*data)
        return Job(tb.frame(self.next_id, *data), tb.answer(self.next_id, r, res), key=self.next_id,
                   care={0} if r.flag else None, flags={"NONFINITE"} if r.flag else set())

    def key_of(self, answer):
        return answer[0] & 0x7FFFFFFF

    @staticmethod
    def queue_checks(core):
        return {"output queue", "load bank"}


FAMILY = Family(MinresKind, "verif.minres.tb:MinresTB", ("queue_overflow",))
