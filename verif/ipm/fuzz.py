"""The protocol fuzz's adapter of the interior-point core (verif/fuzz/kinds.py): its frames, answers and the scenarios of
verif/fuzz/violations.py forced into its small core."""
from __future__ import annotations

from verif.fuzz.kinds import Family, Job, Kind


class IpmKind(Kind):
    """Interior point: frames (channel, tag, x, r), answers matched by tag; each channel keeps its warm start."""
    ordered = False
    short = {"IMAX": 1, "INW": 1}

    def __init__(self, tb):
        super().__init__(tb)
        self.hold_frames = tb.C
        self.tag = tb.rng.randrange(1 << 20)
        self.channels: list[int] | None = None   # channels to use in turn (None: random)

    def job(self, ch: int | None = None) -> Job:
        tb = self.tb
        if ch is None:
            ch = self.channels.pop(0) if self.channels else tb.rng.randrange(tb.C)
        self.tag = (self.tag + 1) & 0xFFFFFF
        data = tb.words(*tb.state())
        e = tb.model.solve(ch % tb.C, None, x_words=data, warm=tb.warm, out_all=tb.out_all)
        flags = {f for f, on in (("NONFINITE", e.status & 1), ("NOT_CONVERGED", e.status & 2),
                                 ("CHANNEL", ch >= tb.C)) if on}
        expect = tb.frame(ch, self.tag, e.words + [e.status])
        return Job(tb.frame(ch, self.tag, data), expect, key=self.tag,
                   care={0, len(expect) - 1} if e.nonfinite else None, flags=flags)

    def key_of(self, answer):
        return answer[0] & 0xFFFFFF

    def before_held_round(self):
        """Every channel once, in random order: a channel's frames are answered in order."""
        self.channels = self.tb.rng.sample(range(self.tb.C), self.tb.C)

    def after_reset(self):
        self.tb.model.reset()
        self.tb.warm = bool(self.tb.rm.reset("CTRL", "WARM_START"))
        self.tb.out_all = bool(self.tb.rm.reset("CTRL", "OUT_ALL"))

    def applied(self, reg, fields):
        m = self.tb.model
        if reg == "IMAX":
            m.i_mr = fields["IMAX"]
        elif reg == "INW":
            m.i_nw = fields["INW"]
        elif reg == "MU_TOL":
            m.mu_tol = fields["VALUE"]
        elif reg == "RES_TOL":
            m.res_tol = fields["VALUE"]
        elif reg == "CTRL":
            self.tb.warm, self.tb.out_all = bool(fields["WARM_START"]), bool(fields["OUT_ALL"])

    @staticmethod
    def queue_checks(core):
        return {"output buffer", "batch order", "group"}


FAMILY = Family(IpmKind, "verif.ipm.tb:IpmTB")
