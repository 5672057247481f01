"""RTL of the generated DGP core (iteration (35) of 003) against its bit-exact golden model in Verilator: the words
and the status word of every answer, the latency solve_overhead + I x cycles_per_iteration - Z x
zero_start_saving_cycles with I the iterations run and Z the zero start (the starting dual all zero), backpressure,
reset in the middle of a solve, HOLD and saturation, the output words clamped to the input box (verif/dgp/tb.py; the
plain case and masses_state have answers outside the box); the issue's example through `make verilog`'s flow with its
design report."""
from __future__ import annotations

import pytest

from conftest import random_problem, small_case
from mpc_cores.dgp.design import design_dgp
from mpc_cores.dgp.report import design_report
from mpc_cores.flow import REPO, generate
from mpc_cores.problem import load_spec
from mpc_cores.sim import run_cocotb

BUILD = REPO / "build" / "tests" / "dgp"
SCENARIOS = 4  # cocotb tests in verif/dgp/tb.py


def _small(seed, **extra):
    return random_problem(f"dg{seed}", 2, 1, 4, 0, seed, **{"states": {"min": -0.5, "max": 0.5},
                          "hard_states": {"indices": [0], "min": -1.0, "max": 1.0}, **extra})


def _dgp_soak_config(seed: int):
    """(problem, design overrides) of a `make soak CORE=dgp` configuration"""
    import numpy as np

    from mpc_cores.dgp.soak import SOAK
    from mpc_cores.problem import problem_from_dict

    c = SOAK.draw(np.random.default_rng(seed))
    return problem_from_dict(dict(c.spec, name=f"s{seed}"), f"s{seed}"), c.design


# id -> (problem factory, design overrides, random solves)
CASES = {
    **small_case("dgp", 6),
    # plain form: averaged primal through the serial divider; lanes not dividing the rows; l_A = 2; an input box
    # narrow enough that the averaged primal leaves it (the output words clamped to it)
    "small_plain_l3": (lambda: _small(6, inputs={"min": -0.15, "max": 0.1}), dict(lanes=3, iterations=400, accelerated=False, lat_add=2), 5),
    # soak configuration 1000033: 15-bit data words, so the stream word was 16 bits and the answer's status word lost
    # its flags (met, sat, overflow) at the port; the stream now holds the 19-bit status word whole
    "soak_1000033_narrow_data": (lambda: _dgp_soak_config(1000033)[0], _dgp_soak_config(1000033)[1], 12),
    # row units: P = 2, and P = 3 with the plain form (n = 4 rows of pass K on 3 units: the last round's missing
    # rows are zero rows)
    # (an input box narrow enough that rows bind: warm starts from nonzero duals, restarts and extrapolation)
    "small_accel_p2": (lambda: _small(7, inputs={"min": -0.15, "max": 0.1}), dict(P=2, lanes=2, iterations=60), 6),
    "small_plain_p3": (lambda: _small(8, inputs={"min": -0.15, "max": 0.1}),
                       dict(P=3, lanes=2, iterations=300, accelerated=False), 4),
    # the shifted warm start (design.shift_sources) at P = 3: one input per stage, so that a row's source, a stage
    # later, is another unit's row; a box that binds beyond the first stage (nonzero shifted starts) and at the first
    # stage alone (shifted starts that are zero starts)
    "small_accel_p3_shift": (lambda: _small(7, inputs={"min": -0.1, "max": 0.05}),
                             dict(P=3, lanes=2, iterations=60, warm_shift=True), 4),
    # the example on the ECP5 target (every product on MULT18X18D partial products), 4 row units of 16
    # lanes (each unit's operands and tokens from kept copies of its own), with the shifted warm start
    "masses_state_ecp5": (lambda: load_spec(REPO / "examples/masses_state.yaml"),
                          dict(target="ecp5", P=4, lanes=16, warm_shift=True), 3),
    # the dual and the bounds in block RAM (ram_state): two units, restarts and warm starts from nonzero duals; one
    # unit with the shifted warm start on the ECP5 target (the memories' primitives; their behavioural model here)
    "small_accel_p2_ram": (lambda: _small(7, inputs={"min": -0.15, "max": 0.1}),
                           dict(P=2, lanes=2, iterations=60, ram_state=True), 6),
    "small_accel_shift_ram_ecp5": (lambda: _small(7, inputs={"min": -0.1, "max": 0.05}),
                                   dict(lanes=2, iterations=60, warm_shift=True, ram_state=True, target="ecp5"), 4),
}


# the plants none of whose rows binds anywhere in the box of w (every dual stays zero: no nonzero start to check)
NO_BINDING = {"soak_1000033_narrow_data"}


@pytest.fixture(scope="session")
def dgp_cores():
    designs = {cid: design_dgp(f(), **ov) for cid, (f, ov, _) in CASES.items()}
    cores = generate("dgp", [(d, BUILD / cid) for cid, d in designs.items()])
    return {cid: (designs[cid], core) for cid, core in zip(designs, cores)}


@pytest.mark.parametrize("cid", list(CASES))
def test_rtl_bitexact(dgp_cores, cid):
    d, core = dgp_cores[cid]
    out = BUILD / cid
    env = {"CORE_OUT": str(out), "CORE_RANDOM": str(CASES[cid][2]),
           "CORE_NONZERO_START": str(int(cid not in NO_BINDING))}
    ran, failed = run_cocotb(out / core["sv"], core["module"], "verif.dgp.tb", out / "sim", env)
    assert (ran, failed) == (SCENARIOS, 0), f"{cid}: {failed} of {ran} scenarios failed (see {out}/sim/sim.log)"


def test_masses_state_report(dgp_cores):
    """core.json and the design report name the bits of (36) and (37) and the cycle contract"""
    d, core = dgp_cores["masses_state_ecp5"]
    assert core["bits_eq36"] == d.bits36 and core["frac_bits"] == d.bits36
    assert core["int_bits"] == d.bits37
    rep = design_report(d, core)
    assert f"(36) of 003 gives p >= {d.bits36}" in rep and f"(37) of 003 gives r >= {d.bits37}" in rep
    assert core["cycles_per_iteration"] == d.cycles_per_iteration
    # the chunk schedule on the structure of masses_state (z = (u_0, ..., u_9), 4 inputs; G's rows: the 40 input
    # rows, then the positions of the 4 masses at stages k = 1..10): a round of 4 input rows of one stage lies in
    # one chunk of 16; a round of the 4 positions at stage k needs the columns of u_0..u_k-1, ceil(4 k / 16) chunks.
    # Dense, each of the 20 rounds would take ceil(40 / 16) = 3.
    assert (d.P, d.lanes, d.problem.N, d.nu) == (4, 16, 10, 4)
    assert core["issue_cycles"]["G"] == 10 + sum(-(-4 * k // 16) for k in range(1, 11)) == 28 < 20 * 3
    assert core["cycles_at_imax"] == core["solve_overhead_cycles"] + d.iterations * core["cycles_per_iteration"]
    # a zero start skips the first iteration's passes K and G and their gaps (z = e, s = G (z - e) = 0): the element
    # stage takes the first pass's 20 rounds of bound rows (one chunk each: nw = 12 <= 16 lanes) a stage after their
    # sums, so the decision follows pass G's gap and a cycle after the first pass
    assert core["issue_cycles"]["F"] == 10 + 20
    assert d.zero_start_gap == core["gap_cycles"]["G"] + 1
    assert core["zero_start_saving_cycles"] == (core["issue_cycles"]["K"] + core["gap_cycles"]["K"]
                                                + core["issue_cycles"]["G"] - 1)
    assert "MULT18X18D" in rep
