import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from verif.fgm.design import design_fgm  # noqa: E402
from verif.flow import REPO, generate_fgm  # noqa: E402
from verif.problem import load_spec, problem_from_dict  # noqa: E402

BUILD = REPO / "build" / "tests" / "fgm"


def pytest_addoption(parser):
    parser.addoption("--random-solves", type=int, default=None,
                     help="random solves per core in the bit-exact RTL test (default: per case)")


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


def _certified_masses(tol: float):
    from verif.fgm.certify import design_for_tolerance

    return design_for_tolerance(load_spec(REPO / "examples/masses.yaml"), tol)[0]


# Cores with a certified design (make design TOL=...), for the guarantee checks on the RTL.
CERTIFIED = {"masses_tol1e-2": lambda: _certified_masses(1e-2)}


@pytest.fixture(scope="session")
def cores():
    """Every core of the suite, elaborated in one generator run."""
    jobs = [(design_fgm(prob(), **ov), BUILD / cid) for cid, (prob, ov, _) in CASES.items()]
    jobs += [(make(), BUILD / cid) for cid, make in CERTIFIED.items()]
    generate_fgm(jobs)
    return {cid: BUILD / cid for cid in list(CASES) + list(CERTIFIED)}
