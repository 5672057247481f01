"""The random configurations of a soak: what a core kind declares (SoakSpace, in mpc_cores/<kind>/soak.py, named by
CoreKind.soak) and the random problems every kind draws from (random_spec).

A configuration is a problem spec (the dict mpc_cores.problem.problem_from_dict reads) and the keywords of the
kind's design function; a seed determines it, so that a seed is the whole reproducer of a configuration.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np


@dataclass
class Config:
    """One random configuration: the spec of its problem and the design keywords."""
    spec: dict
    design: dict = field(default_factory=dict)

    def summary(self) -> dict:
        """Sizes, constraint sets and options in a report row."""
        s = self.spec
        A = np.array(s["model"]["A"], dtype=float)
        B = np.array(s["model"]["B"], dtype=float)
        sets = ["u"] + [label for key, label in (("input_rate", "du"), ("soft_states", "soft x"),
                                                 ("hard_states", "x")) if key in s]
        return {"nx": B.shape[0], "nu": B.shape[1], "N": s["horizon"],
                "ny": len(s.get("tracking", {}).get("outputs", [])),
                "radius": round(float(max(abs(np.linalg.eigvals(A)))), 3), "sets": sets, **self.design}


@dataclass(frozen=True)
class SoakSpace:
    """How a core kind is soaked.

    draw(rng)             a random Config (rng: numpy Generator)
    test                  the cocotb test of the kind's testbench (CoreKind.testbench) that checks random solves
                          word for word against the golden model under random idle and backpressure
    count_knob            its environment variable for the amount of work (solves, problems or rounds)
    per_count(core)       solves per unit of count_knob, on average (1; about 1.5 P answers per round of the
                          interior-point core)
    measured              the key of the test's CORE_MEASURE record holding the solves it checked
    cycles_per_solve(core)  an upper bound of the cycles a solve takes (idle and backpressure included), from
                          core.json: the simulated-time budget of a configuration (CORE_TIMEOUT_MS) comes from it
    solves_per_config     solves per configuration in a soak (simulation against Verilator builds)
    space                 the random space in words, for the report
    """
    draw: Callable[[np.random.Generator], Config]
    test: str
    count_knob: str
    measured: str
    cycles_per_solve: Callable[[dict], int]
    solves_per_config: int
    space: tuple[str, ...]
    per_count: Callable[[dict], float] = lambda core: 1


def random_model(rng: np.random.Generator, nx: int, nu: int, unstable: bool) -> tuple[np.ndarray, np.ndarray]:
    """A random (A, B): A scaled to spectral radius in [0.4, 0.98] (stable) or [1.02, 1.2] (unstable)."""
    A = rng.standard_normal((nx, nx))
    A *= (rng.uniform(1.02, 1.2) if unstable else rng.uniform(0.4, 0.98)) / max(abs(np.linalg.eigvals(A)))
    return A, rng.standard_normal((nx, nu))


def _subset(rng, items: list[int], k: int) -> list[int]:
    return sorted(int(i) for i in rng.choice(items, size=k, replace=False))


def _box(rng, n: int, lo: float, hi: float) -> dict:
    """A box around 0, each side's magnitude uniform in [lo, hi], per component."""
    return {"min": [-float(v) for v in rng.uniform(lo, hi, n)], "max": [float(v) for v in rng.uniform(lo, hi, n)]}


def random_spec(rng: np.random.Generator, nx: int, nu: int, N: int, *, ny: int = 0, rate: bool = False,
                soft: int = 0, hard: int = 0) -> dict:
    """A random problem spec: a stable or unstable model (even odds), diagonal weights, an input box, the box of
    accepted states, `ny` tracked states, an input-rate limit, `soft` soft and `hard` hard state boxes (disjoint)."""
    A, B = random_model(rng, nx, nu, bool(rng.random() < 0.5))
    spec = {"name": "soak", "model": {"A": A.tolist(), "B": B.tolist()},
            "cost": {"Q": [float(v) for v in rng.uniform(0.2, 2.0, nx)],
                     "R": [float(v) for v in rng.uniform(0.1, 1.0, nu)]},
            "horizon": int(N), "inputs": _box(rng, nu, 0.3, 1.5), "states": _box(rng, nx, 1.0, 4.0)}
    if ny:
        spec["tracking"] = {"outputs": _subset(rng, list(range(nx)), ny), **_box(rng, ny, 0.3, 1.0)}
    if rate:
        r = float(rng.uniform(0.1, 0.5))
        spec["input_rate"] = {"min": -r, "max": r, "weight": float(rng.choice([0.01, 0.05, 0.1]))}
    picked = _subset(rng, list(range(nx)), soft + hard)
    if soft:
        spec["soft_states"] = {"indices": picked[:soft], **_box(rng, soft, 0.3, 1.0),
                               "sigma1": float(rng.choice([4, 8, 16])), "sigma2": float(rng.choice([1, 2]))}
    if hard:
        spec["hard_states"] = {"indices": picked[soft:], **_box(rng, hard, 1.0, 3.0)}
    return spec


def pick(rng: np.random.Generator, values):
    """One of `values` (a Python value, not a numpy scalar: configurations go to JSON)."""
    v = values[int(rng.integers(len(values)))]
    return v.item() if isinstance(v, np.generic) else v


def target_latency(rng, lat_mul: int) -> dict:
    """The multipliers' target (generic half the time) and l_M: generic keeps the drawn `lat_mul`; ecp5 and xilinx7
    take their minimum (None: the design resolves it) or 4 to 6 (on ecp5, a fabric operand register too)."""
    t = pick(rng, ["generic", "generic", "ecp5", "xilinx7"])
    if t == "generic":
        return dict(target=t, lat_mul=lat_mul)
    return dict(target=t, lat_mul=None if rng.random() < 0.5 else int(rng.integers(4, 7)))


def problems(rng) -> int:
    """K_p of a fixed-point core: one problem (60 %) or 2 to 4 interleaved"""
    return 1 if rng.random() < 0.6 else int(rng.integers(2, 5))


def fixed_point_solve_cycles(core: dict) -> int:
    """A bound on the cycles of one solve of a fixed-point core under bitexact_random: Imax up to twice the
    default, both streams pausing (an interleaving core: a pass per round of period_cycles)."""
    return core["solve_overhead_cycles"] + 2 * core["iterations"] * core["period_cycles"] + \
        4 * (core["n"] + core["nw"])
