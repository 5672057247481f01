"""RTL of the generated ADMM core against the bit-exact golden model (mpc_cores/admm/model.py), over problems with
input-rate and soft state constraints and a spread of P, latencies and rounding, and the plain sparse form of a
spec without input_rate; generator refusals.

The suite's cores are elaborated in one generator run (session fixture);
each case builds its Verilator model once and runs every scenario of verif/admm/tb.py on it.
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from conftest import ADMM_BUILD, ADMM_CASES, case_params
from mpc_cores.admm.control import AdmmFixedController, admm_references
from mpc_cores.admm.design import design_admm
from mpc_cores.closedloop import run_closed_loop
from mpc_cores.flow import REPO, GeneratorError, run_generator
from mpc_cores.problem import load_spec
from mpc_cores.sim import run_cocotb

SCENARIOS = 9  # cocotb tests in verif/admm/tb.py
# the accelerated cores run from tests/test_admm_acc_rtl.py (a file of their own: the suite's workers take a file
# each, so the two files run side by side)
PLAIN = [c for c in ADMM_CASES if not c.endswith("_acc")]


@pytest.mark.parametrize("cid", case_params(PLAIN))
def test_rtl_matches_golden_model(cid, admm_cores, request):
    run_scenarios(admm_cores[cid], request.config.getoption("--random-solves") or ADMM_CASES[cid][2])


def run_scenarios(out, solves: int) -> None:
    """Every scenario of verif/admm/tb.py on the core in `out`, `solves` random solves in the bit-exact one; the
    measured cycle contract and interleaving against core.json."""
    core = json.loads((out / "core.json").read_text())
    measure = out / "measured.jsonl"
    measure.unlink(missing_ok=True)
    tests, failed = run_cocotb(out / core["sv"], core["module"], "verif.admm.tb", out / "sim",
                               {"CORE_OUT": str(out), "CORE_RANDOM": str(solves), "CORE_MEASURE": str(measure)})
    assert tests == SCENARIOS, f"{tests} cocotb tests ran, expected {SCENARIOS}"
    assert failed == 0, f"{failed} of {tests} scenarios failed: see {out / 'sim' / 'sim.log'}"
    rec = [json.loads(ln) for ln in measure.read_text().splitlines()]
    cyc = next(r for r in rec if r["test"] == "cycle_contract")
    # (fast AMA: eq. (24) plus its momentum lanes, core.json's momentum_cycles = 1 + l_M)
    assert cyc["cycles_per_iteration"] == core["cycles_per_iteration"] <= core["cycles_eq24"] + core["momentum_cycles"]
    assert core["momentum_cycles"] == (1 + core["lat_mul"] if core["accelerated"] else 0)
    assert next(r for r in rec if r["test"] == "bitexact_random")["cases"] == solves
    il = next(r for r in rec if r["test"] == "interleaving")
    assert il["problems"] == core["problems"] and il["mac_utilisation"] == pytest.approx(core["mac_utilisation"])
    if core["problems"] > 1:
        assert cyc["period_cycles"] == core["period_cycles"]


# The plain sparse form's core (a spec without input_rate; ADMM_CASES) in the closed loop
NORATE = "masses_norate_p1_b16"
NORATE_STEPS, NORATE_HOLD, NORATE_SEED = 8, 4, 3


def test_rtl_norate_layout(admm_cores):
    core = json.loads((admm_cores[NORATE] / "core.json").read_text())
    cfg = json.loads((admm_cores[NORATE] / "config.json").read_text())
    assert cfg["rate"] is False and core["rate"] is False and core["form"] == "w = (x, r), u_0 out"
    assert (core["n"], core["nw"], core["nx"]) == (128, 12, 8)


def test_rtl_norate_closed_loop(admm_cores):
    """The core in the closed loop (mpc_cores.closedloop_tb, AdmmRtlController: w = (x, r) out, u_0 = clip of the
    first words back, from core.json's `rate`): the words and the states of the golden model's loop."""
    spec, out = REPO / "examples/masses.yaml", admm_cores[NORATE]
    d = design_admm(load_spec(spec), P=1, iterations=6)
    core = json.loads((out / "core.json").read_text())
    p = load_spec(spec)
    golden = AdmmFixedController(d)
    t_fix = run_closed_loop(p, golden, np.zeros(p.nx), admm_references(p, NORATE_STEPS, NORATE_HOLD, NORATE_SEED))
    result = out / "closed_loop.json"
    result.unlink(missing_ok=True)
    tests, failed = run_cocotb(out / core["sv"], core["module"], "mpc_cores.closedloop_tb", out / "sim",
                               {"CORE_OUT": str(out), "CL_SPEC": str(spec), "CL_STEPS": str(NORATE_STEPS),
                                "CL_HOLD": str(NORATE_HOLD), "CL_SEED": str(NORATE_SEED), "CL_RESULT": str(result)},
                               log=out / "closed_loop.log")
    assert (tests, failed) == (1, 0), f"see {out / 'closed_loop.log'}"
    rtl = json.loads(result.read_text())
    assert rtl["words"] == golden.words
    assert np.array_equal(np.array(rtl["x"]), t_fix.x)


def test_contract_in_core_json(admm_cores):
    """core.json: L_A within eq. (24) of 002, multipliers at most P n_A (Table I; accelerated: plus the momentum
    lanes'), every component placed once, a
    soft pair's state directly before its slack on one unit."""
    for cid, out in admm_cores.items():
        core = json.loads((out / "core.json").read_text())
        cfg = json.loads((out / "config.json").read_text())
        n, P = core["n"], core["P"]
        assert core["cycles_per_iteration"] - core["momentum_cycles"] <= core["cycles_eq24"], cid
        # Table I (P n_A), plus the momentum lanes of an accelerated core: two per extrapolated state and lane
        lanes = 2 if cfg["soft_x"] else 1
        states = {"ama": 1, "admm": 2, "vucondat": 3}[core["method"]]
        assert core["multipliers"] <= P * n + (2 * states * P * lanes if core["accelerated"] else 0), cid
        placed = [j for unit in core["row_units"] for j in unit if j is not None]
        assert sorted(placed) == list(range(n)), cid
        slot = {j: (u, k) for u, unit in enumerate(core["row_units"]) for k, j in enumerate(unit) if j is not None}
        for x, d in zip(cfg["soft_x"], cfg["soft_d"]):
            assert slot[d] == (slot[x][0], slot[x][1] + 1), (cid, x, d)


def test_generator_refuses_invalid_configs(tmp_path, admm_cores):
    """The Chisel generator checks its own rules (it may be fed a hand-edited config.json)."""
    base = json.loads((admm_cores["rand_soft_n19_p3_l00_trunc"] / "config.json").read_text())
    pair_shift = list(base["shift"])
    pair_shift[base["soft_x"][0]] += 1
    bad = {
        "p_gt_n": dict(base, P=base["n"] + 1),
        "coef_overflow": dict(base, M11=[[1 << 24] * base["n"]] + base["M11"][1:]),
        "pair_shift": dict(base, shift=pair_shift),
        "radius": dict(base, soft_r=[0] * len(base["soft_r"])),
        "narrow_stream": dict(base, widths=dict(base["widths"], stream=8)),
    }
    args = []
    for k, cfg in bad.items():
        (tmp_path / f"{k}.json").write_text(json.dumps(cfg))
        args += [str(tmp_path / f"{k}.json"), str(tmp_path / k)]
    with pytest.raises(GeneratorError) as e:
        run_generator("admm.AdmmMain", args)
    msg = str(e.value)
    assert "p_gt_n.json: requirement failed: P must be in [1, n_A]" in msg
    assert "coef_overflow.json: requirement failed: a matrix entry does not fit the coefficient width" in msg
    assert "pair_shift.json: requirement failed: both members of a soft pair must share their penalty shift" in msg
    assert "radius.json: requirement failed: soft-constraint radii must be > 0" in msg
    assert "narrow_stream.json: requirement failed: stream width must be" in msg
    assert not any((tmp_path / k).exists() for k in bad)
