"""One interface over the core kinds for the protocol fuzz: random input frames with the answers the golden model
expects (through each kind's testbench class: mpc_cores.driver.TB for FGM and ADMM, verif/minres/tb.py,
verif/ipm/tb.py), how an answer is matched to its frame, and the model's view of the registers it reads.

`Job.expect` is the whole output frame as stream words; `care` the indices compared (None: all; a flagged
MINRES or interior-point answer compares its id and status only, as the kinds' testbenches do).
"""
from __future__ import annotations

from dataclasses import dataclass, field

from cocotbext.axi import AxiResp

from mpc_cores.driver import TB


@dataclass
class Job:
    words: list[int]
    expect: list[int]
    key: object = None
    care: set[int] | None = None
    flags: set[str] = field(default_factory=set)   # sticky STATUS flags this answer sets

    def mismatch(self, got: list[int]) -> str | None:
        if len(got) != len(self.expect):
            return f"answer of {len(got)} words, expected {len(self.expect)}: {[hex(w) for w in got[:12]]}"
        bad = [i for i in range(len(got)) if (self.care is None or i in self.care) and got[i] != self.expect[i]]
        if bad:
            i = bad[0]
            return f"{len(bad)} words differ, first {i}: RTL {got[i]:#010x} model {self.expect[i]:#010x}"
        return None


class Kind:
    """Base: the kind's testbench `tb`. Answers leave in frame order unless `key_of` names their frame."""
    ordered = True
    #: frames the core takes while its output is held (its input buffer and the solves it holds)
    hold_frames = 1

    def __init__(self, tb):
        self.tb = tb

    def job(self) -> Job:
        raise NotImplementedError

    def key_of(self, answer: list[int]):
        return None

    def after_reset(self):
        """The model after a reset of the core (the testbench's own reset has already run)."""

    def applied(self, reg: str, fields: dict[str, int]):
        """A read-write register took new field values: the model follows."""
        if reg == "IMAX":
            self.tb.imax = fields["IMAX"]

    async def set_reg(self, name: str, value: int):
        """Write a register the model follows (IMAX, CTRL, ...)."""
        assert await self.tb.write(self.tb.rm[name], value) == AxiResp.OKAY, name
        self.applied(name, {f.name: (value & f.mask) >> f.lsb for f in self.tb.rm.regs[name].fields.values()})


class FixedKind(Kind):
    """FGM and ADMM: frames w = (x, r); answers in order."""
    hold_frames = 2

    def job(self) -> Job:
        tb = self.tb
        w = tb.random_w(outside=0.05)
        exp, r = tb.expect(w)
        flags = {f for f, on in (("SAT", r.sat), ("OVERFLOW", r.overflow)) if on}
        return Job([tb.to_word(v) for v in w], [tb.to_word(v) for v in exp], flags=flags)

    def applied(self, reg, fields):
        super().applied(reg, fields)
        if reg == "CTRL":
            self.tb.warm, self.tb.out_all = bool(fields["WARM_START"]), bool(fields["OUT_ALL"])


class MinresKind(Kind):
    """MINRES: frames (id, diag, b), answers matched by id."""
    ordered = False

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


class IpmKind(Kind):
    """Interior point: frames (channel, tag, x, r), answers matched by tag; each channel keeps its warm start."""
    ordered = False

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


def make(dut, kind: str, seed: int, **kw) -> Kind:
    """The kind's testbench on `dut` (reset not yet applied) and its adapter."""
    from verif.ipm.tb import IpmTB
    from verif.minres.tb import MinresTB

    adapter, tb = {"fgm": (FixedKind, TB), "admm": (FixedKind, TB), "minres": (MinresKind, MinresTB),
                   "ipm": (IpmKind, IpmTB)}[kind]
    return adapter(tb(dut, seed, **kw))
