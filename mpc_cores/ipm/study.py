"""Closed-loop studies of the interior-point core's arithmetic (the bit-exact model) against OSQP: the cost at given
I_NW and I_MR, and the smallest I_MR that keeps the closed loop within a tolerance, with and without the
preconditioner. Used by the tests, the design report and the benchmark."""
from __future__ import annotations

import numpy as np

from mpc_cores.closedloop import Controller, OsqpController, reference_schedule, run_closed_loop
from mpc_cores.ipm.machine import words
from mpc_cores.ipm.model import IpmModel
from mpc_cores.ipm.sparse import SparseMpc, sparse_mpc


class ModelController(Controller):
    """The bit-exact model of the core as a closed-loop controller (warm start from the previous sample)."""
    name = "golden"

    def __init__(self, model: IpmModel, cold: bool = False):
        self.model, self.cold = model, cold
        self.words: list[list[int]] = []

    async def step(self, x, r):
        u, _ = self.model.solve(x, r, cold=self.cold)
        self.words.append(words(u))
        return u.astype(float)


def loop(problem, steps: int = 60, hold: int = 20, seed: int = 0):
    refs = reference_schedule(problem, steps, hold, seed, holdable=0.9)
    return refs, np.zeros(problem.nx)


def optimal_cost(problem, steps: int = 60, hold: int = 20, seed: int = 0) -> float:
    refs, x0 = loop(problem, steps, hold, seed)
    return run_closed_loop(problem, OsqpController(problem), x0, refs).cost


def relative_cost(s: SparseMpc, J0: float, i_nw: int, i_mr: int, steps: int = 60, hold: int = 20, seed: int = 0,
                  **model_options) -> float:
    """(J - J_osqp) / J_osqp of the closed loop with the model at I_NW, I_MR."""
    refs, x0 = loop(s.problem, steps, hold, seed)
    J = run_closed_loop(s.problem, ModelController(IpmModel(s, i_nw, i_mr, **model_options)), x0, refs).cost
    return J / J0 - 1.0


def smallest_imr(problem, i_nw: int, tol: float = 1e-3, precondition: bool = True, imax: int | None = None,
                 **kw) -> int | None:
    """The smallest I_MR with |J/J_osqp - 1| <= tol for every I_MR' >= it up to imax (None: not reached)."""
    s = sparse_mpc(problem)
    J0 = optimal_cost(problem, **kw)
    imax = imax or s.N
    best = None
    for imr in range(imax, 0, -1):
        if abs(relative_cost(s, J0, i_nw, imr, precondition=precondition, **kw)) <= tol:
            best = imr
        else:
            break
    return best
