"""RTL of the generated interior-point core against the golden model of the generated core
(mpc_cores/ipm/core_model.py) in Verilator: 2P problems in flight, backpressure, I_NW and I_MR at run time,
NaN/Inf, HOLD, reset mid-batch, an infeasible problem; the measured latency against core.json."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from conftest import built_cases, case_params, random_problem, small_case
from mpc_cores.flow import REPO, generate
from mpc_cores.ipm.design import design_ipm
from mpc_cores.ipm.timing import simulate
from mpc_cores.sim import run_cocotb

BUILD = REPO / "build" / "tests" / "ipm"
SCENARIOS = 4  # cocotb tests in verif/ipm/tb.py

HARD = {"hard_states": {"indices": [0], "min": -1.0, "max": 1.0}}
# id -> (problem factory, design overrides, rounds)
RTL_CASES = {
    # P = 1: two problems in flight; tracking one output, a state box
    **small_case("ipm", 4),
    # P = 2: four problems in flight, two inputs
    "n2_m2_t2_p2": (lambda: random_problem("ib", 2, 2, 2, 0, 6), dict(P=2, iterations=5, newton=2), 3),
    # the narrow format e8m17 (one MULT18X18D per product) in both stages; n = m = 1, T = 3: the answer with the
    # whole iterate has 15 Stage 1 words, one short of a power of two (the answer's length counter's widths); P = 2
    # (at P = 1 its structured storage exceeds the bound of 001, which the generator refuses); target ecp5 (the
    # memories' DP16KD primitives, simulated through their behavioural model)
    "n1_m1_t3_p2_e8m17": (lambda: random_problem("ic", 1, 1, 3, 1, 7, **HARD),
                          dict(P=2, iterations=6, newton=3, format="e8m17", target="ecp5"), 2),
    # multiplexed (Algorithm 2 of 001): two inputs, each channel the single-input problem of input c mod 2 (its
    # Stage 1 constant bank and MINRES table), frames with x^, (x_s, u_s,i) and F, answers with the plan; a state box
    "n2_m2_t3_p2_mux": (lambda: random_problem("id", 2, 2, 3, 0, 8, **HARD),
                        dict(P=2, iterations=5, newton=2, multiplexed=True), 2),
}


# make test-slow: P = 2 with two inputs and no state box (P = 2 and two inputs run in the e8m17 and multiplexed cases)
SLOW = {"n2_m2_t2_p2"}


@pytest.fixture(scope="session")
def ipm_cores(request):
    designs = {cid: design_ipm(RTL_CASES[cid][0](), **RTL_CASES[cid][1])
               for cid in built_cases(RTL_CASES, request.config, SLOW)}
    cores = generate("ipm", [(d, BUILD / cid) for cid, d in designs.items()])
    return {cid: (BUILD / cid, c) for cid, c in zip(designs, cores)}


def test_masses_core_json(tmp_path_factory):
    """The issue's example: `make verilog CORE=ipm` on masses writes the SV, the header and core.json with the sizes,
    2P problems in flight, the storage, the format, the cycles per Newton iteration and the latency formula."""
    from mpc_cores.problem import load_spec

    out = BUILD / "masses"
    core = generate("ipm", [(design_ipm(load_spec(REPO / "examples/masses.yaml")), out)])[0]
    assert (core["N"], core["M"], core["P"], core["problems_in_flight"]) == (216, 20, 3, 6)
    assert core["format"] == "binary32" and (core["i_nw"], core["iterations"]) == (8, 19)
    assert core["stage1_hidden"], "Stage 1 must hide behind MINRES at the default I_MR"
    assert set(core["storage_words"]) == {"minres", "stage1_slots", "stage1_const"}
    # Stage 1 hidden: a Newton iteration of both groups is two MINRES batches back to back (P S = P N here)
    assert core["cycles_per_iteration"] == 3 * 216
    assert core["cycles_per_newton_iteration"] == 2 * (19 + 1) * 3 * 216
    assert core["eq18_cycles"] == 2 * 8 * (3 * 216 + 3) * 19 and "eq. (18)" in core["latency_formula"]
    for f in (core["sv"], core["header"]):
        assert (out / f).exists()


@pytest.mark.parametrize("cid", case_params(RTL_CASES, SLOW))
def test_rtl_matches_golden_model(cid, ipm_cores):
    out, core = ipm_cores[cid]
    measure = out / "measured.jsonl"
    measure.unlink(missing_ok=True)
    tests, failed = run_cocotb(out / core["sv"], core["module"], "verif.ipm.tb", out / "sim",
                               {"CORE_OUT": str(out), "CORE_ROUNDS": str(RTL_CASES[cid][2]),
                                "CORE_MEASURE": str(measure)})
    assert tests == SCENARIOS, f"{tests} cocotb tests ran, expected {SCENARIOS}"
    assert failed == 0, f"{failed} of {tests} scenarios failed: see {out / 'sim' / 'sim.log'}"
    rec = [json.loads(ln) for ln in measure.read_text().splitlines()]
    assert next(r for r in rec if r["test"] == "bitexact_inflight")["answers"] > 0
    # the cycle contract: every answer's latency (id word to status word) equals the cycle model's, for 2P
    # problems sent back to back from cold starts, again warm, warm at I_MR = 1 and at a large I_MR, with the
    # answers carrying z (CTRL.OUT_ALL), and P + 1 problems (a full batch and a partial one, closed at once)
    lat = next(r for r in rec if r["test"] == "latency")["rounds"]
    assert [lat[r]["i_mr"] for r in "012345"] == [core["iterations"]] * 2 + [1, 2 * core["iterations"] + 3,
                                                                              core["iterations"], core["iterations"]]
    assert [lat[r]["out_all"] for r in "012345"] == [False] * 4 + [True, False]
    for rnd in "012345":
        order = list(range(core["P"] + 1 if rnd == "5" else 2 * core["P"]))
        want = {str(c): v["latency"] for c, v in simulate(core, order, warm=set() if rnd == "0" else set(order),
                                                           i_nw=lat[rnd]["i_nw"], i_mr=lat[rnd]["i_mr"],
                                                           out_all=lat[rnd]["out_all"]).items()}
        assert lat[rnd]["latency"] == want, (rnd, lat[rnd]["latency"], want)
    assert max(lat["1"]["latency"].values()) == core["latency_cycles"]
