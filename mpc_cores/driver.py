"""cocotb driver of a generated fixed-point core (Verilator) through its AXI interfaces with cocotbext-axi: clock,
reset, AXI4-Stream source and sink, AXI4-Lite master, the core's bit-exact golden model beside it, and a monitor of
the stream handshakes (cycle counts). The closed loop and the testbenches of verif/ drive the cores through it.

Environment: CORE_OUT = the generator's output folder (core.json, config.json).
"""
from __future__ import annotations

import json
import os
import random
from pathlib import Path

import cocotb
import numpy as np
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, ReadOnly, RisingEdge
from cocotbext.axi import (AxiLiteBus, AxiLiteMaster, AxiResp, AxiStreamBus, AxiStreamFrame, AxiStreamSink,
                           AxiStreamSource)

from mpc_cores.regmap import Regmap


# Every scenario ends in far fewer cycles; a hang fails the test instead of stalling the suite.
TIMEOUT_MS = 200


def _hi(sig) -> bool:
    return str(sig.value) == "1"


def golden_model(cfg: dict):
    """The bit-exact model of the core described by its config.json."""
    from mpc_cores import registry

    return registry.get(cfg.get("core", "fgm")).golden_model(cfg)



def measure(record: dict) -> None:
    """Append a testbench's measurement (a JSON line) to the file CORE_MEASURE names, if any."""
    path = os.environ.get("CORE_MEASURE")
    if path:
        with open(path, "a") as f:
            f.write(json.dumps(record) + "\n")

class AxiDriver:
    """Any generated core: its core.json, config.json and register map (from its .rdl), the clock, a reset pulse,
    the AXI4-Stream source and sink (random backpressure on request) and the AXI4-Lite master (cocotbext-axi's, or
    `axil(dut, rng)`: an object with its write and read methods)."""

    def __init__(self, dut, seed: int = 1, axil=None):
        self.dut = dut
        self.out = out = Path(os.environ["CORE_OUT"])
        self.core = json.loads((out / "core.json").read_text())
        self.cfg = json.loads((out / "config.json").read_text())
        self.rm = Regmap.for_core(out, self.core)
        self.rng = random.Random(seed)
        self.imax = self.core["iterations"]
        cocotb.start_soon(Clock(dut.clock, 10, unit="ns").start())
        self.src = AxiStreamSource(AxiStreamBus.from_prefix(dut, "s_axis"), dut.clock, dut.reset, byte_lanes=1)
        self.sink = AxiStreamSink(AxiStreamBus.from_prefix(dut, "m_axis"), dut.clock, dut.reset, byte_lanes=1)
        self.axil = axil(dut, self.rng) if axil else AxiLiteMaster(AxiLiteBus.from_prefix(dut, "s_axil"), dut.clock,
                                                                    dut.reset)

    async def reset(self):
        self.dut.reset.value = 1
        await ClockCycles(self.dut.clock, 3)
        self.dut.reset.value = 0
        await RisingEdge(self.dut.clock)
        self.imax = self.core["iterations"]

    def backpressure(self, on: bool):
        def gen(p):
            while True:
                yield self.rng.random() < p
        for ep, prob in ((self.src, 0.3), (self.sink, 0.4)):
            ep.set_pause_generator(gen(prob) if on else None)
            if not on:
                ep.pause = False

    # ---- AXI4-Lite
    async def write(self, addr: int, value: int) -> AxiResp:
        r = await self.axil.write(addr, (int(value) & 0xFFFFFFFF).to_bytes(4, "little"))
        return r.resp

    async def read(self, addr: int) -> tuple[int, AxiResp]:
        r = await self.axil.read(addr, 4)
        return int.from_bytes(r.data, "little"), r.resp

    async def set_imax(self, imax: int):
        assert await self.write(self.rm["IMAX"], imax) == AxiResp.OKAY
        self.imax = imax

    async def status(self) -> dict:
        v, resp = await self.read(self.rm["STATUS"])
        assert resp == AxiResp.OKAY
        return self.rm.status(v)


class TB(AxiDriver):
    """A fixed-point core (FGM, ADMM) with its golden model beside it and a monitor of the stream handshakes."""

    def __init__(self, dut, seed: int = 1, **kw):
        super().__init__(dut, seed, **kw)
        self.sw = self.core["stream_width"]
        self.n, self.nu, self.nw = self.core["n"], self.core["nu"], self.core["nw"]
        self.model = golden_model(self.cfg)
        # an interleaving core: one model per problem id (each its own warm start); models[0] is `model`
        self.problems = int(self.core.get("problems", 1))
        self.models = [self.model] + [golden_model(self.cfg) for _ in range(self.problems - 1)]
        # box of the accepted parameter words
        self.box = (self.model.xlo, self.model.xhi) if hasattr(self.model, "xlo") else (self.model.wlo, self.model.whi)
        self.warm = self.core["warm_start"]
        self.out_all = self.core["output_all"]
        self.exit_tol: int | None = None   # EXIT_TOL as written (None: its reset value), for a core with the test
        self.cycle = 0
        self.reset_cycle = 0             # the monitor's cycle of the last clock edge with reset high
        self.in_done: list[int] = []     # cycles of the input tlast handshakes
        self.out_start: list[int] = []   # cycles where an output frame's first word is valid
        self.out_done: list[int] = []    # cycles of the output tlast handshakes
        cocotb.start_soon(self._monitor())

    async def _monitor(self):
        d = self.dut
        expect_first = True
        while True:
            await RisingEdge(d.clock)
            await ReadOnly()
            self.cycle += 1
            if _hi(d.reset):
                expect_first = True
                self.reset_cycle = self.cycle
                continue
            if _hi(d.s_axis_tvalid) and _hi(d.s_axis_tready) and _hi(d.s_axis_tlast):
                self.in_done.append(self.cycle)
            if _hi(d.m_axis_tvalid):
                if expect_first:
                    self.out_start.append(self.cycle)
                    expect_first = False
                if _hi(d.m_axis_tready) and _hi(d.m_axis_tlast):
                    expect_first = True
                    self.out_done.append(self.cycle)

    def since_reset(self, cycle: int) -> int:
        """a monitor cycle as the core counts it: 0 is the first cycle after reset (mpc_cores.interleave)"""
        return cycle - self.reset_cycle - 1

    async def reset(self):
        await super().reset()
        for m in self.models:
            m.reset()
        self.warm = self.core["warm_start"]
        self.out_all = self.core["output_all"]
        self.exit_tol = None

    async def set_exit_tol(self, tol: int):
        """EXIT_TOL (a core with the exit test), and the models' tolerance with it"""
        assert await self.write(self.rm["EXIT_TOL"], tol) == AxiResp.OKAY
        self.exit_tol = tol

    async def iterations(self) -> tuple[int, bool]:
        """ITERATIONS of the last solve: (COUNT, MET)"""
        v, resp = await self.read(self.rm["ITERATIONS"])
        assert resp == AxiResp.OKAY
        return v & 0xFFFF, bool(v >> 16 & 1)

    # ---- words
    def to_word(self, v: int) -> int:
        return int(v) & ((1 << self.sw) - 1)

    def from_word(self, u: int) -> int:
        return u - (1 << self.sw) if u >> (self.sw - 1) & 1 else u

    def random_w(self, outside: float = 0.0) -> np.ndarray:
        """Words of a random parameter in the box; with probability `outside` per word, far outside it."""
        lo, hi = self.box
        w = np.array([self.rng.randint(int(a), int(b)) for a, b in zip(lo, hi)], dtype=np.int64)
        lim = (1 << (self.sw - 1)) - 1
        for j in range(self.nw):
            if self.rng.random() < outside:
                w[j] = self.rng.choice([self.rng.randint(int(hi[j]) + 1, lim), self.rng.randint(-lim - 1, int(lo[j]) - 1)])
        return w

    async def set_ctrl(self, warm: bool | None = None, out_all: bool | None = None, hold: bool = False):
        self.warm = self.warm if warm is None else warm
        self.out_all = self.out_all if out_all is None else out_all
        bit = self.rm.CTRL_BITS
        v = int(self.warm) << bit["WARM_START"] | int(hold) << bit["HOLD"] | int(self.out_all) << bit["OUT_ALL"]
        assert await self.write(self.rm["CTRL"], v) == AxiResp.OKAY

    # ---- streams
    async def send(self, w, problem: int | None = None):
        """a frame; `problem` is its id (tuser) on an interleaving core"""
        f = AxiStreamFrame(tdata=[self.to_word(v) for v in w])
        if problem is not None:
            f.tuser = problem
        await self.src.send(f)

    async def recv(self) -> list[int]:
        return (await self.recv_tagged())[1]

    async def recv_tagged(self) -> tuple[int, list[int]]:
        """(problem id, words) of the next answer; the id is 0 on a core that does not interleave"""
        f = await self.sink.recv()
        tag = f.tuser if f.tuser is not None else 0
        assert isinstance(tag, int), f"an answer's tuser changed within the frame: {f.tuser}"
        return tag, [self.from_word(x) for x in f.tdata]

    def expect(self, w, problem: int = 0):
        """Model result for the next solve (of problem `problem`), as the words the core sends."""
        kw = {} if self.exit_tol is None else {"exit_tol": self.exit_tol}
        r = self.models[problem].solve(w, imax=self.imax, warm=self.warm, **kw)
        words = r.z if self.out_all else r.z[: self.nu]
        return [int(x) for x in words], r

    async def solve_and_check(self, w, tag=""):
        exp, r = self.expect(w)
        await self.send(w)
        got = await self.recv()
        assert got == exp, f"{tag}: RTL {got} != model {exp} for w={list(w)}"
        return r
