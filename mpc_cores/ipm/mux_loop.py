"""Parallel multiplexed MPC (Algorithm 2 of 001) on a generated multiplexed interior-point core: the plan and the
choice of mpc_cores.ipm.multiplexed.MuxPlan, the copies solved by the core (its golden model, or the RTL through
the same frames: mpc_cores.ipm.control).

The closed loop around the core keeps the plan and picks the copy, not the core: choosing needs each candidate's
predicted cost (a T-step rollout of the full model per candidate, m + 2 of them), sequential work on the whole
plan that a host does in microseconds, while the core's channels do what is parallel, the m single-input QPs of a
round in one MINRES batch. The first sample starts from the plan u_s and runs `first_rounds` rounds (no full
solve: the core has none)."""
from __future__ import annotations

import numpy as np

from mpc_cores.ipm.multiplexed import MuxPlan


def frame(job) -> tuple:
    """A round's job (i, dx0, xs, us, dplan, F) as the core's frame data: (channel i, x^, (x_s, u_s,i), F)."""
    i, dx0, xs, us, _, F = job
    return i, dx0 + xs, np.concatenate([xs, us[[i]]]), F


def data(x, ss, F) -> np.ndarray:
    """The frame's data words in order: x^ (n), (x_s, u_s,i) (n + 1), F (T x n, stage by stage)."""
    return np.concatenate([np.ravel(x), np.ravel(ss), np.ravel(F)])


def plan_of(ops, words, T: int) -> np.ndarray:
    """The T planned moves (deviations) of an answer's words (u0, mu, the plan, ...), as float values."""
    return np.asarray(ops.to_float(ops.from_words(words[2: 2 + T])), dtype=float)


class CoreMux(MuxPlan):
    """Algorithm 2 with the copies on a multiplexed core: `solve(i, x, ss, F)` returns copy i's T moves
    (deviations) from the frame (x^, (x_s, u_s,i), F); channel i solves input i."""

    def __init__(self, p, solve, **kw):
        super().__init__(p, **kw)
        self.solve = solve

    def copy(self, *job) -> np.ndarray:
        return np.asarray(self.solve(*frame(job)), dtype=float)


async def run_step(plan: MuxPlan, x, r, solve_round) -> np.ndarray:
    """One sample of `plan` with each round's copies solved together: `await solve_round(frames)` (frames as
    `frame` gives them) returns their moves in order. Returns u_0."""
    gen = plan.steps(x, r)
    try:
        jobs = next(gen)
        while True:
            jobs = gen.send(await solve_round([frame(j) for j in jobs]))
    except StopIteration as e:
        return e.value


def model_solver(model, warm: bool = True):
    """solve(i, x, ss, F) on an IpmCoreModel of a multiplexed core (channel i)."""
    def solve(i, x, ss, F):
        return model.plan(model.solve_copy(i, x, ss, F, warm=warm))
    return solve
