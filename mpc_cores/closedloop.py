"""Closed-loop simulation: plant + MPC controller with setpoint tracking.

A controller maps (x, r) to u0. The controllers share one interface, so a user swaps one line:
  OsqpController   float64, the QP solved to optimality (OSQP)
  RtlController    the Verilator model of the generated core, through its AXI interfaces (inside cocotb)
and each kind's golden model has its controller in its package (FGM: mpc_cores.fgm.control.FixedController).
The loop is a coroutine (`closed_loop`), so the RTL controller can await the simulator; the Python-only
controllers run it with `run_closed_loop`. The ADMM controllers (input-rate and soft state constraints) are in
mpc_cores/admm/control.py and use the same loop: its cost adds the du weight and the soft penalty when the problem has
those sections (`loop_stage_cost`).
"""
from __future__ import annotations

import asyncio
from dataclasses import dataclass

import numpy as np

from mpc_cores.fixed import quantize
from mpc_cores.problem import MpcProblem, condense, stage_cost
from mpc_cores.reference import solve_qp_osqp


class Controller:
    name = "controller"

    async def step(self, x: np.ndarray, r: np.ndarray) -> np.ndarray:
        raise NotImplementedError


class OsqpController(Controller):
    """Double precision, the condensed QP solved to optimality."""
    name = "osqp"

    def __init__(self, problem: MpcProblem, eps: float = 1e-10):
        self.qp = condense(problem)
        self.nu = problem.nu
        self.eps = eps

    async def step(self, x, r):
        z = solve_qp_osqp(self.qp, np.concatenate([x, r]), eps=self.eps)
        return z[: self.nu]


class RtlController(Controller):
    """The generated core in Verilator, driven by the cocotb testbench `tb` (verif.tb.TB)."""
    name = "rtl"

    def __init__(self, tb, b: int):
        self.tb = tb
        self.b = b
        self.words: list[list[int]] = []

    async def step(self, x, r):
        w = quantize(np.concatenate([x, r]), self.b)
        await self.tb.send(w)
        got = await self.tb.recv()
        u = np.array(got[: self.tb.nu])
        self.words.append([int(v) for v in u])
        return u / (1 << self.b)


@dataclass
class Trajectory:
    x: np.ndarray      # (T+1, nx)
    u: np.ndarray      # (T, nu)
    r: np.ndarray      # (T, ny)
    cost: float        # sum of stage costs

    def to_dict(self) -> dict:
        return {"x": self.x.tolist(), "u": self.u.tolist(), "r": self.r.tolist(), "cost": self.cost}


def reference_schedule(problem: MpcProblem, steps: int, hold: int, seed: int = 0, holdable: float = 0.9) -> np.ndarray:
    """Piecewise-constant references inside 80% of the reference box, changing every `hold` steps.

    With holdable > 0 each reference is drawn (by rejection) so that its steady-state input lies inside that
    fraction of the input box: the plant can settle on it, the input limits bind during the transients only, and
    the closed-loop cost is not dominated by an offset no controller can remove."""
    from mpc_cores.problem import steady_state_maps

    rng = np.random.default_rng(seed)
    lo, hi = problem.rmin, problem.rmax
    mid, half = (lo + hi) / 2, (hi - lo) / 2 * 0.8
    R = np.zeros((steps, problem.ny))
    if problem.ny == 0:
        return R
    _, Mu = steady_state_maps(problem)
    umid, uhalf = (problem.umin + problem.umax) / 2, (problem.umax - problem.umin) / 2
    for k in range(0, steps, hold):
        for _ in range(10_000):
            r = mid + half * rng.uniform(-1, 1, problem.ny)
            if holdable <= 0 or np.all(np.abs(Mu @ r - umid) <= holdable * uhalf):
                break
        else:
            raise ValueError(f"no reference in the box of {problem.name!r} can be held within {holdable:.0%} of the input box")
        R[k: k + hold] = r
    return R


def loop_stage_cost(problem: MpcProblem, x, u, u_prev, r=None) -> float:
    """Stage cost of one closed-loop step: the tracking cost (mpc_cores.problem.stage_cost) plus, when the problem has
    the sections, the input-rate weight (u - u_prev)' W (u - u_prev) and the soft-constraint penalty of (2) of 002,
    sigma1 1'v + sigma2 ||v||^2, on the actual violation v = max(0, |x_i - c_i| - r_i) of the plant state.
    Problems without those sections (the FGM ones) get stage_cost unchanged."""
    J = stage_cost(problem, x, u, r)
    if problem.input_rate is not None:
        du = np.asarray(u, dtype=float) - np.asarray(u_prev, dtype=float)
        J += float(du @ problem.input_rate.weight @ du)
    S = problem.soft_states
    if S is not None:
        v = np.maximum(0.0, np.abs(np.asarray(x, dtype=float)[list(S.indices)] - S.center) - S.radius)
        J += float(S.sigma1 * v.sum() + S.sigma2 * v @ v)
    return J


async def closed_loop(problem: MpcProblem, ctrl: Controller, x0, refs: np.ndarray) -> Trajectory:
    """Apply u0 of each solve to the nominal plant x+ = A x + B u for len(refs) steps (the input before the first
    step, u_prev of the first stage cost, is zero)."""
    T = len(refs)
    X = np.zeros((T + 1, problem.nx))
    U = np.zeros((T, problem.nu))
    X[0] = x0
    cost = 0.0
    u_prev = np.zeros(problem.nu)
    for k in range(T):
        u = np.asarray(await ctrl.step(X[k], refs[k]), dtype=float)
        U[k] = u
        cost += loop_stage_cost(problem, X[k], u, u_prev, refs[k] if problem.ny else None)
        u_prev = u
        X[k + 1] = problem.A @ X[k] + problem.B @ u
    return Trajectory(X, U, np.asarray(refs), cost)


def run_closed_loop(problem: MpcProblem, ctrl: Controller, x0, refs) -> Trajectory:
    """closed_loop for controllers that need no simulator."""
    return asyncio.run(closed_loop(problem, ctrl, x0, refs))
