"""The sparse MPC QP of 001 (section II-B) in the interleaved order of Fig. 4: the unknowns z = (nu_0, x_0, u_0,
nu_1, ..., nu_T, x_T) of mpc_cores.minres.kkt, states and inputs as variables, the dynamics as equalities and a box
on every bounded primal variable (inputs; states of `hard_states` at stages 1..T).

Tracking is solved in deviation variables: with the steady state (x_s, u_s) of the reference r
(mpc_cores.problem.steady_state_maps), the QP is a regulator in (x - x_s, u - u_s) from x_0 = x^ - x_s with the
bounds shifted by the steady state, and u_0 = du_0 + u_s. The cost is sum x'Qx + u'Ru + x_T'QN x_T (the QP's 1/2
z'Hz with H = blkdiag(Q, R, ..., QN) has the same minimiser)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mpc_cores.minres.kkt import Layout, kkt_matrix
from mpc_cores.problem import MpcProblem, steady_state_maps


@dataclass(frozen=True, eq=False)
class SparseMpc:
    """The problem data that does not change from sample to sample."""
    problem: MpcProblem
    L: Layout
    K0: np.ndarray          # N x N KKT matrix without the interior-point weights
    primal: np.ndarray      # row of every primal unknown (order of the variable part)
    bounded: np.ndarray     # indices into `primal` of the boxed variables
    lo: np.ndarray          # their bounds before the steady-state shift
    hi: np.ndarray
    shift_of: np.ndarray    # per boxed variable: 0..n-1 a state, n..n+m-1 an input (which steady state it shifts by)
    Mx: np.ndarray
    Mu: np.ndarray

    @property
    def N(self) -> int:
        return self.L.N

    @property
    def n_ineq(self) -> int:
        """inequalities: two per boxed variable"""
        return 2 * len(self.bounded)


def sparse_mpc(p: MpcProblem) -> SparseMpc:
    n, m, T = p.nx, p.nu, p.N
    L = Layout(n, m, T)
    K0 = kkt_matrix(p.A, p.B, p.Q, p.R, p.QN, T)
    bounded, lo, hi, sh = [], [], [], []
    k_of = 0
    for k in range(T + 1):
        if k > 0 and p.hard_states is not None:
            for i, lo_i, hi_i in zip(p.hard_states.indices, p.hard_states.xmin, p.hard_states.xmax):
                bounded.append(k_of + i); lo.append(lo_i); hi.append(hi_i); sh.append(i)
        k_of += n
        if k < T:
            for i in range(m):
                bounded.append(k_of + i); lo.append(p.umin[i]); hi.append(p.umax[i]); sh.append(n + i)
            k_of += m
    Mx, Mu = steady_state_maps(p)
    return SparseMpc(p, L, K0, L.primal_rows(), np.array(bounded, dtype=np.int64), np.array(lo, float),
                     np.array(hi, float), np.array(sh, dtype=np.int64), Mx, Mu)


@dataclass(frozen=True, eq=False)
class Sample:
    """One QP: the shifted initial state and bounds of a sample (x^, r)."""
    x0: np.ndarray      # x^ - x_s
    lo: np.ndarray
    hi: np.ndarray
    us: np.ndarray      # u_s, added back to du_0
    f: np.ndarray       # right-hand side of the equality rows (N vector, zero on primal rows)


def sample(s: SparseMpc, x, r=None) -> Sample:
    p = s.problem
    r = np.zeros(p.ny) if r is None or p.ny == 0 else np.asarray(r, float)
    xs = s.Mx @ r if p.ny else np.zeros(p.nx)
    us = s.Mu @ r if p.ny else np.zeros(p.nu)
    ss = np.concatenate([xs, us])
    x0 = np.asarray(x, float) - xs
    f = np.zeros(s.N)
    f[s.L.lam(0): s.L.lam(0) + p.nx] = -x0
    return Sample(x0, s.lo - ss[s.shift_of], s.hi - ss[s.shift_of], us, f)


def u0(s: SparseMpc, z: np.ndarray, smp: Sample) -> np.ndarray:
    u = s.L.u(0)
    return z[u: u + s.problem.nu] + smp.us
