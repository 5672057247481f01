"""Closed-loop studies of the interior-point core's arithmetic (the bit-exact model) against OSQP: the cost at given
I_NW and I_MR, and the smallest I_MR that keeps the closed loop within a tolerance, with and without the
preconditioner, in any float format (fmt: a Format or a name, binary32, binary16, e8m17, ...). Used by the tests,
the design report and the benchmark."""
from __future__ import annotations

import re
import time

import numpy as np

from mpc_cores.closedloop import Controller, OsqpController, reference_schedule, run_closed_loop
from mpc_cores.float.model import Format
from mpc_cores.ipm.model import IpmModel
from mpc_cores.ipm.sparse import SparseMpc, sparse_mpc

NAMED = {"binary32": Format(8, 23), "binary16": Format(5, 10), "bfloat16": Format(8, 7)}


def format_of(fmt) -> Format:
    """A Format from a Format, None (binary32) or a name: binary32, binary16, bfloat16, e<E>m<M>."""
    if fmt is None:
        return NAMED["binary32"]
    if isinstance(fmt, Format):
        return fmt
    if fmt in NAMED:
        return NAMED[fmt]
    m = re.fullmatch(r"e(\d+)m(\d+)", fmt)
    if not m:
        raise ValueError(f"float format: binary32, binary16, bfloat16 or e<E>m<M>: got {fmt!r}")
    return Format(int(m[1]), int(m[2]))


class ModelController(Controller):
    """The bit-exact model of the core as a closed-loop controller (warm start from the previous sample)."""
    name = "golden"

    def __init__(self, model: IpmModel, cold: bool = False):
        self.model, self.cold = model, cold
        self.words: list[list[int]] = []

    async def step(self, x, r):
        u, _ = self.model.solve(x, r, cold=self.cold)
        self.words.append(self.model.words(u))
        return np.asarray(u, dtype=float)


def loop(problem, steps: int = 60, hold: int = 20, seed: int = 0):
    refs = reference_schedule(problem, steps, hold, seed, holdable=0.9)
    return refs, np.zeros(problem.nx)


def optimal_cost(problem, steps: int = 60, hold: int = 20, seed: int = 0) -> float:
    refs, x0 = loop(problem, steps, hold, seed)
    return run_closed_loop(problem, OsqpController(problem), x0, refs).cost


def relative_cost(s: SparseMpc, J0: float, i_nw: int, i_mr: int, steps: int = 60, hold: int = 20, seed: int = 0,
                  fmt=None, **model_options) -> float:
    """(J - J_osqp) / J_osqp of the closed loop with the model at I_NW, I_MR in the float format `fmt`."""
    refs, x0 = loop(s.problem, steps, hold, seed)
    model = IpmModel(s, i_nw, i_mr, fmt=format_of(fmt), **model_options)
    J = run_closed_loop(s.problem, ModelController(model), x0, refs).cost
    return J / J0 - 1.0


def smallest_imr(problem, i_nw: int, tol: float = 1e-3, precondition: bool = True, imax: int | None = None,
                 fmt=None, known: dict | None = None, **kw) -> int | None:
    """The smallest I_MR with |J/J_osqp - 1| <= tol for every I_MR' >= it up to imax (None: not reached), in the
    float format `fmt`. `known`: relative costs already measured, I_MR -> cost (same loop and options); the new
    ones are added to it."""
    s = sparse_mpc(problem)
    known = {} if known is None else known
    J0 = None
    imax = imax or s.N
    best = None
    for imr in range(imax, 0, -1):
        if imr not in known:
            J0 = J0 if J0 is not None else optimal_cost(problem, **kw)
            known[imr] = relative_cost(s, J0, i_nw, imr, precondition=precondition, fmt=fmt, **kw)
        if abs(known[imr]) <= tol:
            best = imr
        else:
            break
    return best


def format_study(problem, formats, i_nw: int = 8, imrs=(8, 10, 12, 16, 20), tol: float = 1e-3,
                 precondition: bool = True, log=None, **kw) -> dict:
    """Per format: the relative closed-loop cost at each I_MR of the grid `imrs`, the seconds per closed loop, and
    the smallest I_MR within `tol`: below the largest grid point out of tolerance (or down from the smallest grid
    point when none is), every I_MR up to the next grid point is measured, and the smallest I_MR whose measured
    costs at and above it are all within `tol` is taken (None: the largest grid point is out). Returns {name:
    {"rel": {imr: cost}, "smallest": imr, "seconds": {imr: s}}}; a loop with a non-finite cost counts as +inf.
    `log`: a callable getting (name, imr, cost, seconds) after every loop."""
    s = sparse_mpc(problem)
    J0 = optimal_cost(problem, **kw)
    out = {}
    for name in formats:
        rel, sec = {}, {}

        def measure(imr):
            t = time.perf_counter()
            rel[imr] = relative_cost(s, J0, i_nw, imr, precondition=precondition, fmt=name, **kw)
            if not np.isfinite(rel[imr]):
                rel[imr] = float("inf")
            sec[imr] = time.perf_counter() - t
            if log:
                log(name, imr, rel[imr], sec[imr])
            return abs(rel[imr]) <= tol

        grid = sorted(imrs)
        ok = {imr: measure(imr) for imr in grid}
        bad = [imr for imr in grid if not ok[imr]]
        if bad and bad[-1] == grid[-1]:
            best = None
        elif bad:
            best = min(imr for imr in grid if imr > bad[-1])
            for imr in range(best - 1, bad[-1], -1):
                if not measure(imr):
                    break
                best = imr
        else:
            best = grid[0]
            for imr in range(grid[0] - 1, 0, -1):
                if not measure(imr):
                    break
                best = imr
        out[str(name)] = {"rel": rel, "smallest": best, "seconds": sec}
    return out
