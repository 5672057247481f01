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

import copy
import os

import cocotb
from cocotb.triggers import ClockCycles
from cocotbext.axi import AxiResp, AxiStreamFrame

from mpc_cores.driver import TB, measure  # noqa: F401
from mpc_cores import driver
from mpc_cores.interleave import PASS_QUEUE

TIMEOUT_MS = float(os.environ.get("CORE_TIMEOUT_MS") or driver.TIMEOUT_MS)


@cocotb.test(timeout_time=TIMEOUT_MS, timeout_unit="ms")
async def bitexact_random(dut):
    """Random states (some outside the box), random warm/cold start and Imax, random idle and backpressure on both
    streams: every output word equals the golden model, and the SAT and OVERFLOW flags agree."""
    tb = TB(dut, seed=int(os.environ.get("CORE_SEED") or 11))
    await tb.reset()
    count = int(os.environ.get("CORE_RANDOM") or "30")
    sat = ovf = False
    i = 0
    while i < count:
        tb.backpressure(i % 2 == 1)
        if i % 5 == 0:
            await tb.set_ctrl(warm=tb.rng.random() < 0.7)
        if i % 7 == 3:
            await tb.set_imax(tb.rng.randint(1, 2 * tb.core["iterations"]))
        if i % 11 == 5 and tb.core.get("early_exit"):
            await tb.set_exit_tol(tb.rng.choice([0, 1, 2, 5, 1 << tb.rng.randint(2, max(2, tb.core["frac_bits"] - 4))]))
        # one problem: a solve at a time; interleaving: a batch of frames for random problems, all in flight
        ids = [0] if tb.problems == 1 else \
            [tb.rng.randrange(tb.problems) for _ in range(min(count - i, tb.rng.randint(1, 2 * tb.problems)))]
        batch = len(ids)
        for r in await solve_batch(tb, ids, outside=0.05, tag=f"solves {i}.."):
            sat |= r.sat
            ovf |= r.overflow
        i += batch
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
    if tb.problems > 1:
        return await cycle_contract_interleaved(tb)
    early = tb.core.get("early_exit", False)
    if early:                    # IMAX iterations exactly: the exit test off
        await tb.set_exit_tol(0)
    lat = {}
    for imax in (1, 3, tb.core["iterations"]):
        await tb.set_imax(imax)
        tb.in_done.clear()
        tb.out_start.clear()
        await tb.solve_and_check(tb.random_w(), f"imax {imax}")
        assert len(tb.in_done) == 1 and len(tb.out_start) == 1
        lat[imax] = tb.out_start[0] - tb.in_done[0]
        last, _ = await tb.read(tb.rm["LAST_CYCLES"])
        # the run's cycles: the latency less the three cycles around the run and the answer's queue
        assert last == lat[imax] - 3 - PASS_QUEUE, f"LAST_CYCLES {last} vs measured {lat[imax]} - 3 - {PASS_QUEUE}"
        assert lat[imax] == tb.core["solve_overhead_cycles"] + imax * tb.core["cycles_per_iteration"], \
            f"Imax={imax}: measured {lat[imax]} cycles, core.json says {tb.core['cycles_per_solve_formula']}"
    per_iter = (lat[3] - lat[1]) // 2
    assert per_iter == tb.core["cycles_per_iteration"]
    paper = tb.core.get("cycles_eq23", tb.core.get("cycles_eq24"))
    if tb.nw <= tb.n:   # (fast AMA's momentum lanes add their cycles to the paper's iteration)
        mom = tb.core.get("momentum_cycles", 0) + tb.core.get("exit_extra_cycles", 0)
        assert per_iter - mom <= paper, f"L {per_iter} - {mom} exceeds the paper's {paper}"
    reg, _ = await tb.read(tb.rm["CYCLES_PER_ITER"])
    assert reg == per_iter
    runs = await exit_contract(tb) if early else []
    measure({"test": "cycle_contract", "module": tb.core["module"], "n": tb.n, "P": tb.core["P"],
              "cycles_per_iteration": per_iter, "paper": paper,
              "cycles_per_solve": lat[tb.core["iterations"]], "iterations": tb.core["iterations"], "exit_runs": runs})


async def exit_contract(tb, solves: int = 12):
    """A core with the exit test, at EXIT_TOL's reset value and then at a few other tolerances, warm and cold:
    each solve's latency is the overhead + I L with I = ITERATIONS.COUNT, the model's iterations, and MET says
    whether the test ended it. Returns the (COUNT, MET) of the solves."""
    L, over = tb.core["cycles_per_iteration"], tb.core["solve_overhead_cycles"]
    b = tb.core["frac_bits"]
    await tb.set_imax(3 * tb.core["iterations"])
    runs = []
    for k in range(solves):
        if k >= solves // 2:     # coarse tolerances: some solves end early on any problem
            await tb.set_exit_tol(tb.rng.choice([1 << max(0, b - s) for s in (2, 4, 6)] + [1]))
        await tb.set_ctrl(warm=k % 3 != 0)
        tb.in_done.clear()
        tb.out_start.clear()
        r = await tb.solve_and_check(tb.random_w(), f"exit test {k}")
        count, met = await tb.iterations()
        assert (count, met) == (r.iterations, r.met), f"ITERATIONS ({count}, {met}) != model ({r.iterations}, {r.met})"
        lat = tb.out_start[0] - tb.in_done[0]
        assert lat == over + count * L, f"exit test {k}: {lat} cycles for {count} iterations, core.json: {over} + I * {L}"
        runs.append((count, met))
    assert await tb.write(tb.rm["EXIT_TOL"], -1) == AxiResp.SLVERR
    assert await tb.write(tb.rm["EXIT_TOL"], 1 << tb.core["signals"]["z"]["width"]) == AxiResp.SLVERR
    return runs


def _interleave(tb):
    from mpc_cores.interleave import Interleave

    return Interleave(tb.core["rows_per_turn"], tb.problems, tb.core["cycles_per_iteration"])


async def solve_batch(tb, problems: list[int], outside: float = 0.0, idle: float = 0.0, tag: str = "",
                      starts: dict | None = None) -> list:
    """Frames for the given problem ids sent one after another (with probability `idle` a random pause after one),
    then their answers: each equals its problem's model and comes in its problem's order. Returns the model's
    results in the order sent; `starts`, if given, collects per problem the cycles its answers' first words were
    valid."""
    pending = {j: [] for j in range(tb.problems)}
    results = []
    base = len(tb.out_start)
    for j in problems:
        w = tb.random_w(outside=outside)
        exp, r = tb.expect(w, j)
        pending[j].append(exp)
        results.append(r)
        await tb.send(w, j if tb.problems > 1 else None)
        if idle and tb.rng.random() < idle:
            await ClockCycles(tb.dut.clock, tb.rng.randrange(2 * tb.core["period_cycles"]))
    for i in range(len(problems)):
        got_tag, got = await tb.recv_tagged()
        assert pending.get(got_tag), f"{tag} answer {i}: an answer for problem {got_tag}, which has none outstanding"
        exp = pending[got_tag].pop(0)
        assert got == exp, f"{tag} answer {i} of problem {got_tag}: RTL {got} != model {exp}"
        if starts is not None:
            starts.setdefault(got_tag, []).append(tb.out_start[base + i])
    return results


async def saturated_period(tb, rounds: int = 4) -> int:
    """Frames always waiting, in problem order, no backpressure, `rounds` per problem: every answer equals its
    problem's model and carries its id, and from the second round on each problem's answers come exactly the
    period of core.json's throughput apart. Returns that period (cycles per solve of each problem). Which problem
    answers first depends on where in the round the first frame arrives."""
    kp = tb.problems
    starts: dict = {}
    await solve_batch(tb, [i % kp for i in range(rounds * kp)], tag="saturated", starts=starts)
    period = kp / tb.core["throughput_solves_per_cycle"]
    gaps = [b - a for s in starts.values() for a, b in zip(s[1:], s[2:])]
    assert gaps and all(g == round(period) for g in gaps), f"periods {gaps}, core.json says {period}"
    return gaps[0]


async def cycle_contract_interleaved(tb):
    """An interleaving core: each problem's first pass runs in the first turn of its slot (mpc_cores.interleave)
    after the frame is taken, and its first answer word comes Imax R + L + 2 cycles after that turn began; frames
    sent at random phases of the round."""
    from mpc_cores.interleave import TAKE_TO_TURN

    il = _interleave(tb)
    assert il.R == tb.core["period_cycles"]
    from_turn = {}
    for imax in (1, 3, tb.core["iterations"]):
        await tb.set_imax(imax)
        for j in range(tb.problems):
            await ClockCycles(tb.dut.clock, tb.rng.randrange(il.R + 1))
            tb.in_done.clear()
            tb.out_start.clear()
            tb.out_done.clear()
            w = tb.random_w()
            exp, _ = tb.expect(w, j)
            await tb.send(w, j)
            tag, got = await tb.recv_tagged()
            assert (tag, got) == (j, exp), f"Imax={imax}, problem {j}: RTL {tag}: {got} != model {exp}"
            t0 = il.turn_start(j, tb.since_reset(tb.in_done[0]) + TAKE_TO_TURN)
            first = tb.since_reset(tb.out_start[0])
            assert first - t0 == il.answer_from_turn(imax), \
                f"Imax={imax}, problem {j}: answer {first - t0} cycles after its first turn, the model says " \
                f"{il.answer_from_turn(imax)}"
            lo, hi = il.latency_bounds(imax)
            assert lo <= tb.out_start[0] - tb.in_done[0] <= hi
            last, _ = await tb.read(tb.rm["LAST_CYCLES"])
            assert last == tb.since_reset(tb.out_done[0]) - t0, f"LAST_CYCLES {last}"
            from_turn[imax] = first - t0
    period = (from_turn[3] - from_turn[1]) // 2
    assert period == il.R
    reg, _ = await tb.read(tb.rm["CYCLES_PER_ITER"])
    assert reg == period
    L = from_turn[1] - period - 2
    # frames always waiting: each problem's solves come `solve_period` apart
    solve_period = await saturated_period(tb, rounds=3)
    measure({"test": "cycle_contract", "module": tb.core["module"], "n": tb.n, "P": tb.core["P"],
             "problems": tb.problems, "period_cycles": period, "cycles_per_iteration": L,
             "cycles_per_solve": from_turn[tb.imax] + TAKE_TO_TURN, "latency_max": from_turn[tb.imax] + TAKE_TO_TURN
             + period - 1, "solve_period": solve_period, "iterations": tb.imax})


@cocotb.test(timeout_time=TIMEOUT_MS, timeout_unit="ms")
async def interleaving(dut):
    """Frames always waiting, in problem order, no backpressure: every answer equals its problem's model and carries
    its id, and each problem's answers come one period (core.json's throughput) apart, which gives the measured
    MAC utilisation. Then random problem order, idle and backpressure: each problem's answers in its order; and a
    reset with every problem in flight."""
    tb = TB(dut, seed=19)
    await tb.reset()
    kp = tb.problems
    period = await saturated_period(tb)
    util = kp * (tb.imax + 1) * tb.core["rows_per_turn"] / period
    assert abs(util - tb.core["mac_utilisation"]) < 1e-12
    # random problem order, idle and backpressure, warm start per problem
    await tb.set_ctrl(warm=True)
    tb.backpressure(True)
    await solve_batch(tb, [tb.rng.randrange(kp) for _ in range(6 * kp)], outside=0.1, idle=0.3, tag="random order")
    tb.backpressure(False)
    await ClockCycles(dut.clock, 2 * tb.core["latency_cycles"]["max"])
    assert tb.sink.empty(), "an extra answer appeared"
    if kp & (kp - 1):     # an id past the last problem saturates to it and sets SAT
        await tb.write(tb.rm["STATUS"], 1 << tb.rm.STATUS_BITS["SAT"])
        w = tb.random_w()
        exp = tb.expect(w, kp - 1)[0]
        await tb.send(w, (1 << (kp - 1).bit_length()) - 1)
        assert await tb.recv_tagged() == (kp - 1, exp)
        assert (await tb.status())["SAT"]
    # reset with every problem in flight: no answer from the aborted batch, every warm start dropped (the next
    # batch matches the cold-started models)
    for j in range(kp):
        await tb.send(tb.random_w(), j if kp > 1 else None)
    sent = (tb.nw + 3) * kp          # every frame taken (each for a free problem)
    await ClockCycles(dut.clock, tb.rng.randint(sent, max(sent, tb.core["latency_cycles"]["min"])))
    await tb.reset()
    await ClockCycles(dut.clock, 2 * tb.core["latency_cycles"]["max"])
    assert tb.sink.empty(), "the batch aborted by reset produced an answer"
    await solve_batch(tb, list(range(kp)), tag="after reset")
    measure({"test": "interleaving", "module": tb.core["module"], "problems": kp, "period": period,
             "mac_utilisation": util})


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


def _changes_answer(tb, w, name: str, ij, v) -> bool:
    """the next solve of w answers differently with element ij of the model's matrix `name` set to v"""
    a, b = copy.deepcopy(tb.model), copy.deepcopy(tb.model)
    getattr(b, name)[ij] = v
    ra, rb = (m.solve(w, imax=tb.imax, warm=tb.warm) for m in (a, b))
    k = None if tb.out_all else tb.nu
    return list(ra.z[:k]) != list(rb.z[:k])


async def write_meets_frame(tb, name: str, addr_of, cols: int, offsets: int = 8):
    """A data write and a frame started together, the frame 0 to offsets - 1 cycles after the write: an accepted
    write (OKAY) is seen by that frame's solve, a refused one (SLVERR, the frame's first word came first) by none;
    no frame word is lost; the offsets cover both outcomes. The write goes to the largest element of the model's
    matrix `name` (rows n, columns `cols`; `addr_of(i, j)` its address), alternating between its value x0 and
    x0 - x0 / 4; each frame's w is drawn so that the written value changes its answer."""
    mat = getattr(tb.model, name)
    ij = max(((i, j) for i in range(tb.n) for j in range(cols)), key=lambda e: abs(int(mat[e])))
    x0 = int(mat[ij])
    pair, tag = (x0, x0 - (x0 >> 2)), f"{name} race"
    seen = set()
    for d in range(offsets):
        v = pair[1] if int(getattr(tb.model, name)[ij]) == pair[0] else pair[0]
        for _ in range(50):
            w = tb.random_w()
            if _changes_answer(tb, w, name, ij, v):
                break
        else:
            raise AssertionError(f"{tag}: no parameter found whose answer the value {v} changes")
        wr = cocotb.start_soon(tb.write(addr_of(*ij), v))
        await ClockCycles(tb.dut.clock, d)
        await tb.send(w)
        resp = await wr
        assert resp in (AxiResp.OKAY, AxiResp.SLVERR), f"{tag} offset {d}: response {resp}"
        seen.add(resp)
        if resp == AxiResp.OKAY:
            getattr(tb.model, name)[ij] = v
        exp, _ = tb.expect(w)
        got = await tb.recv()
        assert got == exp, f"{tag} offset {d} ({resp.name}): RTL {got} != model {exp} for w={list(w)}"
    assert seen == {AxiResp.OKAY, AxiResp.SLVERR}, f"{tag}: the offsets gave only {seen}"
