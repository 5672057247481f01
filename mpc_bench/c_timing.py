"""The generated C solvers (`make c`, mpc_cores.csrc) on this CPU, as two more software solvers of the FGM and ADMM
sections: "C (fixed point, this CPU)", the bit-exact integer solver of the section's design, and "C (float)", its
float variant in double, both compiled by gcc -O2 (-std=c99, warnings as errors) and warm-started like the core.
They run in the same replays of the same closed loop as the other solvers: mpc_bench.baselines adds `c_makers` to
the SwCase of each section, and its time_software gives their rows (SwResult) with the others' for
`solver_section`.

Wall time: the Python call, the quantisation of w to words (fixed point) and the ctypes call; own time: the solve
alone, by clock_gettime(CLOCK_MONOTONIC) in the shim around the solve function (mpc_cores.csrc.harness). Error: the
first nu words (u0 or du0) as reals against the reference, like every other row."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from mpc_cores.fixed import quantize

FIXED_NAME = "C (fixed point, this CPU)"
FLOAT_NAME = "C (float)"


class CTimed:
    """One replay's solver: a fresh state (cold first solve), then solve(w) -> (z, own seconds)."""
    timer = "clock_gettime around the C solve function (not the ctypes call)"

    def __init__(self, solver, name: str, settings: str, imax: int, frac_bits: int | None):
        self.solver, self.name, self.settings, self.imax, self.b = solver, name, settings, imax, frac_bits
        self.state = solver.new_state()

    def solve(self, w: np.ndarray) -> tuple[np.ndarray, float]:
        if self.b is None:
            z, _, ns = self.solver.solve(self.state, w, self.imax)
            return z, ns * 1e-9
        words = quantize(w, self.b)
        z, _, ns = self.solver.solve(self.state, words, self.imax)
        return z / float(1 << self.b), ns * 1e-9


def c_makers(kind: str, d, build_dir=None) -> tuple[list, list[str]]:
    """The makers of the fixed-point and float C solvers of design `d` of core kind `kind`, generated and compiled
    into build_dir (default build/c_timing/<module>), and the names of those not run (both without gcc)."""
    from mpc_cores import registry
    from mpc_cores.csrc import emit, harness
    from mpc_cores.flow import REPO
    from mpc_cores.kind import load

    if harness.gcc() is None:
        return [], [FIXED_NAME, FLOAT_NAME]
    out = Path(build_dir or REPO / "build" / "c_timing" / d.module_name)
    load(registry.get(kind).c_fn)(d, out)
    nm, cfg = emit.names(d.module_name), d.config()
    fixed, flt = harness.load(out, nm, cfg), harness.load(out, nm, cfg, float_=True)
    what = f"gcc -O2, Imax = {d.iterations}, warm start as the core"
    return [lambda: CTimed(fixed, FIXED_NAME, f"b = {d.b}, {d.rounding}, {what}", d.iterations, d.b),
            lambda: CTimed(flt, FLOAT_NAME, f"double, unquantised data, {what}", d.iterations, None)], []

