"""Parallel multiplexed MPC (Algorithm 2 of 001, section VII) on the float64 interior-point reference.

Step 1 optimises all inputs; afterwards, at every sample, m copies run in parallel, copy i re-optimising the T moves
of input channel i with the other channels fixed to the stored plan; the copy with the smallest predicted cost
is applied and its moves update the plan, which is shifted by one sample (last move repeated). Copy i is a
single-input MPC problem (B_i, R_ii, the bounds of input i) whose dynamics carry the planned moves of the other
channels as a known term: the equality rows of the sparse QP get f_{k+1} = -B_{-i} du_{-i,k} (deviation variables
of the full problem's steady state).
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from mpc_cores.ipm.reference import pdip
from mpc_cores.ipm.sparse import sample, sparse_mpc
from mpc_cores.problem import MpcProblem, _targets


def _channel(p: MpcProblem, i: int) -> MpcProblem:
    return replace(p, name=f"{p.name}_u{i}", B=p.B[:, [i]], R=p.R[np.ix_([i], [i])], umin=p.umin[[i]],
                   umax=p.umax[[i]], C=None, rmin=np.zeros(0), rmax=np.zeros(0))


def _cost(p: MpcProblem, dx0, dU) -> float:
    """Predicted cost in deviation variables of the plan dU (T x m) from dx0."""
    x, J = dx0.copy(), 0.0
    for k in range(p.N):
        J += x @ p.Q @ x + dU[k] @ p.R @ dU[k]
        x = p.A @ x + p.B @ dU[k]
    return float(J + x @ p.QN @ x)


class ParallelMmpc:
    """Algorithm 2: `step(x, r)` returns u_0 and keeps the plan; `copies` QPs per sample (m, one per channel)."""

    def __init__(self, p: MpcProblem, iterations: int = 20):
        self.p, self.it = p, iterations
        self.full = sparse_mpc(p)
        self.chan = [sparse_mpc(_channel(p, i)) for i in range(p.nu)]
        self.plan = None     # T x m planned inputs (absolute)
        self.chosen: list[int] = []

    def _solve_full(self, x, r):
        s = self.full
        smp = sample(s, x, r)
        it, _ = pdip(s, smp, self.it)
        L = s.L
        return np.array([it.z[L.u(k): L.u(k) + self.p.nu] + smp.us for k in range(self.p.N)])

    def step(self, x, r=None) -> np.ndarray:
        p = self.p
        if self.plan is None:
            self.plan = self._solve_full(x, r)
            self.chosen.append(-1)
            return self.plan[0]
        self.plan = np.vstack([self.plan[1:], self.plan[-1:]])
        xs, us = _targets(p, r)
        dx0 = np.asarray(x, float) - xs
        dplan = self.plan - us
        best, best_J = None, np.inf
        for i, s in enumerate(self.chan):
            others = [j for j in range(p.nu) if j != i]
            smp = sample(s, dx0)
            f = smp.f.copy()
            for k in range(p.N):
                row = s.L.lam(k + 1)
                f[row: row + p.nx] = -(p.B[:, others] @ dplan[k, others])
            bound_shift = us[i]
            smp = replace(smp, f=f, lo=smp.lo - bound_shift, hi=smp.hi - bound_shift)
            it, _ = pdip(s, smp, self.it)
            dU = dplan.copy()
            dU[:, i] = [it.z[s.L.u(k)] for k in range(p.N)]
            J = _cost(p, dx0, dU)
            if J < best_J:
                best, best_J = (i, dU + us), J
        self.chosen.append(best[0])
        self.plan = best[1]
        return self.plan[0]
