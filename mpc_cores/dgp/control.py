"""DGP controllers for the closed loop of mpc_cores/closedloop.py (same interface: `async step(x, r) -> u0`).

  DgpOsqpController   float64: the QP of the DGP core (mpc_cores.dgp.problem, input box and the hard state box at
                      stages 1..N) solved to optimality by OSQP, the reference of the loop
  DgpFixedController  the bit-exact golden model of the core (mpc_cores.dgp.model.DgpFixed), warm-started from the
                      previous solve's final dual when the design (or the `warm` argument) says so

The golden controller applies the first nu words of the z the core returns as they are (u = words / 2^b): the
core's answer meets the input box to within eps_g only (the input rows are constraints of the dual, not a
projection), and the loop takes that answer. It records, per step, the nu words of u0 (`words`, as
mpc_cores.fgm.control.FixedController), the iterations the solve ran (`iterations`), whether the stopping test was met
(`met`), the parameter words after the core's input saturation (`w`) and all n output words (`z`), so that a study
can compare each answer with the optimum of the same QP. An RTL controller can inherit it and override
`solve_words` (send the words, return the core's z words and its iterations).

The loop cost is mpc_cores.closedloop.loop_stage_cost (the tracking cost: the spec has neither input_rate nor
soft_states, which the DGP design flow refuses).
"""
from __future__ import annotations

import numpy as np

from mpc_cores.closedloop import Controller
from mpc_cores.dgp.model import DgpFixed
from mpc_cores.dgp.problem import DgpQP, dgp_qp, solve_qp
from mpc_cores.fixed import quantize
from mpc_cores.problem import MpcProblem

HOLDABLE = 0.9   # references whose steady-state input lies in 90 % of the input box (mpc_cores.closedloop)


class DgpOsqpController(Controller):
    """Double precision: the DGP core's QP (with the state constraints) solved to optimality by OSQP
    (mpc_cores.dgp.problem.solve_qp). A state from which an LP proves the constraints cannot be met raises
    RuntimeError naming it as infeasible; OSQP failing on a feasible QP raises RuntimeError saying so."""
    name = "osqp"

    def __init__(self, problem: MpcProblem | DgpQP, eps: float = 1e-10):
        self.qp = problem if isinstance(problem, DgpQP) else dgp_qp(problem)
        self.nu = self.qp.nu
        self.eps = eps

    def solve(self, x, r) -> np.ndarray:
        w = np.concatenate([np.asarray(x, dtype=float), np.asarray(r, dtype=float)])
        a = solve_qp(self.qp, w, eps=self.eps)
        if a.status == "infeasible":
            raise RuntimeError(f"the DGP QP is infeasible at the state x = {np.round(x, 6).tolist()} (an LP proves "
                               f"it: the largest slack on the constraints is {a.margin / self.qp.sigma:.4g} < 0)")
        if a.status != "solved":
            raise RuntimeError(f"OSQP failed to solve the DGP QP at the state x = {np.round(x, 6).tolist()}, which "
                               f"an LP shows feasible (OSQP: {a.status})")
        return a.z

    async def step(self, x, r):
        return self.solve(x, r)[: self.nu]


class DgpFixedController(Controller):
    """The bit-exact golden model of the core: imax / warm override the design's iterations / warm_start."""
    name = "golden"

    def __init__(self, design, imax: int | None = None, warm: bool | None = None):
        self.d = design
        self.b = int(design.b)
        self.nu = int(design.nu)
        self.model = DgpFixed(design)
        self.imax = imax
        self.warm = warm
        self.words: list[list[int]] = []     # u0 words per step
        self.iterations: list[int] = []      # iterations run per step
        self.met: list[bool] = []            # stopping test met per step
        self.w: list[np.ndarray] = []        # parameter words after the input saturation, per step
        self.z: list[np.ndarray] = []        # all n output words per step
        self.sat_steps = 0                   # solves with a parameter word outside the accepted box
        self.overflow_steps = 0              # solves in which a data word saturated

    def w_words(self, x, r) -> np.ndarray:
        """The nw parameter words streamed to the core: w = (x, r) with b fraction bits."""
        return quantize(np.concatenate([x, r]), self.b)

    def solve_words(self, w: np.ndarray) -> tuple[np.ndarray, int]:
        """(z words, iterations run) of one solve of the parameter words w."""
        res = self.model.solve(w, imax=self.imax, warm=self.warm)
        self.met.append(bool(res.met[0]))
        self.sat_steps += int(res.sat[0])
        self.overflow_steps += int(res.overflow[0])
        return res.z[0], int(res.iterations[0])

    async def step(self, x, r):
        w = self.w_words(x, r)
        z, it = self.solve_words(w)
        z = np.asarray(z, dtype=np.int64)
        self.w.append(np.clip(w, self.model.xlo, self.model.xhi))
        self.z.append(z)
        self.iterations.append(it)
        u = z[: self.nu]
        self.words.append([int(v) for v in u])
        return u / float(1 << self.b)

    def reset(self) -> None:
        """Cold start for the next solve and empty records."""
        self.model.reset()
        self.words, self.iterations, self.met, self.w, self.z = [], [], [], [], []
        self.sat_steps = self.overflow_steps = 0


def controllers(d):
    """Closed loop of `make demo`: the DGP QP by OSQP to optimality, the golden model (warm start per the design),
    references whose steady-state input lies in 90 % of the input box (their positions, inside 80 % of the
    reference box, |r| <= 0.32, are inside the position limits 0.5 as well)."""
    return DgpOsqpController(d.qp), DgpFixedController(d), HOLDABLE


__all__ = ["DgpFixedController", "DgpOsqpController", "HOLDABLE", "controllers"]
