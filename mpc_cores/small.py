"""Random plants for the self-tests, and a core kind's small core: the one the per-kind protocol suites (fuzz,
registers, assertions: tests/test_fuzz.py, tests/test_regmap.py, tests/test_assertions.py) run, named by the kind
(CoreKind.small) and shared with a case of the kind's RTL suite (the same folder under build/tests, so one
generated core and one Verilator model serve both)."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


def random_spec(name: str, nx: int, nu: int, N: int, ny: int, seed: int, **extra) -> dict:
    """A random stabilisable plant (spectral radius 0.95) with box bounds, tracking the first ny states, as a spec
    dict; `extra` adds or replaces spec sections (input_rate, soft_states, hard_states, states, ...)."""
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
    d.update(extra)
    return d


@dataclass
class SmallCore:
    """A kind's small core: `case` its folder under build/tests (<suite folder>/<case id> of the kind's RTL suite),
    the problem's spec and the design overrides."""
    case: str
    spec: dict
    overrides: dict = field(default_factory=dict)

    @property
    def id(self) -> str:
        return self.case.rsplit("/", 1)[-1]

    def problem(self):
        from mpc_cores.problem import problem_from_dict

        return problem_from_dict(self.spec, self.spec["name"])
