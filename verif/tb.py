"""cocotb scenarios shared by the generated fixed-point cores (Verilator), driven through mpc_cores.driver.TB.
verif/<core>/tb.py adds the core's own (its data memories over AXI4-Lite) and imports these, so that cocotb finds
them all in one module.

Environment: CORE_OUT = the generator's output folder (core.json, config.json); CORE_RANDOM = random solves in
the bit-exact test; CORE_MEASURE = file to append measured cycle counts to (JSON lines); CORE_SEED = the seed of
the bit-exact test's random solves (default 11); CORE_TIMEOUT_MS = the simulated-time limit of each scenario in ms
(default mpc_cores.driver.TIMEOUT_MS; `make soak` sets it from the number of solves).
Every output word is compared with the core's bit-exact golden model, flags included.
"""
from __future__ import annotations

import os

import cocotb
from cocotb.triggers import ClockCycles
from cocotbext.axi import AxiResp, AxiStreamFrame

from mpc_cores.driver import TB, measure  # noqa: F401
from mpc_cores import driver

TIMEOUT_MS = float(os.environ.get("CORE_TIMEOUT_MS") or driver.TIMEOUT_MS)


@cocotb.test(timeout_time=TIMEOUT_MS, timeout_unit="ms")
async def bitexact_random(dut):
    """Random states (some outside the box), random warm/cold start and Imax, random idle and backpressure on both
    streams: every output word equals the golden model, and the SAT and OVERFLOW flags agree."""
    tb = TB(dut, seed=int(os.environ.get("CORE_SEED") or 11))
    await tb.reset()
    count = int(os.environ.get("CORE_RANDOM") or "30")
    sat = ovf = False
    for i in range(count):
        tb.backpressure(i % 2 == 1)
        if i % 5 == 0:
            await tb.set_ctrl(warm=tb.rng.random() < 0.7)
        if i % 7 == 3:
            await tb.set_imax(tb.rng.randint(1, 2 * tb.core["iterations"]))
        w = tb.random_w(outside=0.05)
        r = await tb.solve_and_check(w, f"solve {i}")
        sat |= r.sat
        ovf |= r.overflow
    st = await tb.status()
    assert st["SAT"] == sat, f"SAT flag {st['SAT']} != model {sat}"
    assert st["OVERFLOW"] == ovf, f"OVERFLOW flag {st['OVERFLOW']} != model {ovf}"
    assert not ovf, "a datapath word saturated for a state inside the box: the Prop. 1 widths are wrong"
    solves, _ = await tb.read(tb.rm["SOLVES"])
    assert solves == count
    measure({"test": "bitexact_random", "module": tb.core["module"], "cases": count})


@cocotb.test(timeout_time=TIMEOUT_MS, timeout_unit="ms")
async def cycle_contract(dut):
    """Latency from the last input word to the first output word is the overhead + Imax * L of core.json, L is
    within the paper's formula (eq. (23) or (24) of 002) and the CYCLES_PER_ITER register says it."""
    tb = TB(dut, seed=12)
    await tb.reset()
    lat = {}
    for imax in (1, 3, tb.core["iterations"]):
        await tb.set_imax(imax)
        tb.in_done.clear()
        tb.out_start.clear()
        await tb.solve_and_check(tb.random_w(), f"imax {imax}")
        assert len(tb.in_done) == 1 and len(tb.out_start) == 1
        lat[imax] = tb.out_start[0] - tb.in_done[0]
        last, _ = await tb.read(tb.rm["LAST_CYCLES"])
        assert last == lat[imax] - 2, f"LAST_CYCLES {last} vs measured {lat[imax]} - 2"
        assert lat[imax] == tb.core["solve_overhead_cycles"] + imax * tb.core["cycles_per_iteration"], \
            f"Imax={imax}: measured {lat[imax]} cycles, core.json says {tb.core['cycles_per_solve_formula']}"
    per_iter = (lat[3] - lat[1]) // 2
    assert per_iter == tb.core["cycles_per_iteration"]
    paper = tb.core.get("cycles_eq23", tb.core.get("cycles_eq24"))
    if tb.nw <= tb.n:
        assert per_iter <= paper, f"L {per_iter} exceeds the paper's {paper}"
    reg, _ = await tb.read(tb.rm["CYCLES_PER_ITER"])
    assert reg == per_iter
    measure({"test": "cycle_contract", "module": tb.core["module"], "n": tb.n, "P": tb.core["P"],
              "cycles_per_iteration": per_iter, "paper": paper,
              "cycles_per_solve": lat[tb.core["iterations"]], "iterations": tb.core["iterations"]})


@cocotb.test(timeout_time=TIMEOUT_MS, timeout_unit="ms")
async def back_to_back(dut):
    """Frames queued back to back (no gaps) under random output backpressure: one output per input, in order."""
    tb = TB(dut, seed=13)
    await tb.reset()
    ws = [tb.random_w() for _ in range(6)]
    exps = [tb.expect(w)[0] for w in ws]
    tb.sink.set_pause_generator(iter(lambda: tb.rng.random() < 0.5, None))  # never returns None: endless
    for w in ws:
        await tb.send(w)
    for k, e in enumerate(exps):
        got = await tb.recv()
        assert got == e, f"frame {k}: RTL {got} != model {e}"
    await ClockCycles(dut.clock, 2 * tb.core["cycles_per_solve"])
    assert tb.sink.empty(), "an extra output frame appeared"


@cocotb.test(timeout_time=TIMEOUT_MS, timeout_unit="ms")
async def reset_mid_solve(dut):
    """Reset in the middle of a solve: no output from the aborted solve, the warm start is dropped, the next solve
    matches the model from a cold start, and the status flags are clear."""
    tb = TB(dut, seed=14)
    await tb.reset()
    await tb.solve_and_check(tb.random_w(), "before")            # makes the warm start valid
    await tb.send(tb.random_w(outside=0.5))
    await ClockCycles(dut.clock, tb.rng.randint(2, tb.core["cycles_per_solve"] - 2))
    await tb.reset()
    await ClockCycles(dut.clock, tb.core["cycles_per_solve"] + 10)
    assert tb.sink.empty(), "the aborted solve produced an output"
    st = await tb.status()
    assert not any(st.values()), f"status after reset: {st}"
    await tb.solve_and_check(tb.random_w(), "after reset")


@cocotb.test(timeout_time=TIMEOUT_MS, timeout_unit="ms")
async def saturation_flag(dut):
    """Words outside the declared box saturate to it (the result equals the model's on the clamped state) and set
    STATUS.SAT; writing 1 clears it."""
    tb = TB(dut, seed=15)
    await tb.reset()
    r = await tb.solve_and_check(tb.random_w(), "inside")
    assert not r.sat and not (await tb.status())["SAT"]
    r = await tb.solve_and_check(tb.random_w(outside=1.0), "outside")
    assert r.sat and (await tb.status())["SAT"]
    assert await tb.write(tb.rm["STATUS"], 1 << tb.rm.STATUS_BITS["SAT"]) == AxiResp.OKAY
    assert not (await tb.status())["SAT"]


@cocotb.test(timeout_time=TIMEOUT_MS, timeout_unit="ms")
async def tlast_error(dut):
    """A frame whose tlast comes early is not lost: words are counted, TLAST_ERROR is set, one solve per nw words."""
    tb = TB(dut, seed=16)
    await tb.reset()
    if tb.nw < 2:
        return
    w = tb.random_w()
    exp, _ = tb.expect(w)
    await tb.src.send(AxiStreamFrame(tdata=[tb.to_word(v) for v in w[:-1]]))
    await tb.src.send(AxiStreamFrame(tdata=[tb.to_word(w[-1])]))
    got = await tb.recv()
    assert got == exp
    assert (await tb.status())["TLAST_ERROR"]


@cocotb.test(timeout_time=TIMEOUT_MS, timeout_unit="ms")
async def output_all(dut):
    """CTRL.OUT_ALL streams all n words of z, equal to the model."""
    tb = TB(dut, seed=17)
    await tb.reset()
    await tb.set_ctrl(out_all=True)
    tb.backpressure(True)
    for i in range(3):
        await tb.solve_and_check(tb.random_w(), f"out_all {i}")
