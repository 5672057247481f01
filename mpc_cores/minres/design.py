"""Design of a MINRES core from an MPC problem: sizes, latencies, P (or eq. (15)), the constant ROM as raw
binary32 words, written to the config.json the Chisel generator (minres.MinresMain) reads."""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mpc_cores.minres.kkt import Layout, const_rom, kkt_matrix, problem_matrices

# default latencies of the binary32 operators (float library defaults)
LAT = {"lat_add": 4, "lat_mul": 3, "lat_div": 16, "lat_sqrt": 16}

from mpc_cores.errors import DesignError  # noqa: E402  (the error the command line reports)


@dataclass
class MinresDesign:
    name: str
    n: int
    m: int
    T: int
    P: int                 # 0: from eq. (15) (the generator computes it)
    iterations: int
    lat: dict = field(default_factory=lambda: dict(LAT))
    flush_cycles: int = 32
    rom: np.ndarray = None  # (2n+m) x (M-1) float32
    h_diag: np.ndarray = None  # diagonal of the Hessian on the primal rows (the variable part without W)
    problem: object = None

    @property
    def layout(self) -> Layout:
        return Layout(self.n, self.m, self.T)

    def config(self) -> dict:
        return {"core": "minres", "name": self.name, "n": self.n, "m": self.m, "T": self.T, "P": self.P,
                "iterations": self.iterations, "flush_cycles": self.flush_cycles, **self.lat,
                "h_diag": [float(v) for v in self.h_diag],
                "rom": self.rom.astype(np.float32).view(np.uint32).astype(np.int64).tolist()}

    def write_config(self, path) -> None:
        Path(path).write_text(json.dumps(self.config()))


def design_minres(problem, P: int | None = None, iterations: int | None = None, lat_add: int | None = None,
                  lat_mul: int | None = None, name: str | None = None, **_ignored) -> MinresDesign:
    A, B, Q, R, QN, T = problem_matrices(problem)
    n, m = problem.nx, problem.nu
    solver = problem.solver or {}
    P = int(P if P is not None else solver.get("minres_P", 0) or 0)
    if P < 0 or P > 64:
        raise DesignError(f"P must be in [1, 64] (0 or none: eq. (15)): got P={P}")
    lat = dict(LAT)
    if lat_add is not None:
        lat["lat_add"] = int(lat_add)
    if lat_mul is not None:
        lat["lat_mul"] = int(lat_mul)
    if lat["lat_add"] < 1:
        raise DesignError(f"lat_add must be >= 1 (the streaming accumulator): got {lat['lat_add']}")
    it = int(iterations or solver.get("minres_iterations", 0) or Layout(n, m, T).N)
    rom = const_rom(A, B, Q, R, QN, T).astype(np.float32)
    h = np.diagonal(kkt_matrix(A, B, Q, R, QN, T))[Layout(n, m, T).primal_rows()]
    return MinresDesign(name or problem.name, n, m, T, P, min(it, 65535), lat, rom=rom, h_diag=h, problem=problem)
