"""RTL of the generated FGM core against the bit-exact golden model, over a sweep of problems and parameters.

All cores are elaborated in one generator run (session fixture); each case builds its Verilator model once and
runs every scenario of verif/fgm/tb.py on it.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from verif.fgm.design import design_fgm
from verif.flow import REPO, GeneratorError, generate_fgm, run_generator
from verif.problem import load_spec, problem_from_dict
from verif.sim import run_cocotb

BUILD = REPO / "build" / "tests" / "fgm"
SCENARIOS = 8  # cocotb tests in verif/fgm/tb.py


def random_problem(name: str, nx: int, nu: int, N: int, ny: int, seed: int):
    """A random stabilisable plant with box bounds, tracking the first ny states."""
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((nx, nx))
    A *= 0.95 / max(abs(np.linalg.eigvals(A)))
    B = rng.standard_normal((nx, nu))
    d = {
        "name": name,
        "model": {"A": A.tolist(), "B": B.tolist()},
        "cost": {"Q": 1.0, "R": 0.5},
        "horizon": N,
        "inputs": {"min": -1.0, "max": 0.8},
        "states": {"min": -3.0, "max": 3.0},
    }
    if ny:
        d["tracking"] = {"outputs": list(range(ny)), "min": -1.0, "max": 1.0}
    return problem_from_dict(d, name)


# id -> (problem factory, design overrides, random solves)
CASES = {
    "masses_p1_b16": (lambda: load_spec(REPO / "examples/masses.yaml"), dict(P=1, frac_bits=16), 40),
    "masses_p3_b12_nearest": (lambda: load_spec(REPO / "examples/masses.yaml"),
                              dict(P=3, frac_bits=12, rounding="nearest"), 25),
    "masses_p40_b14_l23": (lambda: load_spec(REPO / "examples/masses.yaml"),
                           dict(P=40, frac_bits=14, lat_add=2, lat_mul=3), 15),
    "afm_p2_b16": (lambda: load_spec(REPO / "examples/afm_like.yaml"), dict(P=2, frac_bits=16), 25),
    "rand_n4_p4_b10": (lambda: random_problem("r4", 3, 1, 4, 1, 1), dict(P=4, frac_bits=10), 40),
    "rand_n7_p2_b14_nearest": (lambda: random_problem("r7", 4, 1, 7, 2, 2),
                               dict(P=2, frac_bits=14, rounding="nearest"), 40),
    "rand_n4_nw9_p1_b12": (lambda: random_problem("r4w", 7, 2, 2, 2, 3), dict(P=1, frac_bits=12), 40),
    "rand_n24_p5_b12_l00": (lambda: random_problem("r24", 4, 2, 12, 1, 4),
                            dict(P=5, frac_bits=12, lat_add=0, lat_mul=0), 30),
}


@pytest.fixture(scope="session")
def cores():
    jobs = []
    for cid, (prob, ov, _) in CASES.items():
        jobs.append((design_fgm(prob(), **ov), BUILD / cid))
    generate_fgm(jobs)
    return {cid: BUILD / cid for cid in CASES}


@pytest.mark.parametrize("cid", list(CASES))
def test_rtl_matches_golden_model(cid, cores, request):
    out = cores[cid]
    core = json.loads((out / "core.json").read_text())
    measure = out / "measured.jsonl"
    measure.unlink(missing_ok=True)
    solves = request.config.getoption("--random-solves") or CASES[cid][2]
    tests, failed = run_cocotb(out / core["sv"], core["module"], "verif.fgm.tb", out / "sim",
                               {"FGM_OUT": str(out), "FGM_RANDOM": str(solves), "FGM_MEASURE": str(measure)})
    assert tests == SCENARIOS, f"{tests} cocotb tests ran, expected {SCENARIOS}"
    assert failed == 0, f"{failed} of {tests} scenarios failed: see {out / 'sim' / 'sim.log'}"
    rec = [json.loads(ln) for ln in measure.read_text().splitlines()]
    cyc = next(r for r in rec if r["test"] == "cycle_contract")
    assert cyc["cycles_per_iteration"] == core["cycles_per_iteration"]
    assert next(r for r in rec if r["test"] == "bitexact_random")["cases"] == solves


def test_generator_refuses_invalid_configs(tmp_path, cores):
    """The Chisel generator checks its own rules (it may be fed a hand-edited config.json)."""
    base = json.loads((cores["rand_n4_p4_b10"] / "config.json").read_text())
    bad = {
        "p_gt_n": dict(base, P=base["n"] + 1),
        "p_lt_1": dict(base, P=0),
        "coef_overflow": dict(base, A=[[1 << 20] * base["n"]] + base["A"][1:]),
        "narrow_stream": dict(base, widths=dict(base["widths"], stream=8)),
    }
    args = []
    for k, cfg in bad.items():
        (tmp_path / f"{k}.json").write_text(json.dumps(cfg))
        args += [str(tmp_path / f"{k}.json"), str(tmp_path / k)]
    with pytest.raises(GeneratorError) as e:
        run_generator("fgm.FgmMain", args)
    msg = str(e.value)
    assert "p_gt_n.json: requirement failed: P must not exceed n" in msg
    assert "p_lt_1.json: requirement failed: P must be >= 1" in msg
    assert "coef_overflow.json: requirement failed: a matrix entry does not fit the coefficient width" in msg
    assert "narrow_stream.json: requirement failed: stream width must be" in msg
    assert not any((tmp_path / k).exists() for k in bad)
