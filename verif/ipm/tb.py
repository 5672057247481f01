"""cocotb testbench of the interior-point core (Verilator), through its AXI4-Stream and AXI4-Lite interfaces.

Environment: CORE_OUT = the generator's output folder (core.json, config.json); CORE_ROUNDS = rounds of 2P
samples in the bit-exact test; CORE_MEASURE = file to append measurements to (JSON lines); CORE_SEED = the seed of
the bit-exact test (default 3); CORE_TIMEOUT_MS = the simulated-time limit of each scenario in ms (default 2000).
Every answer word is compared with the golden model of the generated core (mpc_cores.ipm.core_model, from
config.json).
"""
from __future__ import annotations

import os

import cocotb
import numpy as np
from cocotb.triggers import ClockCycles, RisingEdge
from cocotbext.axi import AxiResp, AxiStreamFrame

from mpc_cores.driver import AxiDriver, measure
from mpc_cores.ipm.core_model import IpmCoreModel

TIMEOUT_MS = float(os.environ.get("CORE_TIMEOUT_MS") or 2000)


class IpmTB(AxiDriver):
    def __init__(self, dut, seed: int = 1, **kw):
        super().__init__(dut, seed, **kw)
        c = self.core
        self.P, self.n, self.m, self.ny = c["P"], c["n"], c["m"], c["ny"]
        self.C = 2 * self.P
        self.model = IpmCoreModel(self.cfg, self.P)
        self.nrng = np.random.default_rng(seed)
        self.warm = True
        self.out_all = False
        # multiplexed: a frame carries x^, (x_s, u_s,i) and F, an answer the T planned moves after u0 and mu
        self.mux = bool(self.cfg.get("multiplexed"))
        self.T = self.cfg["minres"]["T"]

    def state(self, scale: float = 1.0):
        """a random state and reference (float values); multiplexed: the state and ((x_s, u_s,i), F)"""
        rest = self.n + 1 + self.n * self.T if self.mux else self.ny
        return self.nrng.uniform(-scale, scale, self.n), self.nrng.uniform(-0.5, 0.5, rest)

    def words(self, x, r) -> list[int]:
        return self.model.mr.to_words(np.concatenate([x, r]))

    @staticmethod
    def frame(ch: int, tag: int, data: list[int]) -> list[int]:
        """The words of one input frame: the id word (channel, tag), then x and r."""
        return [(ch << 24) | (tag & 0xFFFFFF)] + list(data)

    async def send(self, ch: int, tag: int, data: list[int]):
        await self.src.send(AxiStreamFrame(tdata=self.frame(ch, tag, data)))

    async def recv(self) -> tuple[int, int, list[int], int]:
        f = await self.sink.recv()
        d = list(f.tdata)
        want = self.m + 4 + (self.T if self.mux else 0) + (self.core["N"] + self.n + self.m if self.out_all else 0)
        assert len(d) == want, f"answer of {len(d)} words, expected {want}"
        return (d[0] >> 24) & 0x3F, d[0] & 0xFFFFFF, d[1:-1], d[-1]

    async def set_ctrl(self, hold: bool = False):
        bit = self.rm.CTRL_BITS
        word = int(self.warm) << bit["WARM_START"] | int(hold) << bit["HOLD"] | int(self.out_all) << bit["OUT_ALL"]
        assert await self.write(self.rm["CTRL"], word) == AxiResp.OKAY

    async def set_reg(self, name: str, value: int):
        assert await self.write(self.rm[name], value) == AxiResp.OKAY

    async def round(self, jobs, tag: str = "") -> dict:
        """jobs: (channel, tag, data words); every channel at most once. Sends all, receives as many answers and
        checks each against the model; returns tag -> answer."""
        exp = {}
        for ch, t, data in jobs:
            exp[t] = self.model.solve(ch % self.C, None, x_words=data, warm=self.warm,  # the channel modulo 2P
                                      out_all=self.out_all)
        sends = cocotb.start_soon(self._send_all(jobs))
        got = {}
        for _ in jobs:
            ch, t, words, status = await self.recv()
            assert t in exp and t not in got, f"{tag}: unexpected or repeated tag {t}"
            got[t] = (ch, words, status)
        await sends
        for ch, t, _ in jobs:
            gch, words, status = got[t]
            e = exp[t]
            assert gch == ch, f"{tag}: tag {t} came back on channel {gch}, sent on {ch}"
            assert status == e.status, f"{tag}: tag {t}: status {status:#x} != model {e.status:#x}"
            if not e.nonfinite:
                bad = [i for i in range(len(e.words)) if words[i] != e.words[i]]
                assert not bad, (f"{tag}: tag {t} (channel {ch}): {len(bad)} words differ, first {bad[0]}: "
                                 f"RTL {words[bad[0]]:#010x} model {e.words[bad[0]]:#010x}")
        return exp

    async def _send_all(self, jobs):
        for ch, t, data in jobs:
            await self.send(ch, t, data)


@cocotb.test(timeout_time=TIMEOUT_MS, timeout_unit="ms")
async def bitexact_inflight(dut):
    """Rounds of samples on all 2P channels in random order (2P problems in flight with different data), warm
    starts carried per channel, random I_NW and I_MR between rounds, random idle and backpressure on both streams,
    one round with CTRL.OUT_ALL (z and the steady state in the answer): every answer word and status equals the
    model's."""
    tb = IpmTB(dut, seed=int(os.environ.get("CORE_SEED") or 3))
    await tb.reset()
    rounds = int(os.environ.get("CORE_ROUNDS") or "3")
    tag = 0
    for k in range(rounds):
        tb.backpressure(k % 2 == 1)
        if k in (1, 2):     # the answers with the whole iterate and the steady state (CTRL.OUT_ALL), then without
            tb.out_all = k == 1
            await tb.set_ctrl()
        if k == 2:
            inw, imr = tb.rng.randint(1, 4), tb.rng.randint(1, 9)
            await tb.set_reg("INW", inw)
            await tb.set_reg("IMAX", imr)
            tb.model.i_nw, tb.model.i_mr = inw, imr
        chans = list(range(tb.C))
        tb.rng.shuffle(chans)
        chans = chans[: tb.rng.randint(1, tb.C)] if k % 3 == 2 else chans
        jobs = []
        for ch in chans:
            tag += 1
            jobs.append((ch, tag, tb.words(*tb.state())))
        await tb.round(jobs, f"round {k}")
    tb.backpressure(False)
    st = await tb.status()
    assert not st["NONFINITE"] and not st["CHANNEL"] and not st["TLAST_ERROR"] and not st["BUSY"], st
    solves, _ = await tb.read(tb.rm["SOLVES"])
    assert solves == tag, f"SOLVES {solves} != {tag}"
    measure({"test": "bitexact_inflight", "answers": tag})


@cocotb.test(timeout_time=TIMEOUT_MS, timeout_unit="ms")
async def latency(dut):
    """2P problems sent back to back on an idle core (cold starts, then warm, then warm at other I_MR and I_NW): the
    cycles from each id word to its answer's status word (LAST_CYCLES of the last answer, and the testbench's own
    count for all) against the cycle model of core.json."""
    tb = IpmTB(dut, seed=5)
    await tb.reset()
    now = [0]

    async def count():
        while True:
            await RisingEdge(dut.clock)
            now[0] += 1
    cocotb.start_soon(count())
    trace = []
    if os.environ.get("CORE_TRACE"):
        cocotb.start_soon(_trace(dut, now, trace))
    took, answered = {}, {}
    cocotb.start_soon(_handshakes(dut, now, tb.core["in_words"], took, answered))
    rec = {}
    # cold, warm, then warm at I_MR = 1 (Stage 1 sets the pace), at a large I_MR with I_NW = 2 (MINRES does),
    # with CTRL.OUT_ALL (longer answers), and P + 1 problems: the second group's batch is partial (closed at once)
    i_nw, i_mr = tb.model.i_nw, tb.model.i_mr
    settings = [None, None, (i_nw, 1, False), (2, 2 * i_mr + 3, False), (i_nw, i_mr, True), (i_nw, i_mr, False)]
    for rnd, setting in enumerate(settings):
        if setting:
            tb.model.i_nw, tb.model.i_mr, tb.out_all = setting
            await tb.set_reg("INW", setting[0])
            await tb.set_reg("IMAX", setting[1])
            await tb.set_ctrl()
        chans = range(tb.C // 2 + 1) if rnd == 5 else range(tb.C)
        jobs = [(ch, 100 * rnd + ch, tb.words(*tb.state())) for ch in chans]
        t0 = now[0]
        await tb.round(jobs, f"latency {rnd}")
        rec[rnd] = {"all_done": now[0] - t0, "i_nw": tb.model.i_nw, "i_mr": tb.model.i_mr, "out_all": tb.out_all,
                    "latency": {ch: answered[t] - took[t] for ch, t, _ in jobs}}
        rec[rnd]["last_cycles"], _ = await tb.read(tb.rm["LAST_CYCLES"])
        last = max((answered[t], ch) for ch, t, _ in jobs)[1]
        assert rec[rnd]["last_cycles"] == rec[rnd]["latency"][last], "LAST_CYCLES is not the last answer's latency"
    measure({"test": "latency", "rounds": rec, **({"trace": trace} if trace else {})})


async def _handshakes(dut, now, in_words: int, took: dict, answered: dict):
    """the cycle of each frame's id word handshake and of each answer's status word, by tag"""
    i, tag = 0, None
    while True:
        await RisingEdge(dut.clock)
        if dut.s_axis_tvalid.value and dut.s_axis_tready.value:
            if i == 0:
                took[int(dut.s_axis_tdata.value) & 0xFFFFFF] = now[0]
            i = (i + 1) % in_words
        if dut.m_axis_tvalid.value and dut.m_axis_tready.value:
            if tag is None:
                tag = int(dut.m_axis_tdata.value) & 0xFFFFFF
            if dut.m_axis_tlast.value:
                answered[tag] = now[0]
                tag = None


async def _trace(dut, now, trace):
    """events of the two stages, by cycle: Stage 1 starts (program, slot) and dones, MINRES frames in (last word),
    MINRES state changes (bits: batch 0 running, batch 1 running, batch 0 answers out, batch 1 answers out),
    answers (status word)"""
    prev = None
    while True:
        await RisingEdge(dut.clock)
        t = now[0]
        st1, mr = dut.st1, dut.mr
        if st1.start.value and (not st1.busy.value or st1.done.value):
            trace.append((t, "start", int(st1.prog.value), int(st1.slot.value)))
        if st1.done.value:
            trace.append((t, "done"))
        if mr.s_axis_tvalid.value and mr.s_axis_tready.value and mr.s_axis_tlast.value:
            trace.append((t, "mr_in_last"))
        st = int(mr.active_0.value) | int(mr.active_1.value) << 1 | int(mr.doneB_0.value) << 2 | \
            int(mr.doneB_1.value) << 3
        if st != prev:
            trace.append((t, "mr_state", st))
            prev = st
        if dut.m_axis_tvalid.value and dut.m_axis_tready.value and dut.m_axis_tlast.value:
            trace.append((t, "answer"))


@cocotb.test(timeout_time=TIMEOUT_MS, timeout_unit="ms")
async def nonfinite_hold_reset(dut):
    """NaN and Inf in x: those answers flagged (status bit 0, STATUS.NONFINITE), the others exact, the flagged
    channel's next sample cold and exact; a channel field beyond 2P taken modulo 2P and flagged; HOLD keeps a frame waiting until released; a reset in the middle of a
    batch loses nothing after it (the core answers the next samples exactly, from cold starts)."""
    tb = IpmTB(dut, seed=7)
    await tb.reset()
    jobs = []
    for ch in range(tb.C):
        x, r = tb.state()
        if ch == 0:
            x[0] = np.nan
        if ch == 1:
            x[-1] = np.inf
        jobs.append((ch, ch + 1, tb.words(x, r)))
    exp = await tb.round(jobs, "nonfinite")
    assert exp[1].nonfinite and exp[2].nonfinite
    st = await tb.status()
    assert st["NONFINITE"], "NONFINITE not set"
    assert await tb.write(tb.rm["STATUS"], 1 << tb.rm.STATUS_BITS["NONFINITE"]) == AxiResp.OKAY
    assert not (await tb.status())["NONFINITE"]
    await tb.round([(0, 50, tb.words(*tb.state())), (1, 51, tb.words(*tb.state()))], "after nonfinite")
    # a channel field beyond 2P: taken modulo 2P (the answer echoes the field), STATUS.CHANNEL set
    await tb.round([(tb.C + 1, 55, tb.words(*tb.state()))], "channel beyond 2P")
    st = await tb.status()
    assert st["CHANNEL"], "CHANNEL not set"
    # HOLD: a frame waits
    await tb.set_ctrl(hold=True)
    frame = (0, 60, tb.words(*tb.state()))
    e = tb.model.solve(0, None, x_words=frame[2])
    send = cocotb.start_soon(tb.send(*frame))
    await ClockCycles(dut.clock, 200)
    assert not dut.m_axis_tvalid.value and not dut.s_axis_tready.value, "HOLD: the frame was taken"
    await tb.set_ctrl(hold=False)
    await send
    ch, t, words, status = await tb.recv()
    assert (t, words, status) == (60, e.words, e.status), "after HOLD"
    # reset in the middle of a batch
    jobs = [(ch, 70 + ch, tb.words(*tb.state())) for ch in range(tb.C)]
    for j in jobs:
        await tb.send(*j)
    await ClockCycles(dut.clock, 1500)
    tb.src.clear()
    tb.sink.clear()
    await tb.reset()
    await ClockCycles(dut.clock, 5)
    tb.sink.clear()
    tb.model.reset()
    await tb.round([(ch, 90 + ch, tb.words(*tb.state())) for ch in range(tb.C)], "after reset")


@cocotb.test(timeout_time=TIMEOUT_MS, timeout_unit="ms")
async def infeasible(dut):
    """A state far outside what the state constraints allow: the answer is flagged (not converged or non-finite,
    as the model says), never marked good, and the core answers the next sample exactly."""
    tb = IpmTB(dut, seed=9)
    await tb.reset()
    if not tb.cfg.get("hard_states"):
        return
    x, r = tb.state()
    x[:] = 50.0
    exp = await tb.round([(0, 1, tb.words(x, r))], "infeasible")
    assert exp[1].status & 3, "the model marks the infeasible problem good"
    await tb.round([(1, 2, tb.words(*tb.state()))], "after infeasible")
