"""cocotb testbench of the MINRES core (Verilator), through its AXI4-Stream and AXI4-Lite interfaces.

Environment: CORE_OUT = the generator's output folder (core.json, config.json); CORE_RANDOM = random problems in
the bit-exact test; CORE_MEASURE = file to append measurements to (JSON lines); CORE_SEED = the seed of the
bit-exact test (default 11); CORE_TIMEOUT_MS = the simulated-time limit of each scenario in ms (default 400).
Every output word is compared with the bit-exact golden model (mpc_cores/minres/model.py) in the core's float
format (core.json `format`): data words are the format's raw words in the low bits of the 32-bit stream words.
"""
from __future__ import annotations

import os

import cocotb
import numpy as np
from cocotbext.axi import AxiResp, AxiStreamFrame

from mpc_cores.driver import AxiDriver, measure
from mpc_cores.minres.model import MinresCoreModel

TIMEOUT_MS = float(os.environ.get("CORE_TIMEOUT_MS") or 400)
STATUS_NONFINITE = 6


class MinresTB(AxiDriver):
    def __init__(self, dut, seed: int = 1, **kw):
        super().__init__(dut, seed, **kw)
        c = self.core
        self.N, self.P, self.n, self.m, self.T = c["N"], c["P"], c["n"], c["m"], c["T"]
        self.model = MinresCoreModel.from_config(self.cfg)
        self.h = np.array(self.cfg["h_diag"])
        self.nrng = np.random.default_rng(seed)
        # the warm form of the interior-point core (MinresParams.warm): frames id, diag, d, b, z0 in; id, x,
        # ||r_0|| out; iterations and the closing of a partial batch on the ports ipm_imax, ipm_close
        self.warm = bool(c.get("warm", False))
        if self.warm:
            dut.ipm_close.value = 0
            dut.ipm_imax.value = c["iterations"]

    @property
    def M(self) -> int:
        return self.core["M"]

    def random_problem(self):
        """diag = H_ii + W_ii with random interior-point weights, b random (float64 values: the words sent and the
        model round them to the format alike)."""
        from mpc_cores.minres.kkt import random_weights
        w = random_weights(self.nrng, self.n, self.m, self.T, 0.1, 10.0)
        diag = self.h + w
        b = self.nrng.standard_normal(self.N)
        if not self.warm:
            return diag, b
        d = self.nrng.uniform(0.2, 1.5, self.N)
        z0 = self.nrng.standard_normal(self.N)
        return diag, b, d, z0

    def expect(self, diag, b, d=None, z0=None, pid: int = 0):
        """The model's result (and ||r_0|| in the warm form, else None) for the problem of id `pid` (which chooses
        the coefficient table of a core with several)."""
        t = self.model.table_of(pid)
        if not self.warm:
            return self.model.solve(diag, b, self.imax, table=t), None
        return self.model.solve_warm(diag, d, b, z0, self.imax, table=t)

    async def set_imax(self, imax: int):
        if self.warm:
            self.dut.ipm_imax.value = imax
            self.imax = imax
            return
        await super().set_imax(imax)

    async def close(self):
        """warm form: send a partly loaded batch on (a one-cycle pulse)"""
        from cocotb.triggers import RisingEdge
        await RisingEdge(self.dut.clock)
        self.dut.ipm_close.value = 1
        await RisingEdge(self.dut.clock)
        self.dut.ipm_close.value = 0

    def frame(self, pid: int, diag, b, d=None, z0=None) -> list[int]:
        """The words of one input frame; in a format narrower than 32 bits the unused upper bits of the data words
        are random (the core ignores them)."""
        W = self.core.get("word_width", 32)

        def words(x):
            return [w | (self.rng.getrandbits(32 - W) << W if W < 32 else 0) for w in self.model.to_words(x)]
        data = words(diag) + (words(d) + words(b) + words(z0) if self.warm else words(b))
        return [pid & 0x7FFFFFFF] + data

    async def send(self, pid: int, diag, b, d=None, z0=None):
        await self.src.send(AxiStreamFrame(tdata=self.frame(pid, diag, b, d, z0)))

    def answer(self, pid: int, r, res=None) -> list[int]:
        """The output frame of problem `pid` with the model's result r (and ||r_0|| res in the warm form, in the
        model's arithmetic: a float32 value, or a raw word in other formats): the id with bit 31 the flag, then the
        words (not compared when flagged)."""
        res_words = self.model.ops.words(np.atleast_1d(res)) if self.warm else []
        return [pid & 0x7FFFFFFF | int(r.flag) << 31] + r.words + res_words

    async def recv(self) -> tuple[int, bool, list[int]]:
        f = await self.sink.recv()
        d = list(f.tdata)
        n = self.N + (2 if self.warm else 1)
        assert len(d) == n, f"output frame of {len(d)} words, expected {n}"
        return d[0] & 0x7FFFFFFF, bool(d[0] >> 31), d[1:]

    async def wait_idle(self):
        for _ in range(100000):
            v, _ = await self.read(self.rm["STATUS"])
            if not v & 1:
                return
        raise AssertionError("core never became idle")

    async def run_batch(self, problems, tag=""):
        """Send (id, diag, b[, d, z0]) problems, receive as many frames, check each against the model by id (and
        ||r_0|| in the warm form)."""
        exp, res = {}, {}
        for pid, *data in problems:
            exp[pid], res[pid] = self.expect(*data, pid=pid)
        for pid, *data in problems:
            await self.send(pid, *data)
        if self.warm and len(problems) % self.P:
            await self.src.wait()
            await self.close()
        got = {}
        for _ in problems:
            pid, flag, z = await self.recv()
            assert pid in exp and pid not in got, f"{tag}: unexpected or repeated id {pid}"
            got[pid] = (flag, z)
        for pid, r in exp.items():
            flag, z = got[pid]
            assert flag == r.flag, f"{tag}: id {pid}: flag {flag} != model {r.flag}"
            if not r.flag:
                want = self.answer(pid, r, res[pid])[1:]
                bad = [i for i in range(len(want)) if z[i] != want[i]]
                assert not bad, (f"{tag}: id {pid}: {len(bad)} words differ, first at {bad[0]}: "
                                 f"RTL {z[bad[0]]:#010x} model {want[bad[0]]:#010x}")
        return exp


@cocotb.test(timeout_time=TIMEOUT_MS, timeout_unit="ms")
async def bitexact_random(dut):
    """Batches of random problems (full, partial by the flush timeout), random Imax, random idle and backpressure
    on both streams: every word equals the golden model, every id comes back once with its own solution."""
    tb = MinresTB(dut, seed=int(os.environ.get("CORE_SEED") or 11))
    await tb.reset()
    total = int(os.environ.get("CORE_RANDOM") or "12")
    sent, k = 0, 0
    while sent < total:
        tb.backpressure(k % 2 == 1)
        if k % 3 == 1:
            await tb.wait_idle()
            await tb.set_imax(tb.rng.randint(1, 2 * tb.core["iterations"]))
        cnt = min(total - sent, tb.rng.choice([tb.P, tb.P, 2 * tb.P, max(1, tb.P // 2), 1]))
        probs = [(tb.rng.getrandbits(31), *tb.random_problem()) for _ in range(cnt)]
        if len({p[0] for p in probs}) < cnt:
            continue
        await tb.run_batch(probs, f"batch {k}")
        sent += cnt
        k += 1
    tb.backpressure(False)
    st, _ = await tb.read(tb.rm["STATUS"])
    assert not st >> STATUS_NONFINITE & 1, "NONFINITE set without non-finite data"
    solves, _ = await tb.read(tb.rm["SOLVES"])
    assert solves == total, f"SOLVES {solves} != {total}"
    measure({"test": "bitexact_random", "cases": total})


@cocotb.test(timeout_time=TIMEOUT_MS, timeout_unit="ms")
async def cycles_per_iteration(dut):
    """Batch cycles at Imax = k and k + 1 (P problems each): their difference is the measured cycles per MINRES
    iteration; both equal the formula of core.json."""
    tb = MinresTB(dut, seed=5)
    await tb.reset()
    meas = {}
    for imax in (3, 4):
        await tb.wait_idle()
        await tb.set_imax(imax)
        probs = [(100 * imax + q, *tb.random_problem()) for q in range(tb.P)]
        await tb.run_batch(probs, f"imax {imax}")
        meas[imax], _ = await tb.read(tb.rm["LAST_CYCLES"])
        assert meas[imax] == tb.core["batch_cycles_imax0"] + imax * tb.core["cycles_per_iteration"], meas
    per_it = meas[4] - meas[3]
    reg, _ = await tb.read(tb.rm["CYCLES_PER_ITER"])
    assert per_it == reg == tb.core["cycles_per_iteration"], (per_it, reg)
    measure({"test": "cycles", "cycles_per_iteration": per_it, "batch_cycles": meas,
              "PN_plus_P": tb.P * tb.N + tb.P})


@cocotb.test(timeout_time=TIMEOUT_MS, timeout_unit="ms")
async def nonfinite_flagged(dut):
    """NaN in the matrix data, Inf in b: those problems come back flagged (id bit 31), the others of the same
    batch exact; STATUS.NONFINITE is set and cleared by writing 1; the core goes on with the next batch."""
    tb = MinresTB(dut, seed=7)
    await tb.reset()
    await tb.set_imax(5)
    probs = []
    for q in range(tb.P):
        data = tb.random_problem()  # (diag, b[, d, z0])
        if q == 0:
            data[0][tb.rng.randrange(len(data[0]))] = np.nan
        elif q == 1 % tb.P and tb.P > 1:
            data[1][tb.rng.randrange(len(data[1]))] = np.inf
        probs.append((q + 1, *data))
    exp = await tb.run_batch(probs, "nonfinite")
    assert exp[1].flag
    st, _ = await tb.read(tb.rm["STATUS"])
    assert st >> STATUS_NONFINITE & 1, "NONFINITE not set"
    assert await tb.write(tb.rm["STATUS"], 1 << STATUS_NONFINITE) == AxiResp.OKAY
    st, _ = await tb.read(tb.rm["STATUS"])
    assert not st >> STATUS_NONFINITE & 1, "NONFINITE not cleared"
    await tb.run_batch([(77, *tb.random_problem())], "after")
    ident, _ = await tb.read(tb.rm["ID"])
    assert ident == 0x4D4E5231
