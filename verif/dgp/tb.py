"""cocotb testbench of a DGP core (Verilator) against its bit-exact golden model (mpc_cores/dgp/model.py), through
AXI4-Stream and AXI4-Lite.

Every answer is u0 (or z) then the status word (iterations in bits 15:0, test met 16, input saturated 17, overflow
18); the testbench compares all of it with the model, and the cycles from the last input word to the first answer
word with core.json: solve_overhead + I cycles_per_iteration - Z zero_start_saving_cycles, I the iterations the
model ran and Z 1 when the model's starting dual was all zero (a zero start skips the first passes K and G).

Environment: CORE_OUT (the generator's output folder), CORE_RANDOM (random solves of the bit-exact test), CORE_SEED
(its seed, default 7), CORE_MEASURE (a file to append measurements to), CORE_NONZERO_START (0: the plant's rows bind
nowhere in the box, so cycle_contract has no warm start from a nonzero dual to check).
"""
from __future__ import annotations

import os

import cocotb
import numpy as np
from cocotb.triggers import ClockCycles, with_timeout
from cocotbext.axi import AxiResp

from mpc_cores.dgp.model import DgpFixed
from mpc_cores.driver import TB, measure

TIMEOUT_MS = float(os.environ.get("CORE_TIMEOUT_MS") or 400)


class DgpTB(TB):
    def __init__(self, dut, seed: int = 7, **kw):
        super().__init__(dut, seed, **kw)
        self.L = self.core["cycles_per_iteration"]
        self.over = self.core["solve_overhead_cycles"]
        self.save = self.core["zero_start_saving_cycles"]

    def last_cycles(self, r) -> int:
        """LAST_CYCLES of the model's solve r: the first pass to its decision cycle"""
        return self.core["issue_cycles"]["F"] + int(r.iterations[0]) * self.L - int(r.zero_start[0]) * self.save

    def expect(self, w, problem: int = 0):
        r = self.model.solve(w, imax=self.imax, warm=self.warm)
        z = r.z[0]
        words = [int(x) for x in (z if self.out_all else z[: self.nu])]
        st = int(r.iterations[0]) | int(r.met[0]) << 16 | int(r.sat[0]) << 17 | int(r.overflow[0]) << 18
        return words + [st], r

    async def check(self, w, tag: str, cycles: bool = True):
        """one solve with the core idle: words, status word, ITERATIONS, and the latency against core.json"""
        exp, r = self.expect(w)
        n_in = len(self.in_done)
        await self.send(w)
        got = await self.recv()
        assert got[:-1] == exp[:-1] and got[-1] == exp[-1], f"{tag}: RTL {got} != model {exp} for w={list(w)}"
        iters, zs = int(r.iterations[0]), int(r.zero_start[0])
        if cycles:
            lat = self.out_start[-1] - self.in_done[n_in]
            assert lat == self.over + iters * self.L - zs * self.save, \
                f"{tag}: {lat} cycles to the answer, core.json: {self.over} + {iters} x {self.L} - {zs} x {self.save}"
        v, resp = await self.read(self.rm["ITERATIONS"])
        assert resp == AxiResp.OKAY and v & 0xFFFF == iters and (v >> 16) & 1 == int(r.met[0]) \
            and (v >> 17) & 1 == zs, (v, iters, zs)
        return r


async def _start(dut, seed=None):
    tb = DgpTB(dut, seed=int(os.environ.get("CORE_SEED") or 7) if seed is None else seed)
    await tb.reset()
    return tb


@cocotb.test()
async def bitexact_random(dut):
    """random states (10 % of words outside the box), warm and cold starts, random IMAX up to the default, random
    idle and backpressure; every word, the status word and the latency"""
    async def body():
        tb = await _start(dut)
        solves = int(os.environ.get("CORE_RANDOM") or 6)
        iters = []
        for i in range(solves):
            if i % 4 == 3:
                await tb.set_ctrl(warm=tb.rng.random() < 0.7, out_all=tb.rng.random() < 0.3)
                await tb.set_imax(tb.rng.randint(1, tb.core["iterations"]))
                tb.backpressure(tb.rng.random() < 0.5)
            await ClockCycles(dut.clock, tb.rng.randint(0, 5))
            r = await tb.check(tb.random_w(outside=0.1), f"solve {i}")
            iters.append(int(r.iterations[0]))
            v, _ = await tb.read(tb.rm["LAST_CYCLES"])
            assert v == tb.last_cycles(r), (v, iters[-1], bool(r.zero_start[0]))
        tb.backpressure(False)
        measure({"test": "bitexact_random", "module": tb.core["module"], "cases": solves, "iterations": iters})
    await with_timeout(body(), TIMEOUT_MS, "ms")


@cocotb.test()
async def cycle_contract(dut):
    """LAST_CYCLES, ITERATIONS and the answer's cycle for cold starts (zero starts) at IMAX = 1, 2, 3 (the test
    cannot hold that early at a state with active constraints), then warm starts at the default IMAX (half the
    words outside the box, saturated to its faces), the first from a nonzero dual"""
    async def body():
        tb = await _start(dut, seed=3)
        await tb.set_ctrl(warm=False)
        for imax in (1, 2, 3):
            await tb.set_imax(imax)
            r = await tb.check(tb.random_w(), f"cold, imax {imax}")
            assert r.zero_start[0], "a cold start that is not a zero start"
            v, _ = await tb.read(tb.rm["LAST_CYCLES"])
            assert v == tb.last_cycles(r), (v, int(r.iterations[0]))
        # a state whose cold solve at IMAX = 1 (else 2, 3) leaves a nonzero dual (the unconstrained optimum z = e
        # violates a row), then warm starts: the first from that dual (with the shifted warm start, a dual whose
        # shifted start is nonzero: probe.warm_dual)
        probe = DgpFixed(tb.cfg)
        ws = [tb.random_w(outside=0.5) for _ in range(200)]
        hot = None
        for imax_hot in (1, 2, 3):
            ys = probe.solve_batch(np.array(ws), imax=imax_hot).y
            hot = next((w for w, y in zip(ws, ys) if probe.warm_dual(y).any()), None)
            if hot is not None:
                break
        if hot is None:
            # CORE_NONZERO_START=0: a plant none of whose rows binds anywhere in the box (every dual stays zero)
            assert os.environ.get("CORE_NONZERO_START") == "0", \
                "no state of 200 leaves a nonzero dual: the full first iteration untested"
        else:
            await tb.set_imax(imax_hot)
            await tb.check(hot, "cold, nonzero dual after")
            await tb.set_ctrl(warm=True)
            await tb.set_imax(tb.core["iterations"])
            starts = []
            for i in range(4):
                r = await tb.check(hot if i == 0 else tb.random_w(outside=0.5), f"warm {i}")
                starts.append(bool(r.zero_start[0]))
                v, _ = await tb.read(tb.rm["LAST_CYCLES"])
                assert v == tb.last_cycles(r), (v, int(r.iterations[0]), starts[-1])
            assert not starts[0], "a warm start from a nonzero dual taken as a zero start"
        # the shifted warm start: a nonzero dual whose shifted start is all zero (its rows at the first stage only)
        # starts a zero start, where one of the 200 states leaves such a dual at IMAX = 1
        ys = probe.solve_batch(np.array(ws), imax=1).y
        dead = next((w for w, y in zip(ws, ys) if y.any() and not probe.warm_dual(y).any()), None)
        if tb.cfg.get("shift_src") and dead is not None:
            await tb.set_ctrl(warm=False)
            await tb.set_imax(1)
            await tb.check(dead, "cold, a dual at the first stage only after")
            await tb.set_ctrl(warm=True)
            r = await tb.check(tb.random_w(), "warm from it")
            assert r.zero_start[0], "the model's shifted start from a first-stage dual is not a zero start"
        v, _ = await tb.read(tb.rm["CYCLES_PER_ITER"])
        assert v == tb.L
        measure({"test": "cycle_contract", "cycles_per_iteration": tb.L, "overhead": tb.over,
                 "zero_start_saving_cycles": tb.save})
    await with_timeout(body(), TIMEOUT_MS, "ms")


@cocotb.test()
async def backpressure_and_order(dut):
    """frames sent back to back under random backpressure on both streams: one answer per frame, in order"""
    async def body():
        tb = await _start(dut, seed=5)
        tb.backpressure(True)
        ws = [tb.random_w(outside=0.15) for _ in range(5)]
        exp = [tb.expect(w)[0] for w in ws]
        for w in ws:
            cocotb.start_soon(tb.send(w))
            await ClockCycles(dut.clock, tb.rng.randint(0, 3))
        for i, e in enumerate(exp):
            got = await tb.recv()
            assert got == e, f"frame {i}: RTL {got} != model {e}"
        tb.backpressure(False)
        st = await tb.status()
        assert st["SAT"] == any((e[-1] >> 17) & 1 for e in exp)
    await with_timeout(body(), TIMEOUT_MS, "ms")


@cocotb.test()
async def reset_hold_saturation(dut):
    """a reset in the middle of a solve loses the warm start and nothing else; HOLD takes no frame until released;
    a state outside the box saturates and is flagged in the status word"""
    async def body():
        tb = await _start(dut, seed=9)
        await tb.check(tb.random_w(), "before reset")
        await tb.send(tb.random_w())
        await ClockCycles(dut.clock, tb.core["issue_cycles"]["F"] + tb.L // 2)
        await tb.reset()
        await tb.check(tb.random_w(), "after reset")
        await tb.set_ctrl(hold=True)
        w = tb.random_w()
        exp, _ = tb.expect(w)
        started = len(tb.out_start)
        cocotb.start_soon(tb.send(w))
        await ClockCycles(dut.clock, tb.over + 3 * tb.L)
        assert tb.sink.empty() and len(tb.out_start) == started, "an answer while HOLD was set"
        await tb.set_ctrl(hold=False)
        got = await tb.recv()
        assert got == exp, f"after HOLD: RTL {got} != model {exp}"
        w = tb.random_w(outside=1.0)
        r = await tb.check(w, "outside the box")
        assert r.sat[0]
        assert (await tb.status())["SAT"]
    await with_timeout(body(), TIMEOUT_MS, "ms")
