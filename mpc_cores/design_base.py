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
    target: str              # FPGA family of the multipliers (mpc_cores.target)

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
                "target": self.target,
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
    the kind's defaults for frac_bits, rounding and iterations. lat_mul is None when neither gives it: the design
    resolves it for its target once the word widths are known (`apply_target`)."""
    def opt(k, d):
        return solver_opt(problem, overrides, k, d)

    lat_mul = opt("lat_mul", None)
    return (int(opt("frac_bits", frac_bits)), int(opt("P", 1)), int(opt("lat_add", 1)),
            None if lat_mul is None else int(lat_mul),
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
    if lat_add < 0 or (lat_mul or 0) < 0:
        raise DesignError(f"lat_add and lat_mul must be >= 0: got lat_add={lat_add}, lat_mul={lat_mul}")
    if rounding not in ROUNDING_MODES:
        raise DesignError(f"rounding must be one of {ROUNDING_MODES}: got {rounding!r}")
    if not 1 <= iterations <= 65535:
        raise DesignError(f"iterations must be in [1, 65535]: got {iterations}")


def problems_option(problem, overrides: dict) -> int:
    """K_p, the problems interleaved on the row units (mpc_cores.interleave), from the overrides or the spec."""
    kp = solver_opt(problem, overrides, "problems", 1)
    if isinstance(kp, bool) or not isinstance(kp, int) or not 1 <= kp <= 16:
        raise DesignError(f"problems (K_p, problems interleaved on the row units) must be an integer in [1, 16]: "
                          f"got {kp}")
    return kp


def target_option(problem, overrides: dict) -> str:
    """The multipliers' FPGA family (mpc_cores.target), checked."""
    from mpc_cores.target import check_target

    return check_target(str(solver_opt(problem, overrides, "target", "generic")))


def apply_target(d: FixedPointDesign, lat_mul: int | None, products: list[tuple[int, int]]) -> None:
    """Set d.lat_mul for d.target once the word widths are known: `products` lists the (a, b) bit widths of the
    core's multipliers (mirroring the generator's). Refuses an explicit lat_mul below the target's DSP pipeline."""
    from mpc_cores.target import resolve_lat_mul

    d.lat_mul = resolve_lat_mul(d.target, lat_mul, products)


def module_suffix(target: str) -> str:
    """The module name's mark of a non-generic target (so that cores of several targets compile together)."""
    return "" if target == "generic" else f"_{target}"
