"""cocotb protocol fuzz of a generated core of any kind (Verilator): AXI4-Lite traffic against the register map of
its SystemRDL description, during solves too; tlast errors, tvalid gaps and backpressure on AXI4-Stream; reset at
a sweep of cycle offsets within a solve. Every answer is compared word for word with the golden model
(verif/fuzz/kinds.py); no hang (each answer within a time limit), exactly one answer per accepted frame. The RTL's
protocol assertions (bus.Protocol) are checked all along.

Environment: CORE_OUT = the generator's output folder; FUZZ_LONG=1 for the long variant (every address of the
AXI4-Lite port, more rounds, reset at every cycle offset of the solve).
"""
from __future__ import annotations

import json
import math
import os
from pathlib import Path

import cocotb
from cocotb.triggers import ClockCycles
from cocotbext.axi import AxiResp

from verif.fuzz import kinds
from verif.fuzz.axil import AxiLiteFuzzMaster
from verif.fuzz.exchange import Exchange, frame_ends
from verif.fuzz.regfile import RegFile
from verif.fuzz.regs import RegFuzz

TIMEOUT_MS = 5000
LONG = os.environ.get("FUZZ_LONG") == "1"
FIRST_LIMIT = 200_000   # cycles for the first answer, before the solve time is measured


def _kind_name() -> str:
    return json.loads((Path(os.environ["CORE_OUT"]) / "core.json").read_text())["core"]


async def _start(dut, seed: int, **kw):
    k = kinds.make(dut, _kind_name(), seed, **kw)
    await k.tb.reset()
    k.after_reset()
    return k, Exchange(k)


async def _short(k):
    """The kind's short solves (kinds.Kind.short) for the stream and reset scenarios."""
    for reg, v in k.short.items():
        await k.set_reg(reg, v)


async def _solve_time(k, ex):
    """Cycles from handing a frame to the source to its answer's last word, on the idle core; and the job."""
    job = k.job()
    t0 = ex.now
    ex.send([job])
    await ex.collect(1, FIRST_LIMIT)
    return ex.now - t0, job


async def _flag(tb, name: str) -> bool:
    return (await tb.status())[name]


# ------------------------------------------------------------------------------------------------------ AXI4-Lite
def _addresses(rf: RegFile, rng) -> list:
    """Every word address of a small map; of a large one every register and unmapped word below the data
    memories, and per memory its first and last element, 8 more, 2 words of its gap and 16 unmapped words."""
    if LONG or len(rf.addr) <= 256:
        return list(rf.addr.values())
    g = rf.groups()
    out = [a for a in rf.addr.values() if a.byte < 64 or (a.kind == "data" and not a.reg.external)]
    for r in (r for r in rf.rm.regs.values() if r.external):
        el = [a for a in g["data"] if a.reg is r]
        out += [el[0], el[-1]] + rng.sample(el, min(8, len(el)))
        gaps = [a for a in g.get("gap", []) if a.reg is r]
        out += rng.sample(gaps, min(2, len(gaps)))
    out += rng.sample(g["unmapped"], 16)
    return list({a.byte: a for a in out}.values())


def _dynamic(ex, busy: bool | None, before: int, inflight: int) -> dict:
    """What the fields the core sets may read: BUSY, SOLVES, WARM_VALID (no successful bounds write ever)."""
    counts = set(range(before, before + inflight + 1))
    return {"STATUS.BUSY": None if busy is None else {int(busy)}, "SOLVES.COUNT": counts,
            "STATUS.WARM_VALID": {int(c > 0) for c in counts}, "LAST_CYCLES.CYCLES": None}


async def _configure(fz: RegFuzz):
    """After an idle phase: HOLD clear, random WARM_START and OUT_ALL, a random iteration count up to the default
    for each register that refuses 0 (IMAX, INW), the reset value of any other."""
    rf, rng = fz.rf, fz.rng
    for name, fields in rf.tracked.items():
        a = rf.addr[rf.rm[name]]
        if name == "STATUS":
            continue
        if name == "CTRL":
            v = sum(rng.getrandbits(1) << f.lsb for f in fields if f.name != "HOLD")
        elif "SLVERR" in a.reg.desc:
            v = rng.randint(1, fields[0].reset)
        else:
            v = sum(f.reset << f.lsb for f in fields)
        await fz.write(a, v, False)


@cocotb.test(timeout_time=TIMEOUT_MS, timeout_unit="ms")
async def axil_fuzz(dut):
    """Rounds of: reads and writes of the addresses (AW/W in either order, random delays and wstrb, back to back,
    random bready/rready) on the idle core; then frames sent with the output held, the same traffic while the core
    is busy (data writes refused), the output released under backpressure while registers are read. Each answer
    bit-exact, each transaction answered once as the RDL says."""
    k, ex = await _start(dut, 41, axil=lambda d, rng: AxiLiteFuzzMaster(d, rng, delay=0.3, stall=0.3))
    tb = k.tb
    rf = RegFile(tb.rm, len(dut.s_axil_awaddr))
    fz = RegFuzz(k, rf)
    addrs = _addresses(rf, tb.rng)
    regs = [a for a in addrs if a.kind == "reg"]
    for rnd in range(6 if LONG else 2):
        tb.axil.delay = tb.axil.stall = 0.3 if rnd % 2 == 0 else 0.0   # odd rounds: back to back, no stalls
        await fz.phase(addrs, False, _dynamic(ex, False, ex.answered, 0))
        await _configure(fz)
        tb.sink.pause = True
        k.before_held_round()
        jobs = [k.job() for _ in range(tb.rng.randint(1, k.hold_frames))]
        racy = set().union(*(j.flags for j in jobs))
        before = ex.answered
        ex.send(jobs)
        await tb.src.wait()
        await ClockCycles(dut.clock, 2)      # BUSY is registered
        await fz.phase(addrs, True, _dynamic(ex, True, before, k.held_solves(dut, jobs)), racy)
        tb.sink.set_pause_generator(iter(lambda: tb.rng.random() < 0.4, None))
        reads = cocotb.start_soon(fz.phase(regs, None, _dynamic(ex, None, before, len(jobs)), racy, writes=False))
        await ex.collect(len(jobs), FIRST_LIMIT)
        await reads
        tb.sink.set_pause_generator(None)
        tb.sink.pause = False
        rf.hw_sets(racy)
        await ClockCycles(dut.clock, 4)
    await fz.phase(addrs, False, _dynamic(ex, False, ex.answered, 0))
    order = tb.axil.order
    dut._log.info("AXI4-Lite fuzz: %d transactions over %d addresses, %d answers; writes with AW first %d, W "
                  "first %d, both on one cycle %d", fz.transactions, len(addrs), ex.answered, order["aw"],
                  order["w"], order["both"])
    assert min(order.values()) > 0, f"not every order of AW and W occurred: {order}"


# ------------------------------------------------------------------------------------------------------ AXI4-Stream
def _cuts(ends: list[int], rng) -> list[int]:
    """tlast positions for frames ending at `ends`: per frame on its last word, or early (on an inner word), or
    missing (so the next tlast comes late), or both; at least one early and one missing."""
    cuts, start = [], 0
    kinds_ = [rng.choice(["ok", "early", "missing", "both"]) for _ in ends]
    kinds_[0], kinds_[-2 if len(ends) > 1 else 0] = "early", "missing"
    for e, kd in zip(ends, kinds_):
        if kd in ("early", "both") and e - start > 1:
            cuts.append(rng.randrange(start + 1, e))
        if kd in ("ok", "early") or e == ends[-1]:
            cuts.append(e)
        start = e
    return cuts


@cocotb.test(timeout_time=TIMEOUT_MS, timeout_unit="ms")
async def axis_fuzz(dut):
    """Frames with tlast early, late (missing on the frame's last word) and extra, under random tvalid gaps and
    tready backpressure: frames are counted in words, so every answer is the model's, STATUS.TLAST_ERROR is set and
    clears on writing 1; good frames after it solve exactly with the flag clear. A truncated frame (its last word
    missing, tlast early): flagged, no answer and BUSY while the core waits for the word; after a reset the next
    frames solve exactly."""
    k, ex = await _start(dut, 42)
    tb = k.tb
    await _short(k)
    limit = 4 * (await _solve_time(k, ex))[0] + 200
    bit = 1 << tb.rm.STATUS_BITS["TLAST_ERROR"]
    tb.backpressure(True)
    for rnd in range(6 if LONG else 2):
        jobs = [k.job() for _ in range(4)]
        ex.send(jobs, _cuts(frame_ends(jobs), tb.rng))
        await ex.collect(len(jobs), limit * len(jobs))
        assert await _flag(tb, "TLAST_ERROR"), "TLAST_ERROR not set by misplaced tlast"
        assert await tb.write(tb.rm["STATUS"], bit) == AxiResp.OKAY
        assert not await _flag(tb, "TLAST_ERROR"), "TLAST_ERROR not cleared by writing 1"
    jobs = [k.job() for _ in range(3)]
    ex.send(jobs)
    await ex.collect(len(jobs), limit * len(jobs))
    assert not await _flag(tb, "TLAST_ERROR"), "TLAST_ERROR set by good frames"
    # a truncated frame
    job = k.job()
    ex.send([kinds.Job(job.words[:-1], [])])
    await ex.quiet(limit)
    st = await tb.status()
    assert st["TLAST_ERROR"] and st["BUSY"], f"truncated frame: {st}"
    tb.backpressure(False)
    tb.src.clear()
    await tb.reset()
    k.after_reset()
    ex.pending.clear()
    await _short(k)
    jobs = [k.job() for _ in range(2)]
    ex.send(jobs)
    await ex.collect(len(jobs), limit * len(jobs))
    await ex.quiet(limit)


# ------------------------------------------------------------------------------------------------------ reset
def sweep(T: int, period: int, head: int, tail: int) -> tuple[list[int], int]:
    """Reset offsets (cycles after a frame is handed to the source) for a solve of T cycles, and the stride: every
    offset when FUZZ_LONG or T <= 400; else every offset of the first `head` and last `tail` cycles (the frame's
    intake, the start of the solve, the answer) and in between a stride coprime with the pipeline's period, so that
    the offsets meet every phase of it: period + 1 when that leaves at least `period` offsets, else the smallest
    stride from T / 100 up (about 100 offsets)."""
    if LONG or T <= 400:
        return list(range(T + 2)), 1
    stride = period + 1
    if (T - head - tail) // stride < period:
        stride = max(2, T // 100)
        while math.gcd(stride, period) != 1:
            stride += 1
    return sorted(set(range(head)) | set(range(head, T - tail, stride)) | set(range(T - tail, T + 2))), stride


def _period(core: dict) -> int:
    """The period of the pipeline: cycles per iteration (FGM, ADMM), of a slot's pass (MINRES, and the MINRES of
    the interior-point core)."""
    return core.get("slot_cycles") or core["cycles_per_iteration"]


@cocotb.test(timeout_time=TIMEOUT_MS, timeout_unit="ms")
async def reset_sweep(dut):
    """A frame, then reset at an offset of the sweep: an answer completed before the reset is right, none comes
    from the aborted solve after it, STATUS is clear, and the next frame gets exactly one answer, the model's (cold
    start)."""
    k, ex = await _start(dut, 43)
    tb = k.tb
    await _short(k)
    T, probe = await _solve_time(k, ex)
    period = _period(tb.core)
    edge = min(period, 32)
    flush = tb.core.get("flush_cycles", 0)
    offsets, stride = sweep(T, period, len(probe.words) + flush + edge, len(probe.expect) + edge)
    dut._log.info("reset sweep: solve of %d cycles, %d offsets (period %d, stride %d)", T, len(offsets), period,
                  stride)
    for t in offsets:
        ex.send([k.job()])
        await ClockCycles(dut.clock, t)
        while not tb.sink.empty():
            ex.take(list(tb.sink.recv_nowait().tdata))
        tb.src.clear()
        await tb.reset()
        tb.sink.clear()
        k.after_reset()
        ex.pending.clear()
        st = await tb.status()
        assert not any(st.values()), f"reset at {t}: STATUS {st}"
        await _short(k)
        ex.send([k.job()])
        await ex.collect(1, 2 * T + 100)
        await ex.quiet(8)
    await ex.quiet(2 * T)
