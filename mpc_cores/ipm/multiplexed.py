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


def channel_problem(p: MpcProblem, i: int) -> MpcProblem:
    """Copy i's problem: input i alone (B_i, R_ii, its bounds), no tracking (the steady state comes with the
    sample), the states' hard box as the full problem's."""
    return replace(p, name=f"{p.name}_u{i}", B=p.B[:, [i]], R=p.R[np.ix_([i], [i])], umin=p.umin[[i]],
                   umax=p.umax[[i]], C=None, rmin=np.zeros(0), rmax=np.zeros(0))


def _cost(p: MpcProblem, dx0, dU) -> float:
    """Predicted cost in deviation variables of the plan dU (T x m) from dx0."""
    x, J = dx0.copy(), 0.0
    for k in range(p.N):
        J += x @ p.Q @ x + dU[k] @ p.R @ dU[k]
        x = p.A @ x + p.B @ dU[k]
    return float(J + x @ p.QN @ x)


class MuxPlan:
    """Algorithm 2's plan and choice around a copy solver: `step(x, r)` returns u_0 and keeps the plan. `copy(i,
    dx0, xs, us, dplan, F)` (a subclass's) solves copy i from the stored plan (dplan: T x m deviations from the
    steady state (x_s, u_s); F: T x n, the known term of its dynamics rows) and returns its T moves of input i
    (deviations); the copies of a round are independent, so the core runs them as one batch.

    Additions for tracking (a reference change moves the steady state (x_s, u_s) that the plan's deviation
    variables are taken from):
    - `shift`: the stored plan moves with u_s (plan += u_s,new - u_s,old, clipped to the input box), so the
      channels that are not chosen follow the new steady state instead of holding the old one;
    - `rounds`: in a sample whose reference changed, the m copies run `rounds` times, each round from the plan the
      previous one chose (block-coordinate descent on the full QP); otherwise once;
    - `blends`: besides the m copies, the candidates include the plan with every channel's new moves applied at
      once, scaled by each blend factor (Jacobi steps); the cheapest candidate by predicted cost is applied.
    `shift=False, rounds=1, blends=()` is Algorithm 2 as 001 states it. `chosen` records the copy per round (-1:
    the full solve of the first sample, -2: a blend). The first sample: `first_sample` (a subclass's, the full
    problem's plan), or, without one, the plan u_s (clipped to the input box) from which the copies run
    `first_rounds` rounds (default twice `rounds`)."""

    def __init__(self, p: MpcProblem, shift: bool = True, rounds: int = 4, blends: tuple[float, ...] = (0.5, 1.0),
                 first_rounds: int | None = None):
        self.p = p
        self.shift, self.rounds, self.blends = shift, rounds, tuple(blends)
        self.first_rounds = 2 * rounds if first_rounds is None else first_rounds
        self.plan = None     # T x m planned inputs (absolute)
        self.us = None       # the steady-state input of the last sample
        self.chosen: list[int] = []
        self.copies = 0      # single-input QPs solved so far
        self.rounds_run = 0

    def first_sample(self, x, r):
        """the first sample's plan (T x m, absolute), or None: the copies start from u_s"""
        return None

    def copy(self, i: int, dx0, xs, us, dplan, F) -> np.ndarray:
        raise NotImplementedError

    def step(self, x, r=None) -> np.ndarray:
        """One sample, the copies solved by `copy` one by one."""
        gen = self.steps(x, r)
        try:
            jobs = next(gen)
            while True:
                jobs = gen.send([self.copy(*j) for j in jobs])
        except StopIteration as e:
            return e.value

    def steps(self, x, r=None):
        """One sample as a generator: it yields each round's copies, a list of (i, dx0, xs, us, dplan, F), is sent
        their moves (a list of T-vectors in the same order) and returns u_0. A solver that runs a round as one
        batch (the core: mpc_cores.ipm.mux_loop) drives it."""
        p = self.p
        xs, us = _targets(p, r)
        dx0 = np.asarray(x, float) - xs
        if self.plan is None:
            plan = self.first_sample(x, r)
            if plan is not None:
                self.plan, self.us = plan, us
                self.chosen.append(-1)
                return self.plan[0]
            self.plan, self.us = np.clip(np.tile(us, (p.N, 1)), p.umin, p.umax), us
            n_rounds = self.first_rounds
        else:
            changed = not np.array_equal(us, self.us)
            if self.shift:   # kept inside the input box: a copy re-optimises only its own channel's moves
                self.plan = np.clip(self.plan + (us - self.us), p.umin, p.umax)
            self.us = us
            self.plan = np.vstack([self.plan[1:], self.plan[-1:]])
            n_rounds = self.rounds if changed else 1
        for _ in range(n_rounds):
            dplan = self.plan - us
            jobs = [(i, dx0, xs, us, dplan, self.known_term(i, dplan)) for i in range(p.nu)]
            moves = yield jobs
            self._choose(dx0, us, dplan, moves)
        return self.plan[0]

    def known_term(self, i: int, dplan) -> np.ndarray:
        """T x n: F_k = -B_{-i} du_{-i,k}, the other channels' planned moves in copy i's dynamics rows"""
        others = [j for j in range(self.p.nu) if j != i]
        return -(dplan[:, others] @ self.p.B[:, others].T)

    def _choose(self, dx0, us, dplan, moves) -> None:
        """The round's candidates (each copy's moves in the plan, the blends); the cheapest becomes the plan."""
        p = self.p
        new = dplan.copy()
        cands = []
        for i, du in enumerate(moves):
            # an interior-point iterate stops inside its box only to the solver's tolerance: clipped to it
            du = np.clip(du, p.umin[i] - us[i], p.umax[i] - us[i])
            self.copies += 1
            dU = dplan.copy()
            dU[:, i] = new[:, i] = du
            cands.append((_cost(p, dx0, dU), i, dU))
        for w in self.blends:
            dU = dplan + w * (new - dplan)
            cands.append((_cost(p, dx0, dU), -2, dU))
        _, i, dU = min(cands, key=lambda c: c[0])
        self.chosen.append(i)
        self.rounds_run += 1
        self.plan = dU + us


class ParallelMmpc(MuxPlan):
    """Algorithm 2 on the float64 interior-point reference (`iterations` per QP); the first sample optimises all
    inputs (the full problem)."""

    def __init__(self, p: MpcProblem, iterations: int = 20, shift: bool = True, rounds: int = 4,
                 blends: tuple[float, ...] = (0.5, 1.0)):
        super().__init__(p, shift, rounds, blends)
        self.it = iterations
        self.full = sparse_mpc(p)
        self.chan = [sparse_mpc(channel_problem(p, i)) for i in range(p.nu)]

    def first_sample(self, x, r):
        s = self.full
        smp = sample(s, x, r)
        it, _ = pdip(s, smp, self.it)
        L = s.L
        return np.array([it.z[L.u(k): L.u(k) + self.p.nu] + smp.us for k in range(self.p.N)])

    def copy(self, i, dx0, xs, us, dplan, F) -> np.ndarray:
        p, s = self.p, self.chan[i]
        smp = sample(s, dx0)
        f = smp.f.copy()
        for k in range(p.N):
            row = s.L.lam(k + 1)
            f[row: row + p.nx] = F[k]
        ss = np.concatenate([xs, us[[i]]])   # the bounds shifted by the full problem's steady state
        smp = replace(smp, f=f, lo=s.lo - ss[s.shift_of], hi=s.hi - ss[s.shift_of])
        it, _ = pdip(s, smp, self.it)
        return np.array([it.z[s.L.u(k)] for k in range(p.N)])
