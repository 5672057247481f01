"""Closed-loop sweeps of the cost tables (mpc_bench.tables): a Sweep is one table (spec, b, Imax, loop), each cell
an independent closed-loop run of the core's golden model from x0 = 0 under a piecewise-constant reference
(mpc_cores.closedloop.reference_schedule), against OSQP to optimality on the same loop. FGM cells design one core
each (design_fgm); the ADMM cells of one b share one core (design_admm, word widths sized for the sweep's largest
Imax) run with IMAX set per row, and the float64 ADMM gives the convergence part. run_sweeps spreads the cells over
a process pool with a progress bar on stderr. Also the CSV and markdown grid of one sweep."""
from __future__ import annotations

import csv
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

import numpy as np
from tqdm import tqdm

from mpc_bench.tables_paper import PAPER_002_ADMM_B
from mpc_cores.closedloop import OsqpController, Trajectory, reference_schedule, run_closed_loop
from mpc_cores.fgm.control import FixedController
from mpc_cores.fgm.design import DesignError, design_fgm
from mpc_cores.flow import REPO
from mpc_cores.problem import load_spec
from mpc_cores.quiet import c_output_silenced

MASSES = REPO / "examples/masses.yaml"
AFM = REPO / "examples/afm_like.yaml"
ADMM_SPEC = REPO / "examples/masses_rate_soft.yaml"

# Default closed loop: four reference segments of 15 s (masses) each; the segments ask for steady states the
# input box cannot hold part of the time, so the input bounds are active for most of the run (Fig. 5 of 002).
# References change every 10 steps (5 s on masses): the input limits bind in about a third of the optimal
# loop's steps, as in Fig. 5 of 002, and every reference can be held inside the input box.
STEPS, HOLD, SEED = 120, 10, 0

# ADMM closed loop: references uniform in 80 % of the reference box with no holdability filter
# (mpc_cores.admm.control.admm_references), a new one every 15 steps (7.5 s): |r| up to 0.8 exceeds the soft position
# limits 0.5, so the soft limits, the input box and the rate limit are all active for long stretches (Fig. 5 of 002).
ADMM_STEPS, ADMM_HOLD = 120, 15
# Rounding of the ADMM products: the design flow's default (design_admm) and the recommendation of this table;
# the other mode is measured beside it (table2_admm_truncate.csv).
ADMM_ROUNDING = "nearest"


@dataclass
class Sweep:
    key: str
    spec: Path
    bs: tuple
    imaxes: tuple
    steps: int = STEPS
    hold: int = HOLD
    seed: int = SEED
    method: str = "fgm"              # "fgm" (condensed QP, design_fgm) or "admm" (sparse QP (8), design_admm)
    rounding: str | None = None      # None: the design flow's choice (the spec's solver section or its default)
    holdable: float = 0.9            # reference_schedule(holdable=...): 0 for the ADMM references
    overrides: tuple = ()            # ADMM: extra design_admm keywords as (key, value) pairs, e.g. (("rho", 4),)


@dataclass
class SweepResult:
    sweep: Sweep
    opt: Trajectory
    cells: dict = field(default_factory=dict)   # (imax, b) -> {"cost": float} or {"refused": reason}
    floats: dict = field(default_factory=dict)  # ADMM: imax -> cost of the float64 ADMM (same rho_j, warm start)

    def pct(self, imax: int, b: int) -> float | None:
        c = self.cells[(imax, b)]
        return None if "refused" in c else 100.0 * (c["cost"] - self.opt.cost) / self.opt.cost


def masses_sweep(**kw) -> Sweep:
    return Sweep("masses", MASSES, tuple(range(10, 21)), tuple(range(5, 36, 5)), **kw)


def afm_sweep(**kw) -> Sweep:
    return Sweep("afm_like", AFM, tuple(range(10, 23, 2)), tuple(range(15, 36, 5)), **kw)


def admm_sweep(rounding: str = ADMM_ROUNDING, **kw) -> Sweep:
    """Table II(b) of 002: ADMM on masses_rate_soft, the paper's rows Imax = 10, 15, ..., 40; every b in 10..20 for
    the recommended rounding, the paper's columns b = 10, 12, ..., 20 for the other mode (the comparison; it keeps
    `make table2` shorter)."""
    kw = {"steps": ADMM_STEPS, "hold": ADMM_HOLD} | kw
    key = "admm" if rounding == ADMM_ROUNDING else f"admm_{rounding}"
    bs = tuple(range(10, 21)) if rounding == ADMM_ROUNDING else PAPER_002_ADMM_B
    return Sweep(key, ADMM_SPEC, bs, tuple(range(10, 41, 5)), method="admm", rounding=rounding, holdable=0.0, **kw)


# ---------------------------------------------------------------- closed-loop runs

@lru_cache(maxsize=None)
def _problem(spec: str):
    return load_spec(spec)


def _refs(sw: Sweep) -> np.ndarray:
    return reference_schedule(_problem(str(sw.spec)), sw.steps, sw.hold, sw.seed, holdable=sw.holdable)


def optimal_loop(sw: Sweep) -> Trajectory:
    """The reference loop: OSQP to optimality on the condensed QP (FGM) or on the soft-constrained QP (8) (ADMM)."""
    p = _problem(str(sw.spec))
    if sw.method == "admm":
        from mpc_cores.admm.control import AdmmOsqpController

        ctrl = AdmmOsqpController(p)
    else:
        ctrl = OsqpController(p)
    with c_output_silenced():
        return run_closed_loop(p, ctrl, np.zeros(p.nx), _refs(sw))


def _loop_key(sw: Sweep) -> tuple:
    """What the optimal loop (and the float64 ADMM rows) depend on: sweeps that differ only in b, Imax or the
    rounding share them."""
    return sw.method, str(sw.spec), sw.steps, sw.hold, sw.seed, sw.holdable, sw.overrides


def _optimal(sw: Sweep) -> tuple[tuple, Trajectory]:
    return _loop_key(sw), optimal_loop(sw)


def golden_loop(sw: Sweep, b: int, imax: int) -> tuple[Trajectory, FixedController]:
    """One cell: the golden model of the core designed for (b, Imax); raises DesignError if refused."""
    p = _problem(str(sw.spec))
    ctrl = FixedController(design_fgm(p, frac_bits=b, iterations=imax))
    return run_closed_loop(p, ctrl, np.zeros(p.nx), _refs(sw)), ctrl


def _cell(sw: Sweep, b: int, imax: int) -> tuple[str, int, int, dict]:
    try:
        traj, _ = golden_loop(sw, b, imax)
    except DesignError as e:
        return sw.key, imax, b, {"refused": str(e)}
    return sw.key, imax, b, {"cost": traj.cost}


# ---------------------------------------------------------------- ADMM (Table II(b) of 002)

@lru_cache(maxsize=4)
def admm_design(spec: str, b: int, rounding: str | None, iterations: int, overrides: tuple = ()):
    """The ADMM core of one column: the design flow at b fraction bits (raises DesignError if refused)."""
    from mpc_cores.admm.design import design_admm

    return design_admm(_problem(spec), **(dict(overrides) | {"frac_bits": b, "rounding": rounding,
                                                             "iterations": iterations}))


def admm_golden_loop(sw: Sweep, b: int, imax: int):
    """One ADMM cell: the golden model of the core designed for b (widths sized for the sweep's largest Imax), run
    with IMAX = imax and warm start. Returns (trajectory, controller); raises DesignError if refused."""
    from mpc_cores.admm.control import AdmmFixedController

    p = _problem(str(sw.spec))
    d = admm_design(str(sw.spec), b, sw.rounding, max(sw.imaxes), sw.overrides)
    ctrl = AdmmFixedController(d, imax=imax)
    return run_closed_loop(p, ctrl, np.zeros(p.nx), _refs(sw)), ctrl


def _admm_column(sw: Sweep, b: int) -> list[tuple[str, int, int, dict]]:
    """All Imax rows of one b: one design, one closed loop per row."""
    out = []
    for im in sw.imaxes:
        try:
            traj, ctrl = admm_golden_loop(sw, b, im)
        except DesignError as e:
            out.append((sw.key, im, b, {"refused": str(e)}))
            continue
        out.append((sw.key, im, b, {"cost": traj.cost, "overflow_steps": ctrl.overflow_steps,
                                    "sat_steps": ctrl.sat_steps}))
    return out


# float64 ADMM also run at these Imax (beyond the table's rows): how much of the gap is convergence
FLOAT_EXTRA_IMAX = (100, 400)


def admm_float_loops(sw: Sweep) -> dict[int, float]:
    """Cost of the float64 ADMM (exact data, the design's rho_j, warm start) per Imax of the sweep and of
    FLOAT_EXTRA_IMAX: the convergence part of the table without round-off. It does not depend on b; the design
    here only supplies M11, G~ and rho_j."""
    from mpc_cores.admm.control import AdmmFloatController
    from mpc_cores.admm.design import design_admm

    p = _problem(str(sw.spec))
    # word widths unused by the float model: a short sizing run
    d = design_admm(p, **(dict(sw.overrides) | {"sizing_solves": 2}))
    return {im: run_closed_loop(p, AdmmFloatController(d, imax=im), np.zeros(p.nx), _refs(sw)).cost
            for im in sorted(set(sw.imaxes) | set(FLOAT_EXTRA_IMAX))}


def _admm_floats(sw: Sweep) -> tuple[tuple, dict]:
    return _loop_key(sw), admm_float_loops(sw)


def run_sweeps(sweeps: list[Sweep], workers: int = 2, progress: bool = True) -> dict[str, SweepResult]:
    """All cells of all sweeps on one pool of `workers` processes (cells are independent runs). FGM cells are one
    job each; an ADMM column (one b, every Imax) is one job, so its core is designed once; the optimal loops and
    the float64 ADMM rows are jobs too. The long ADMM jobs are submitted first. progress: a bar over the cells on
    stderr (when it is a terminal)."""
    for sw in sweeps:
        if sw.method not in ("fgm", "admm"):
            raise ValueError(f"sweep {sw.key}: method must be 'fgm' or 'admm', got {sw.method!r}")
    shared = {_loop_key(sw): sw for sw in reversed(sweeps)}       # one optimal loop per distinct _loop_key
    jobs = ([(_admm_column, sw, b) for sw in sweeps if sw.method == "admm" for b in sw.bs]
            + [(_optimal, sw) for sw in shared.values()]
            + [(_admm_floats, sw) for sw in shared.values() if sw.method == "admm"]
            + [(_cell, sw, b, im) for sw in sweeps if sw.method == "fgm" for im in sw.imaxes for b in sw.bs])
    opts, floats, cells = {}, {}, {}

    def collect(fn, out):
        if fn is _optimal:
            opts[out[0]] = out[1]
        elif fn is _admm_floats:
            floats[out[0]] = out[1]
        else:
            for key, im, b, c in (out if fn is _admm_column else [out]):
                cells.setdefault(key, {})[(im, b)] = c

    total = sum(len(sw.bs) * len(sw.imaxes) for sw in sweeps)
    bar = tqdm(total=total, desc="closed-loop cells", unit="cell", disable=None if progress else True)

    def tick(fn, out):
        if fn in (_cell, _admm_column):
            bar.update(len(out) if fn is _admm_column else 1)

    if workers <= 1:
        for fn, *args in jobs:
            out = fn(*args)
            collect(fn, out)
            tick(fn, out)
    else:
        with ProcessPoolExecutor(max_workers=workers) as ex:
            futs = {ex.submit(fn, *args): fn for fn, *args in jobs}
            for f in as_completed(futs):
                out = f.result()
                collect(futs[f], out)
                tick(futs[f], out)
    bar.close()
    results = {}
    for sw in sweeps:
        results[sw.key] = SweepResult(sw, opts[_loop_key(sw)], cells.get(sw.key, {}), floats.get(_loop_key(sw), {}))
    return results


# ---------------------------------------------------------------- outputs

def write_csv(path: Path, res: SweepResult) -> None:
    """One row per cell, Imax-major; a refused cell keeps its row with cost_pct empty."""
    with open(path, "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["imax", "b", "cost_pct"])
        for im in res.sweep.imaxes:
            for b in res.sweep.bs:
                v = res.pct(im, b)
                w.writerow([im, b, "" if v is None else f"{v:.6f}"])


def _grid(res: SweepResult, fmt: str = "{:.3f}") -> tuple[list[str], dict[int, str]]:
    sw = res.sweep
    lines = ["| Imax \\ b | " + " | ".join(str(b) for b in sw.bs) + " |",
             "|---|" + "---|" * len(sw.bs)]
    reasons: dict[int, str] = {}
    for im in sw.imaxes:
        row = []
        for b in sw.bs:
            v = res.pct(im, b)
            if v is None:
                reasons.setdefault(b, res.cells[(im, b)]["refused"])
                row.append("refused")
            else:
                row.append(fmt.format(v))
        lines.append(f"| {im} | " + " | ".join(row) + " |")
    return lines, reasons


def _paper_grid(bs, table) -> list[str]:
    lines = ["| Imax \\ b | " + " | ".join(str(b) for b in bs) + " |", "|---|" + "---|" * len(bs)]
    for im, vals in table.items():
        lines.append(f"| {im} | " + " | ".join(f"{v:.2f}" for v in vals) + " |")
    return lines


def _rtl_lines(rtl: list[dict] | None) -> list[str]:
    """The RTL-in-the-loop section: rows with b, imax, steps, golden_pct, rtl_pct, same_words, same_cost."""
    if not rtl:
        return []
    out = ["## RTL in the loop (Verilator, AXI interfaces)", "",
           "| b | Imax | golden cost_pct | RTL cost_pct | RTL words = golden words | cost identical |",
           "|---|---|---|---|---|---|"]
    for r in rtl:
        out.append(f"| {r['b']} | {r['imax']} | {r['golden_pct']:.6f} | {r['rtl_pct']:.6f} | "
                   f"{'yes' if r['same_words'] else 'NO'} ({r['steps']} steps) | "
                   f"{'yes' if r['same_cost'] else 'NO'} |")
    return out + [""]


