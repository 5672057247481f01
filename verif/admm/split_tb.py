"""cocotb tests of the heterogeneous split of the ADMM family (mpc_cores/admm/split.py).

Toplevel the matrix-vector block `<module>_linstep` (LINSTEP_OUT: its generator output):
- `linstep_words`: answers against the bit-exact LinStep word for word with every tuser flag, the cycle contract of
  linstep.json (latency, period of back-to-back frames), random idle and backpressure, words outside the operand
  width, a misplaced tlast, reset in the middle of a frame;
- `split_closed_loop`: the closed loop of CL_SPEC in which the generated C (`<p>_solve_split`, loaded from C_DIR
  with the ADMM design's CORE_CFG) runs the method and every s = M11 v comes from the block; at every step its words
  and flags equal the C's own solve and the golden model. Writes the parameter words and the answers to CL_RESULT.

Toplevel the ADMM core itself (CORE_OUT):
- `replay`: the parameter words of REPLAY_IN through the core, all in hardware; its words to REPLAY_OUT.
"""
from __future__ import annotations

import json
import os
import random
import tempfile
from pathlib import Path

import cocotb
import numpy as np
from cocotb.clock import Clock
from cocotb.task import bridge, resume
from cocotb.triggers import ClockCycles, ReadOnly, RisingEdge
from cocotbext.axi import AxiStreamBus, AxiStreamFrame, AxiStreamSink, AxiStreamSource

from mpc_cores.admm.split import OVF_ROW, SAT_IN, TLAST_ERR, LinStep

TIMEOUT_MS = 2000


def _hi(sig) -> bool:
    return str(sig.value) == "1"


class LinStepTB:
    """The block, its model, and a monitor of the stream handshakes (cycles of last input beats, first output
    words)."""

    def __init__(self, dut, seed: int):
        out = Path(os.environ["LINSTEP_OUT"])
        self.meta = json.loads((out / "linstep.json").read_text())
        self.model = LinStep(json.loads((out / "config.json").read_text()))
        self.n = self.meta["n"]
        self.dut, self.rng = dut, random.Random(seed)
        self.iw, self.ow = self.meta["in_stream_width"], self.meta["out_stream_width"]
        cocotb.start_soon(Clock(dut.clock, 10, unit="ns").start())
        self.src = AxiStreamSource(AxiStreamBus.from_prefix(dut, "s_axis"), dut.clock, dut.reset, byte_lanes=1)
        self.sink = AxiStreamSink(AxiStreamBus.from_prefix(dut, "m_axis"), dut.clock, dut.reset, byte_lanes=1)
        self.cycle, self.in_last, self.out_first = 0, [], []
        cocotb.start_soon(self._monitor())

    async def _monitor(self):
        d, first = self.dut, True
        while True:
            await RisingEdge(d.clock)
            await ReadOnly()
            self.cycle += 1
            if _hi(d.reset):
                first = True
                continue
            if _hi(d.s_axis_tvalid) and _hi(d.s_axis_tready) and _hi(d.s_axis_tlast):
                self.in_last.append(self.cycle)
            if _hi(d.m_axis_tvalid):
                if first:
                    self.out_first.append(self.cycle)
                first = _hi(d.m_axis_tready) and _hi(d.m_axis_tlast)

    async def reset(self):
        self.dut.reset.value = 1
        await ClockCycles(self.dut.clock, 3)
        self.dut.reset.value = 0
        await RisingEdge(self.dut.clock)
        self.in_last.clear()
        self.out_first.clear()

    def backpressure(self, on: bool):
        def gen(p):
            while True:
                yield self.rng.random() < p
        for ep, prob in ((self.src, 0.3), (self.sink, 0.4)):
            ep.set_pause_generator(gen(prob) if on else None)
            if not on:
                ep.pause = False

    def random_v(self, outside: float = 0.0) -> np.ndarray:
        """Words of v in the operand width; with probability `outside` per word, beyond it (in the stream word)."""
        ow, iw = self.meta["op_width"], self.iw
        v = [self.rng.randint(-(1 << (ow - 1)), (1 << (ow - 1)) - 1) >> self.rng.randint(0, ow - 2)
             for _ in range(self.n)]
        for j in range(self.n):
            if iw > ow and self.rng.random() < outside:
                v[j] = self.rng.choice([1, -1]) * self.rng.randint(1 << (ow - 1), (1 << (iw - 1)) - 1)
        return np.array(v, dtype=np.int64)

    async def send(self, v, split_at: int | None = None):
        words = [int(x) & ((1 << self.iw) - 1) for x in v]
        parts = [words] if split_at is None else [words[:split_at], words[split_at:]]
        for p in parts:
            await self.src.send(AxiStreamFrame(tdata=p))

    async def recv(self) -> tuple[np.ndarray, list[int]]:
        f = await self.sink.recv()
        s = [x - (1 << self.ow) if x >> (self.ow - 1) & 1 else x for x in f.tdata]
        user = f.tuser if isinstance(f.tuser, list) else [f.tuser] * len(s)
        return np.array(s, dtype=np.int64), [int(u) for u in user]

    def check(self, got, v, tlast_err: bool = False, tag: str = ""):
        s, user = got
        s_m, ovf, sat = self.model(v)
        want = [int(o) * OVF_ROW | int(sat) * SAT_IN | int(tlast_err) * TLAST_ERR for o in ovf]
        assert len(s) == self.n, f"{tag}: {len(s)} words"
        assert np.array_equal(s, s_m), f"{tag}: s differs at rows {np.nonzero(s != s_m)[0].tolist()}"
        assert user == want, f"{tag}: tuser {user} != {want}"

    async def matvec(self, v) -> tuple[np.ndarray, bool]:
        """One frame through the block, checked against the model: (s, a row saturated)."""
        await self.send(v)
        got = await self.recv()
        self.check(got, v, tag="split")
        return got[0], any(u & OVF_ROW for u in got[1])


@cocotb.test(timeout_time=TIMEOUT_MS, timeout_unit="ms")
async def linstep_words(dut):
    tb = LinStepTB(dut, seed=5)
    await tb.reset()
    lat, period = tb.meta["latency_cycles"], tb.meta["period_cycles"]
    # one frame at a time, sink ready: the latency contract
    for k in range(4):
        v = tb.random_v(outside=0.1 if k == 3 else 0.0)
        await tb.send(v)
        tb.check(await tb.recv(), v, tag=f"single {k}")
        assert tb.out_first[-1] - tb.in_last[-1] == lat, (tb.in_last, tb.out_first, lat)
        await ClockCycles(dut.clock, tb.rng.randint(0, 5))
    # frames always waiting: one answer every period_cycles
    vs = [tb.random_v() for _ in range(5)]
    n0 = len(tb.out_first)
    for v in vs:
        await tb.send(v)
    for k, v in enumerate(vs):
        tb.check(await tb.recv(), v, tag=f"back-to-back {k}")
    gaps = np.diff(tb.out_first[n0:]).tolist()
    assert gaps == [period] * (len(vs) - 1), (gaps, period)
    # random idle and backpressure on both streams, words beyond the operand width, a misplaced tlast
    tb.backpressure(True)
    sent = []
    for k in range(16):
        v = tb.random_v(outside=0.05)
        split = tb.rng.randint(1, tb.n - 1) if k % 5 == 2 and tb.n > 1 else None
        sent.append((v, split is not None))
        cocotb.start_soon(tb.send(v, split))
        await ClockCycles(dut.clock, tb.rng.randint(0, 2 * tb.n))
    for k, (v, err) in enumerate(sent):
        tb.check(await tb.recv(), v, tlast_err=err, tag=f"backpressure {k}")
    tb.backpressure(False)
    # reset in the middle of a frame: the next frame is answered alone
    part = tb.random_v()[: max(1, tb.n // 2)]
    tb.src.send_nowait(AxiStreamFrame(tdata=[int(x) & ((1 << tb.iw) - 1) for x in part]))
    await ClockCycles(dut.clock, tb.n)
    tb.src.clear()
    await tb.reset()
    await ClockCycles(dut.clock, 2)
    v = tb.random_v()
    await tb.send(v)
    tb.check(await tb.recv(), v, tag="after reset")
    await ClockCycles(dut.clock, 4 * tb.n)
    assert tb.sink.empty(), "an answer too many"


@cocotb.test(timeout_time=20 * TIMEOUT_MS, timeout_unit="ms")
async def split_closed_loop(dut):
    from mpc_cores.admm.control import _AdmmController, admm_references
    from mpc_cores.admm.model import AdmmFixed
    from mpc_cores.closedloop import closed_loop
    from mpc_cores.csrc import emit, harness
    from mpc_cores.fixed import quantize
    from mpc_cores.problem import load_spec

    tb = LinStepTB(dut, seed=9)
    await tb.reset()
    tb.backpressure(True)
    problem = load_spec(os.environ["CL_SPEC"])
    cfg = json.loads(Path(os.environ["CORE_CFG"]).read_text())
    module = tb.meta["module"].removesuffix("_linstep")
    lib = harness.load(os.environ["C_DIR"], emit.names(module), cfg, split=True, build_dir=tempfile.mkdtemp())
    model = AdmmFixed(cfg)
    b = int(cfg["frac_bits"])
    hw_state, sw_state = lib.new_state(), lib.new_state()
    linstep = resume(tb.matvec)
    record = {"w": [], "words": [], "flags": [], "calls": 0}

    def on_hw(v):
        record["calls"] += 1
        return linstep(v)

    class Split(_AdmmController):
        async def step(self, x, r):
            w = quantize(self._w(x, r), b)
            words, flags, _ = await bridge(lib.solve)(hw_state, w, None, linstep=on_hw)
            assert lib.linstep_error is None, lib.linstep_error
            sw_words, sw_flags, _ = lib.solve(sw_state, w, None)
            g = model.solve(w)
            assert np.array_equal(words, sw_words) and flags == sw_flags, (words, sw_words, flags, sw_flags)
            assert hw_state.raw == sw_state.raw, "the state kept (z, nu) differs from the C solve's"
            assert np.array_equal(words, g.z[: self.nu]) and (flags[1], flags[2]) == (g.sat, g.overflow)
            record["w"].append([int(a) for a in w])
            record["words"].append([int(a) for a in words])
            record["flags"].append([int(f) for f in flags])
            return self._apply(words / float(1 << b))

    steps, hold = int(os.environ.get("CL_STEPS", "12")), int(os.environ.get("CL_HOLD", "4"))
    refs = admm_references(problem, steps, hold, seed=int(os.environ.get("CL_SEED", "0")))
    traj = await closed_loop(problem, Split(problem, int(cfg["nu"]), bool(cfg.get("rate", True))), np.zeros(problem.nx),
                             refs)
    record["x"] = traj.x.tolist()
    Path(os.environ["CL_RESULT"]).write_text(json.dumps(record))


@cocotb.test(timeout_time=20 * TIMEOUT_MS, timeout_unit="ms")
async def replay(dut):
    from mpc_cores.driver import TB

    tb = TB(dut, seed=11)
    await tb.reset()
    seq = json.loads(Path(os.environ["REPLAY_IN"]).read_text())["w"]
    words = []
    for w in seq:
        await tb.send(w)
        words.append(await tb.recv())
    st = await tb.status()
    Path(os.environ["REPLAY_OUT"]).write_text(json.dumps({"words": words, "status": st}))
