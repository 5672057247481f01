"""cocotb testbench of the Stage 1 engine of the interior-point core (src/main/scala/ipm/Stage1Engine.scala) in
Verilator, against the interpreter of the instruction set (mpc_cores/ipm/machine.py).

Environment: STAGE1_OUT = the generator's output folder (config.json, hw.json) with tb.json (what to run: the
names of the random programs and runs per program; the interior-point problem and its parameters);
STAGE1_MEASURE = a file to append measurements to (JSON lines).

Scenarios (each a cocotb test):
  random_programs  random programs on random slot contents (NaN, infinities, subnormals, signed zeros), the slot
                   loaded and read back whole through the `load` and `dump` programs, every OUT word and every
                   memory word equal to the interpreter's (NaN compared as the canonical NaN); half the runs with
                   random idle input and backpressure on the output
  ipm_programs     sample, cold or warm start, I_NW times (linearise, MINRES on the interpreter's output fed
                   back on IN, update), output, on every slot in turn; OUT words and slot memories compared
  cycles           every program of the ROM once without stream stalls: start to done equals
                   mpc_cores.ipm.isa.cycles and hw.json
"""
from __future__ import annotations

import json
import os
import random
from collections import deque
from pathlib import Path

import cocotb
import numpy as np
from cocotb.clock import Clock
from cocotb.triggers import Event, ReadOnly, RisingEdge, with_timeout

from mpc_cores.ipm import isa
from mpc_cores.ipm import stage1_config as sc
from mpc_cores.ipm.machine import words
from verif.ipm.random_programs import random_words

QNAN = 0x7FC00000
f32 = np.float32


def strict(w, keep: bool) -> int:
    """The word the engine must hold: a computed NaN is the canonical one; kept data keeps its bits."""
    w = int(w) & 0xFFFFFFFF
    return QNAN if not keep and (w >> 23) & 0xFF == 0xFF and w & 0x7FFFFF else w


def to_f32(ws) -> np.ndarray:
    return np.array([int(w) & 0xFFFFFFFF for w in ws], dtype=np.uint32).view(f32)


class Stage1TB:
    def __init__(self, dut, seed: int = 1):
        self.dut = dut
        out = Path(os.environ["STAGE1_OUT"])
        self.cfg = json.loads((out / "config.json").read_text())
        self.hw = json.loads((out / "hw.json").read_text())
        tbf = out / "tb.json"
        self.spec = json.loads(tbf.read_text()) if tbf.exists() else {}
        self.measure = os.environ.get("STAGE1_MEASURE")
        self.progs = sc.programs(self.cfg)
        self.index = {p["name"]: p["index"] for p in self.hw["programs"]}
        self.hw_cycles = {p["name"]: p["cycles"] for p in self.hw["programs"]}
        self.lat = {k: self.cfg[f"lat_{k}"] for k in ("add", "mul", "div", "sqrt", "cmp")}
        self.slots, self.slot_words = self.cfg["slots"], self.cfg["slot_words"]
        self.rng = random.Random(seed)
        self.inq: deque = deque()
        self.outq: list = []
        self.p_idle = self.p_bp = 0.0
        self.cycle = 0
        self.reqs: deque = deque()   # (program index, slot) to start, in order
        self.pending = 0             # programs started and not done
        self.first = False           # the next start is the first of a chain
        self.done_event = Event()
        self.start_cycle = self.done_cycle = 0
        self.raw = np.ones((self.slots, self.slot_words), dtype=bool)
        cocotb.start_soon(Clock(dut.clock, 10, unit="ns").start())

    def record(self, **kw):
        if self.measure:
            with open(self.measure, "a") as f:
                f.write(json.dumps(kw) + "\n")

    async def reset(self):
        d = self.dut
        d.start.value = 0
        d.prog.value = 0
        d.slot.value = 0
        d.s_axis_tvalid.value = 0
        d.s_axis_tdata.value = 0
        d.s_axis_tlast.value = 0
        d.m_axis_tready.value = 0
        d.reset.value = 1
        for _ in range(3):
            await RisingEdge(d.clock)
        d.reset.value = 0
        await RisingEdge(d.clock)
        cocotb.start_soon(self._loop())

    async def _loop(self):
        """One iteration per cycle: drive the inputs, sample the handshakes before the edge. `start` is held with
        the next program of the chain until the engine takes it (idle, or on its `done` cycle)."""
        d = self.dut
        while True:
            sv = bool(self.inq) and self.rng.random() >= self.p_idle
            d.s_axis_tvalid.value = int(sv)
            d.s_axis_tdata.value = self.inq[0] if sv else self.rng.getrandbits(32)
            rdy = self.rng.random() >= self.p_bp
            d.m_axis_tready.value = int(rdy)
            st = bool(self.reqs)
            d.start.value = int(st)
            if st:
                d.prog.value, d.slot.value = self.reqs[0]
            await ReadOnly()
            busy, done = d.busy.value == 1, d.done.value == 1
            if done and self.pending:
                self.pending -= 1
                if not self.pending and not self.reqs:
                    self.done_cycle = self.cycle
                    self.done_event.set()
            if st and (not busy or done):
                self.reqs.popleft()
                if self.first:
                    self.start_cycle, self.first = self.cycle, False
                self.pending += 1
            if sv and d.s_axis_tready.value == 1:
                self.inq.popleft()
            if rdy and d.m_axis_tvalid.value == 1:
                self.outq.append((int(d.m_axis_tdata.value), int(d.m_axis_tlast.value)))
            await RisingEdge(d.clock)
            self.cycle += 1

    async def run(self, name, slot: int, words_in=(), n_out: int = 0, stalls: bool = False) -> tuple[list, int]:
        """Run a program on the engine, or a list of programs back to back (each started on its predecessor's
        `done` cycle); returns the OUT words and the cycles from the first start to the last done."""
        chain = [(name, slot)] if isinstance(name, str) else list(name)
        self.p_idle, self.p_bp = (0.3, 0.4) if stalls else (0.0, 0.0)
        self.inq.extend(int(w) & 0xFFFFFFFF for w in words_in)
        self.outq = []
        self.done_event = Event()
        want = sum(isa.cycles(self.progs[k], self.lat) for k, _ in chain)
        self.first = True
        self.reqs.extend((self.index[k], s) for k, s in chain)
        await with_timeout(self.done_event.wait(), 10 * (5 * want + 5000), "ns")   # 10 ns a cycle
        cycles = self.done_cycle - self.start_cycle
        for _ in range(20000):
            if len(self.outq) >= n_out:
                break
            await RisingEdge(self.dut.clock)
        for _ in range(4):
            await RisingEdge(self.dut.clock)
        assert not self.inq, f"{chain}: {len(self.inq)} input words left"
        assert len(self.outq) == n_out, f"{chain}: {len(self.outq)} output words, expected {n_out}"
        # tlast on the last word of every OUT instruction
        ends, k = set(), 0
        for i in (i for p, _ in chain for i in self.progs[p]):
            if i.op == "OUT":
                k += i.n
                ends.add(k - 1)
        last = {j for j, (_, t) in enumerate(self.outq) if t}
        assert last == ends, f"{chain}: tlast on words {sorted(last)}, expected {sorted(ends)}"
        if not stalls:
            hw = sum(self.hw_cycles[k] for k, _ in chain)
            assert cycles == want == hw, f"{chain}: {cycles} cycles, isa.cycles {want}, hw.json {hw}"
        return [w for w, _ in self.outq], cycles

    def interpret(self, machine, name: str, slot: int) -> list[int]:
        """Run a program on the interpreter instruction by instruction; return the OUT words the engine must
        give. Words are compared bit for bit: a NaN the program computed must be the canonical one, a word that
        only went through IN, the memory and OUT (loaded data, constants) keeps its bits (`raw` tracks which
        slot words hold such data)."""
        out = []
        chain = [(name, slot)] if isinstance(name, str) else list(name)
        for i, slot in ((i, s) for p, s in chain for i in self.progs[p]):
            raw = self.raw[slot]
            if i.op == "OUT":
                v = machine.read(i.a, i.n, slot)
                keep = [True] * i.n if i.a.space == "const" else [raw[a] for a in self.addrs(i.a, i.n)]
                out += [strict(w, k) for w, k in zip(v.view(np.uint32), keep)]
            machine.step(i, slot)
            if i.op != "OUT":
                raw[self.addrs(i.d, 1 if i.op in ("ACC", "MINRED") else i.n, dest=True)] = i.op == "IN"
        machine.outq.clear()
        return out

    def addrs(self, o, n: int, dest: bool = False) -> list[int]:
        if o.mode == "gather":
            return [o.addr + int(t) for t in self.cfg["tables"][o.table][:n]]
        return [o.addr] * n if (o.mode == "scalar" and not dest) else list(range(o.addr, o.addr + n))

    async def step(self, machine, name: str, slot: int, words_in=(), stalls=False, tag=""):
        """The program on the interpreter and on the engine: OUT words equal."""
        machine.inq.extend(list(to_f32(words_in)))
        want = self.interpret(machine, name, slot)
        got, cycles = await self.run(name, slot, words_in, len(want), stalls)
        bad = [k for k in range(len(want)) if got[k] != want[k]]
        assert not bad, (f"{tag}{name} slot {slot}: {len(bad)} of {len(want)} OUT words differ, first at {bad[0]}: "
                         f"RTL {got[bad[0]]:#010x} model {want[bad[0]]:#010x}")
        return want, cycles

    async def compare_slot(self, machine, slot: int, tag=""):
        got, _ = await self.run("dump", slot, (), self.slot_words)
        want = [strict(w, k) for w, k in zip(machine.mem[slot].view(np.uint32), self.raw[slot])]
        bad = [k for k in range(self.slot_words) if got[k] != want[k]]
        assert not bad, (f"{tag}slot {slot}: {len(bad)} memory words differ, first at {bad[0]}: "
                         f"RTL {got[bad[0]]:#010x} model {want[bad[0]]:#010x}")

    async def load_slot(self, machine, slot: int, ws):
        await self.run("load", slot, ws)
        machine.mem[slot] = to_f32(ws)
        self.raw[slot] = True

    def in_words(self, name: str) -> int:
        return sum(i.n for i in self.progs[name] if i.op == "IN")


@cocotb.test()
async def random_programs(dut):
    tb = Stage1TB(dut, seed=11)
    await tb.reset()
    spec = tb.spec.get("random")
    if not spec:
        return
    m = sc.machine(tb.cfg)
    runs = 0
    for r in range(spec["runs"]):
        for name in spec["programs"]:
            slot = tb.rng.randrange(tb.slots)
            few = tb.rng.random() < 0.5
            await tb.load_slot(m, slot, random_words(tb.rng, tb.slot_words, few))
            ins = random_words(tb.rng, tb.in_words(name), few)
            await tb.step(m, name, slot, ins, stalls=(runs % 2 == 1), tag=f"run {r}: ")
            await tb.compare_slot(m, slot, tag=f"run {r}, {name}: ")
            runs += 1
    tb.record(test="random_programs", runs=runs, cycles=tb.cycle)


def ipm_model(spec: dict):
    from mpc_cores.ipm.model import IpmModel
    from mpc_cores.ipm.sparse import sparse_mpc
    from mpc_cores.problem import load_spec, problem_from_dict

    p = load_spec(spec["spec"]) if "spec" in spec else problem_from_dict(spec["problem"], spec["problem"]["name"])
    return IpmModel(sparse_mpc(p), spec["i_nw"], spec["i_mr"], sigma=spec["sigma"], tau=spec["tau"],
                    precondition=spec["precondition"], lat_add=spec["lat_add"], start_value=spec["start_value"],
                    slots=spec["slots"], warm_floor=spec["warm_floor"])


@cocotb.test()
async def ipm_programs(dut):
    tb = Stage1TB(dut, seed=12)
    await tb.reset()
    spec = tb.spec.get("ipm")
    if not spec:
        return
    model = ipm_model(spec)
    m, st1, p = model.machine, model.st1, model.s.problem
    assert model.L == tb.cfg["lat_add"] and m.mem.shape == (tb.slots, tb.slot_words)
    for k, prog in st1.programs.items():   # the configured ROM holds the model's programs
        assert [(i.op, i.n, i.d, i.a, i.b) for i in prog] == [(i.op, i.n, i.d, i.a, i.b) for i in tb.progs[k]], k
    for s in range(tb.slots):
        await tb.load_slot(m, s, [0] * tb.slot_words)
    nrng = np.random.default_rng(spec.get("seed", 5))
    npr, N = model.npr, model.N
    every = spec.get("compare_every_program", True)
    progs = 0
    for sample in range(spec["samples"]):
        stalls = sample % 2 == 1

        async def run(name, slot, ins=()):
            nonlocal progs
            out, _ = await tb.step(m, name, slot, ins, stalls, tag=f"sample {sample}: ")
            progs += 1
            if every:
                await tb.compare_slot(m, slot, tag=f"sample {sample}, after {name}: ")
            return out

        for s in range(tb.slots):
            x = nrng.uniform(-1.5, 1.5, p.nx).astype(f32)
            r = nrng.uniform(-0.6, 0.6, p.ny).astype(f32)
            await run("sample", s, words(np.concatenate([x, r])) if p.ny else words(x))
        for s in range(tb.slots):
            await run("cold" if sample == 0 else "warm", s)
        for it in range(spec["i_nw"]):
            for s in range(tb.slots):
                out = to_f32(await run("linearise", s))
                diag, d, bh, z0 = out[:npr], out[npr:npr + N], out[npr + N:npr + 2 * N], out[npr + 2 * N:]
                xs, _ = model.minres(diag, d, bh, z0)
                await run("receive", s, words(xs))
                await run("update", s)
        for s in range(tb.slots):
            u_mu = to_f32(await run("output", s))
            assert np.all(np.isfinite(u_mu)) and u_mu[-1] > 0, f"sample {sample}, slot {s}: u0, mu = {u_mu}"
            await tb.compare_slot(m, s, tag=f"sample {sample}, end: ")
    tb.record(test="ipm_programs", programs=progs, cycles=tb.cycle)


@cocotb.test()
async def cycles(dut):
    tb = Stage1TB(dut, seed=13)
    await tb.reset()
    m = sc.machine(tb.cfg)
    for s in range(tb.slots):   # the engine's memory as the interpreter's
        await tb.load_slot(m, s, random_words(tb.rng, tb.slot_words))
    got = {}
    for name in tb.index:
        slot = tb.rng.randrange(tb.slots)
        if name not in ("load", "dump"):
            await tb.load_slot(m, slot, random_words(tb.rng, tb.slot_words))
        ins = random_words(tb.rng, tb.in_words(name))
        _, c = await tb.step(m, name, slot, ins, stalls=False)   # run() checks the cycles
        got[name] = c
    # back to back: every program but load and dump, each started on the done cycle of the previous one
    # on alternating slots
    chain = [(k, j % tb.slots) for j, k in enumerate(k for k in tb.index if k not in ("load", "dump"))]
    ins = random_words(tb.rng, sum(tb.in_words(k) for k, _ in chain))
    _, c = await tb.step(m, chain, 0, ins, stalls=False)
    for s in range(tb.slots):
        await tb.compare_slot(m, s, tag="after the chain: ")
    got["chain"] = c
    tb.record(test="cycles", measured=got, isa={k: isa.cycles(v, tb.lat) for k, v in tb.progs.items()},
              hw=tb.hw_cycles, chain=[k for k, _ in chain])
