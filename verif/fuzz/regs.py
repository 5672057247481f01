"""AXI4-Lite traffic of the protocol fuzz: phases of reads and writes over a set of addresses, through
verif/fuzz/axil.py (AW and W in random order and delays, random wstrb, up to DEPTH transactions queued back to back
per direction, random bready and rready), every response and read value checked against verif/fuzz/regfile.py.

A phase runs with the core idle (busy=False: read-write registers take random values, data words only values that
do not fit, so that no data changes), or busy for sure (busy=True: the output is held while a frame is in the core;
data writes of any value are refused; read-write registers are written with the values they hold, or values they
refuse, so that the solves in flight keep their settings). Reads overlapping writes may see any state between them.
"""
from __future__ import annotations

from collections import deque

import cocotb

from verif.fuzz.regfile import Address, RegFile

DEPTH = 3


class RegFuzz:
    def __init__(self, kind, rf: RegFile):
        self.kind, self.tb, self.rf = kind, kind.tb, rf
        self.axil = self.tb.axil
        self.rng = self.tb.rng
        self.outstanding = 0     # writes issued and not yet committed
        self.transactions = 0
        # in a phase: the state index before its first write, its writes issued and answered so far (write j of
        # the phase leaves state base + j)
        self.base = self.issued = self.answered = 0

    # ---- values
    def _word(self, reg: str) -> int:
        return sum(self.rf.state[f"{reg}.{f.name}"] << f.lsb for f in self.rf.tracked[reg])

    def value(self, a: Address, busy: bool, racy: set[str]) -> int | None:
        """A value to write to `a` (None: no write)."""
        rnd = self.rng.getrandbits(32)
        if a.kind == "data" and not busy:
            if a.fit is None or a.fit >= 32:
                return None
            big = self.rng.randrange(1 << (a.fit - 1), 1 << 31)
            return big if self.rng.random() < 0.5 else (-big - 1) & 0xFFFFFFFF
        if a.kind != "reg" or a.name not in self.rf.tracked:
            return rnd
        if a.name == "STATUS":
            keep = sum(f.mask for f in a.reg.fields.values() if f.name in racy)
            return rnd & ~keep
        refused = self.rng.choice([0, self.rng.randrange(1 << 16, 1 << 32)])
        if busy:
            return refused if "SLVERR" in a.reg.desc and self.rng.random() < 0.5 else self._word(a.name)
        if "SLVERR" in a.reg.desc:
            return self.rng.choice([refused, self.rng.randrange(1, 1 << 16)])
        return rnd

    # ---- traffic
    async def write(self, a: Address, v: int, busy: bool | None):
        """One write, alone: its response checked and its effect applied."""
        t = cocotb.start_soon(self._one_write(a, v, busy, self.rf.expect_write(a, v, busy)))
        self._commit(*(await t))

    def _commit(self, a, v, busy, want, r):
        self.outstanding -= 1
        assert r.resp in want, f"write {v:#010x} to {a.name} ({a.kind}, busy {busy}): {r.resp.name}, expected " \
            f"{sorted(x.name for x in want)}"
        changed = self.rf.commit_write(a, v, r.resp)
        if changed is not None:
            self.kind.applied(a.name, changed)
        self.transactions += 1

    async def _one_write(self, a, v, busy, want):
        self.outstanding += 1
        self.issued += 1
        r = await self.axil.write(a.byte, v)
        self.answered += 1
        return a, v, busy, want, r

    async def _reader(self, addrs, reads: list):
        q = deque()
        for a in addrs:
            q.append(cocotb.start_soon(self._one_read(a)))
            if len(q) >= DEPTH:
                reads.append(await q.popleft())
        for t in q:
            reads.append(await t)

    async def _one_read(self, a):
        lo = self.base + self.answered
        r = await self.axil.read(a.byte)
        hi = self.base + self.issued
        self.transactions += 1
        return a, int.from_bytes(r.data, "little"), r.resp, lo, hi

    async def phase(self, addrs: list[Address], busy: bool | None, dynamic: dict, racy: set[str] = frozenset(),
                    writes: bool = True):
        """Reads of every address of `addrs` and writes to them (in two random orders, concurrently); then check
        the responses, the read values and that every transaction had one response."""
        reads: list = []
        assert self.outstanding == 0
        self.base, self.issued, self.answered = len(self.rf.snaps) - 1, 0, 0
        order = list(addrs)
        self.rng.shuffle(order)
        rd = cocotb.start_soon(self._reader(order, reads))
        if writes:
            wr = list(addrs)
            self.rng.shuffle(wr)
            await self._commit_in_order(wr, busy, racy)
        await rd
        assert self.axil.idle() and not self.axil.errors, f"AXI4-Lite: {self.axil.errors or self.axil.counts}"
        dyn = dict(dynamic)
        for f in racy:
            dyn[f"STATUS.{f}"] = None
        for a, word, resp, lo, hi in reads:
            err = self.rf.check_read(a, word, resp, lo, hi, dyn)
            assert err is None, f"{err} (busy {busy})"

    async def _commit_in_order(self, addrs, busy, racy):
        """Writes queued DEPTH deep; their responses checked and their effects applied in issue order."""
        q = deque()
        for a in addrs:
            v = self.value(a, busy, racy)
            if v is None:
                continue
            q.append(cocotb.start_soon(self._one_write(a, v, busy, self.rf.expect_write(a, v, busy))))
            if len(q) >= DEPTH:
                self._commit(*(await q.popleft()))
        while q:
            self._commit(*(await q.popleft()))
