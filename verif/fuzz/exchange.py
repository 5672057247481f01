"""Frames in, answers out, for the protocol fuzz: jobs (verif/fuzz/kinds.py) sent on s_axis with tlast where the
caller puts it, every answer on m_axis matched to its frame (in order, or by the key the kind reads from it) and
compared word for word with the golden model's; an answer no frame is waiting for, a second answer to a frame, or
no answer within the time limit fails.
"""
from __future__ import annotations

import cocotb
from cocotb.triggers import ClockCycles, RisingEdge, with_timeout
from cocotbext.axi import AxiStreamFrame

from verif.fuzz.kinds import Job, Kind

PERIOD_NS = 10   # the clock of mpc_cores.driver.AxiDriver


class Exchange:
    def __init__(self, kind: Kind):
        self.kind, self.tb = kind, kind.tb
        self.pending: list[Job] = []   # sent and not answered, in send order
        self.answered = 0
        self.now = 0
        cocotb.start_soon(self._count())

    async def _count(self):
        while True:
            await RisingEdge(self.tb.dut.clock)
            self.now += 1

    def send(self, jobs: list[Job], cuts: list[int] | None = None):
        """Queue the jobs' words on s_axis as packets ending (tlast) after the word counts in `cuts` (default: one
        packet per frame)."""
        words = [w for j in jobs for w in j.words]
        if cuts is None:
            cuts = frame_ends(jobs)
        start = 0
        for c in sorted(set(cuts) | {len(words)}):
            if c > start:
                self.tb.src.send_nowait(AxiStreamFrame(tdata=words[start:c]))
                start = c
        self.pending += jobs

    def take(self, answer: list[int]) -> Job:
        """Match an answer to its frame and compare it."""
        k = self.kind
        if k.ordered:
            assert self.pending, f"an answer without a frame: {answer}"
            job = self.pending.pop(0)
        else:
            key = k.key_of(answer)
            match = [j for j in self.pending if j.key == key]
            assert match, f"an answer for no waiting frame (key {key}): {answer}"
            job = match[0]
            self.pending.remove(job)
        err = job.mismatch(answer)
        assert err is None, f"answer {self.answered} (key {job.key}): {err}"
        self.answered += 1
        return job

    async def collect(self, n: int, limit: int) -> list[Job]:
        """The next n answers, each within `limit` cycles."""
        out = []
        for _ in range(n):
            try:
                f = await with_timeout(self.tb.sink.recv(), limit * PERIOD_NS, "ns")
            except cocotb.triggers.SimTimeoutError:
                raise AssertionError(f"no answer within {limit} cycles ({len(self.pending)} frames waiting)") from None
            out.append(self.take(list(f.tdata)))
        return out

    async def quiet(self, cycles: int):
        """No answer appears for `cycles` cycles."""
        await ClockCycles(self.tb.dut.clock, cycles)
        assert self.tb.sink.empty(), "an answer appeared that no frame asked for"


def frame_ends(jobs: list[Job]) -> list[int]:
    """Word counts at which the frames of `jobs` end."""
    out, n = [], 0
    for j in jobs:
        n += len(j.words)
        out.append(n)
    return out
