"""One interface over the core kinds for the protocol fuzz and the forced protocol violations: random input frames
with the answers the golden model expects (through each kind's testbench class: mpc_cores.driver.TB for FGM and the
ADMM family, verif/minres/tb.py, verif/ipm/tb.py, verif/dgp/tb.py), how an answer is matched to its frame, the
model's view of the registers it reads, and the kind's facts the suites need (short solves, solves completed while
the output is held, its queues' assertions, where a violation can be forced into it).

Each kind's adapter and scenarios are its `Family`, at CoreKind.fuzz (verif/<kind>/fuzz.py: FAMILY): the ADMM
method kinds share the ADMM one. This module holds the base adapter and FixedKind, the adapter of the cores driven
through the shared fixed-point testbench (mpc_cores.driver.TB).

`Job.expect` is the whole output frame as stream words; `care` the indices compared (None: all; a flagged
MINRES or interior-point answer compares its id and status only, as the kinds' testbenches do).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from cocotbext.axi import AxiResp

from mpc_cores import registry
from mpc_cores.kind import load


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
    #: register values for short solves in the stream and reset scenarios (the solve time sets their length)
    short: dict[str, int] = {}

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

    def held_solves(self, dut, jobs: list[Job]) -> int:
        """Of `jobs` sent with the output held, the solves SOLVES may count before any answer leaves."""
        return 0

    def before_held_round(self):
        """Before a round of frames sent with the output held (the AXI4-Lite fuzz)."""

    @staticmethod
    def queue_checks(core: dict) -> set[str]:
        """The queues and buffers of the core whose overflow assertion (`<name>: enqueue while full`) it carries."""
        raise NotImplementedError

    # ---- forced violations (verif/fuzz/violations.py); a kind supports those its Family lists
    def force_valid_drop(self, dut):
        """With an answer waiting on m_axis (tready low): make tvalid fall on the next edge."""
        raise NotImplementedError

    def force_payload_change(self, dut):
        """With an answer of all of z waiting on m_axis (tready low): change tdata and raise tlast on the next
        edge."""
        raise NotImplementedError


# words of answers that a one-problem FGM or ADMM core's output queue (shell.AnswerQueue) takes while m_axis is
# held: a solve counts as done when its answer's last word is queued
QUEUE_HELD_WORDS = 3


class FixedKind(Kind):
    """FGM and the ADMM family: frames w = (x, r); answers in order."""
    hold_frames = 2

    def job(self) -> Job:
        tb = self.tb
        w = tb.random_w(outside=0.05)
        exp, r = tb.expect(w)
        flags = {f for f, on in (("SAT", r.sat), ("OVERFLOW", r.overflow)) if np.any(on)}
        return Job([tb.to_word(v) for v in w], [tb.to_word(v) for v in exp], flags=flags)

    def applied(self, reg, fields):
        super().applied(reg, fields)
        if reg == "CTRL":
            self.tb.warm, self.tb.out_all = bool(fields["WARM_START"]), bool(fields["OUT_ALL"])

    def held_solves(self, dut, jobs):
        """The answers that fit the output queue whole (none without one)."""
        if not hasattr(dut, "ansQ"):
            return 0
        done = words = 0
        for j in jobs:
            words += len(j.expect)
            if words > QUEUE_HELD_WORDS:
                break
            done += 1
        return done

    @staticmethod
    def queue_checks(core):
        return {"input frame"} | ({"answer queue"} if int(core.get("problems", 1)) > 1 else set())

    def force_valid_drop(self, dut):
        """One problem: the output queue emptied; several: the sequencer sent back to idle."""
        if hasattr(dut, "ansQ"):  # one problem: the answer leaves through shell.AnswerQueue
            dut.ansQ.nonEmpty.value = 0
        else:
            dut.seq.state.value = 0

    def force_payload_change(self, dut):
        """One problem: the head of the output queue; several: the output index moved to the last word."""
        if hasattr(dut, "ansQ"):  # one problem: shell.AnswerQueue's head entry
            rd = int(dut.ansQ.rd.value)
            head = getattr(dut.ansQ, f"d_{rd}_data")
            head.value = int(head.value) ^ 1
            getattr(dut.ansQ, f"d_{rd}_last").value = 1
        else:
            dut.seq.outCnt.value = self.tb.core["n"] - 1
            dut.seq.outAtEnd.value = 1   # the last-word flag (tlast) is a register of its own


@dataclass(frozen=True)
class Family:
    """The cores of one testbench: the adapter, the testbench class ("module:class", constructed as cls(dut, seed,
    axil=...)), and the scenarios of verif/fuzz/violations.py forced into its small core in tests/test_assertions.py
    (at least one; axil_response_dropped works on any core)."""
    adapter: type[Kind]
    tb: str
    violations: tuple[str, ...] = ("axil_response_dropped",)


def family(kind: str) -> Family:
    """The family of the registry kind `kind`: its CoreKind.fuzz."""
    ref = registry.get(kind).fuzz
    try:
        f = load(ref)
    except (ImportError, AttributeError) as e:
        raise KeyError(f"CORE={kind}: no protocol-fuzz family at {ref} ({e})") from None
    if not isinstance(f, Family):
        raise KeyError(f"CORE={kind}: {ref} is not a verif.fuzz.kinds.Family")
    return f


def violations(kind: str) -> tuple[str, ...]:
    """The violation scenarios of the kind's family; none without a family (so that collecting the suites does not
    fail: tests/test_suites.py does)."""
    try:
        return family(kind).violations
    except KeyError:
        return ()


def make(dut, kind: str, seed: int, **kw) -> Kind:
    """The kind's testbench on `dut` (reset not yet applied) and its adapter."""
    f = family(kind)
    return f.adapter(load(f.tb)(dut, seed, **kw))
