"""What the fixed-point design flows share: sizes read from the design's QP, the config.json the generator reads,
and the precedence of keyword overrides over the spec's `solver:` section."""
from __future__ import annotations

import json
from dataclasses import dataclass

from mpc_cores.errors import DesignError
from mpc_cores.fixed import ROUNDING_MODES


@dataclass
class FixedPointDesign:
    """The fields and sizes the FGM and ADMM designs share; a kind's dataclass adds its own fields (`widths`,
    `output_all` among them) and `config()`, the generator's data."""
    problem: object          # the MpcProblem
    qp: object               # the kind's QP form
    b: int                   # fraction bits
    P: int                   # row units
    lat_add: int
    lat_mul: int
    rounding: str
    iterations: int          # IMAX reset value
    warm_start: bool

    @property
    def n(self) -> int:
        return self.qp.n

    @property
    def nw(self) -> int:
        return self.qp.nw

    @property
    def nu(self) -> int:
        return self.qp.nu

    def common_config(self, core: str) -> dict:
        """The config.json entries of every fixed-point kind."""
        return {"core": core, "name": self.name, "n": self.n, "nu": self.nu, "nw": self.nw, "P": self.P,
                "frac_bits": self.b, "lat_add": self.lat_add, "lat_mul": self.lat_mul, "rounding": self.rounding,
                "widths": self.widths, "iterations": self.iterations, "warm_start": self.warm_start,
                "output_all": self.output_all}

    def write_config(self, path) -> None:
        with open(path, "w") as f:
            json.dump(self.config(), f)


def solver_opt(problem, overrides: dict, key: str, default):
    """A keyword override if given, else the spec's `solver:` entry, else `default`."""
    if key in overrides and overrides[key] is not None:
        return overrides[key]
    return problem.solver.get(key, default)


def run_options(problem, overrides: dict, frac_bits: int, rounding: str, iterations: int) -> tuple:
    """(b, P, lat_add, lat_mul, rounding, iterations, warm_start, output_all) from the overrides and the spec, with
    the kind's defaults for frac_bits, rounding and iterations."""
    def opt(k, d):
        return solver_opt(problem, overrides, k, d)

    return (int(opt("frac_bits", frac_bits)), int(opt("P", 1)), int(opt("lat_add", 1)), int(opt("lat_mul", 1)),
            str(opt("rounding", rounding)), int(opt("iterations", iterations)), bool(opt("warm_start", True)),
            bool(opt("output_all", False)))


def check_run_options(n: int, n_name: str, b: int, P: int, lat_add: int, lat_mul: int, rounding: str,
                      iterations: int) -> None:
    """Refuse options outside their ranges (DesignError naming the rule and the values); `n_name` names the
    number of variables in the message."""
    if not 1 <= P <= n:
        raise DesignError(f"P must be in [1, {n_name}] (one row unit per variable at most): got P={P}, {n_name}={n}")
    if b < 1:
        raise DesignError(f"frac_bits must be >= 1: got {b}")
    if lat_add < 0 or lat_mul < 0:
        raise DesignError(f"lat_add and lat_mul must be >= 0: got lat_add={lat_add}, lat_mul={lat_mul}")
    if rounding not in ROUNDING_MODES:
        raise DesignError(f"rounding must be one of {ROUNDING_MODES}: got {rounding!r}")
    if not 1 <= iterations <= 65535:
        raise DesignError(f"iterations must be in [1, 65535]: got {iterations}")
