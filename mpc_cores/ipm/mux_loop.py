"""Parallel multiplexed MPC (Algorithm 2 of 001) on a generated multiplexed interior-point core: the plan and the
choice of mpc_cores.ipm.multiplexed.MuxPlan, the copies solved by the core (its golden model here, the RTL in the
testbench through the same frames).

The closed loop around the core keeps the plan and picks the copy, not the core: choosing needs each candidate's
predicted cost (a T-step rollout of the full model per candidate, m + 2 of them), sequential work on the whole
plan that a host does in microseconds, while the core's channels do what is parallel, the m single-input QPs of a
round in one MINRES batch. The first sample starts from the plan u_s and runs `rounds` rounds (no full solve: the
core has none)."""
from __future__ import annotations

import numpy as np

from mpc_cores.ipm.multiplexed import MuxPlan


class CoreMux(MuxPlan):
    """Algorithm 2 with the copies on a multiplexed core: `solve(i, x, ss, F)` returns copy i's T moves
    (deviations) from the frame (x^, (x_s, u_s,i), F); channel i solves input i."""

    def __init__(self, p, solve, **kw):
        super().__init__(p, **kw)
        self.solve = solve

    def copy(self, i, dx0, xs, us, dplan, F) -> np.ndarray:
        return np.asarray(self.solve(i, dx0 + xs, np.concatenate([xs, us[[i]]]), F), dtype=float)


def model_solver(model, warm: bool = True):
    """solve(i, x, ss, F) on an IpmCoreModel of a multiplexed core (channel i)."""
    def solve(i, x, ss, F):
        return model.plan(model.solve_copy(i, x, ss, F, warm=warm))
    return solve
