"""Algorithm 1 of 001 in float64: the infeasible primal-dual interior-point method on the sparse MPC QP
(mpc_cores.ipm.sparse), with the reduced KKT system A_k dz = b_k of section V solved exactly or by MINRES.

Boxed variable i has two inequalities, theta_i <= hi_i (slack su, multiplier lu) and -theta_i <= -lo_i (sl, ll).
Per Newton iteration (lines of Algorithm 1):
  residuals (6a-d): rH = -(K0 z)_primal - (lu - ll), rF = f - (K0 z)_eq, rGu = hi - theta - su,
                    rGl = theta - lo - sl, rS = -lambda s + sigma mu;  mu = lambda's / (number of inequalities) (7)
  W_k (line 1): w_i = lu/su + ll/sl on the boxed variables
  b_k (line 2): b_primal = rH - (tu - tl) with tu = (rSu - lu rGu)/su, tl = (rSl - ll rGl)/sl; b_eq = rF
  line 3: A_k dz = b_k, A_k = K0 + diag(w)
  lines 4-5: dlu = wu dtheta + tu, dll = -wl dtheta + tl;  dsu = rGu - dtheta, dsl = rGl + dtheta
  line 6: alpha = tau * min(1, largest step keeping (lambda, s) > 0)
  line 7: z, lambda, s += alpha (dz, dlambda, ds)
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mpc_cores.ipm.sparse import Sample, SparseMpc


@dataclass
class Iterate:
    z: np.ndarray    # N, interleaved (multipliers of the dynamics and primal unknowns)
    lu: np.ndarray
    ll: np.ndarray
    su: np.ndarray
    sl: np.ndarray

    def copy(self) -> "Iterate":
        return Iterate(*(a.copy() for a in (self.z, self.lu, self.ll, self.su, self.sl)))


def cold_start(s: SparseMpc, value: float = 1.0) -> Iterate:
    nb = len(s.bounded)
    return Iterate(np.zeros(s.N), *(np.full(nb, value) for _ in range(4)))


@dataclass
class Stats:
    mu: float = 0.0
    residual: float = 0.0      # largest |rH|, |rF|, |rG| of the last linearisation
    alphas: list = field(default_factory=list)


def exact_solver(A: np.ndarray, b: np.ndarray, d: np.ndarray | None = None) -> np.ndarray:
    return np.linalg.solve(A, b)


def minres_solver(imax: int, precondition: bool = True):
    """MINRES from 0 for imax iterations on D A D y = D b, z = D y (D = 1 without preconditioning)."""
    from mpc_cores.minres.model import minres64

    def solve(A, b, d=None):
        if not precondition or d is None:
            return minres64(A, b, imax)
        return d * minres64(d[:, None] * A * d[None, :], d * b, imax)
    return solve


def equilibration(s: SparseMpc, w_full: np.ndarray) -> np.ndarray:
    """The diagonal preconditioner: d_i = 1 / sqrt(max_j |A_ij|) (one Ruiz equilibration step). The largest
    off-diagonal of every row is a constant of the problem; only the primal diagonal changes with W_k."""
    off = np.abs(s.K0 - np.diag(np.diag(s.K0))).max(axis=1)
    diag = np.abs(np.diag(s.K0) + w_full)
    return 1.0 / np.sqrt(np.maximum(off, diag))


def newton_step(s: SparseMpc, smp: Sample, it: Iterate, sigma: float, tau: float, solver, stats: Stats,
                precondition: bool = True) -> Iterate:
    K0, pr, bd = s.K0, s.primal, s.bounded
    z, lu, ll, su, sl = it.z, it.lu, it.ll, it.su, it.sl
    th = z[pr][bd]
    Kz = K0 @ z
    mu = (lu @ su + ll @ sl) / s.n_ineq
    rH = -Kz[pr]
    rH[bd] -= lu - ll
    eq = np.ones(s.N, bool)
    eq[pr] = False
    rF = (smp.f - Kz)[eq]
    rGu = smp.hi - th - su
    rGl = th - smp.lo - sl
    rSu = -lu * su + sigma * mu
    rSl = -ll * sl + sigma * mu
    wu, wl = lu / su, ll / sl
    tu = (rSu - lu * rGu) / su
    tl = (rSl - ll * rGl) / sl
    w_full = np.zeros(s.N)
    wp = np.zeros(len(pr))
    wp[bd] = wu + wl
    w_full[pr] = wp
    b = np.zeros(s.N)
    bp = rH.copy()
    bp[bd] -= tu - tl
    b[pr] = bp
    b[eq] = rF
    A = K0 + np.diag(w_full)
    d = equilibration(s, w_full) if precondition else None
    dz = solver(A, b, d)
    dth = dz[pr][bd]
    dlu = wu * dth + tu
    dll = -wl * dth + tl
    dsu = rGu - dth
    dsl = rGl + dth
    v = np.concatenate([lu, ll, su, sl])
    dv = np.concatenate([dlu, dll, dsu, dsl])
    neg = dv < 0
    amax = min(1.0, float(np.min(-v[neg] / dv[neg]))) if neg.any() else 1.0
    alpha = tau * amax
    stats.mu = mu
    stats.residual = float(max(np.abs(rH).max(), np.abs(rF).max(), np.abs(rGu).max(initial=0), np.abs(rGl).max(initial=0)))
    stats.alphas.append(alpha)
    return Iterate(z + alpha * dz, lu + alpha * dlu, ll + alpha * dll, su + alpha * dsu, sl + alpha * dsl)


def pdip(s: SparseMpc, smp: Sample, iterations: int, sigma: float = 0.1, tau: float = 0.99, start: Iterate | None = None,
         solver=exact_solver, precondition: bool = True) -> tuple[Iterate, Stats]:
    it = start.copy() if start is not None else cold_start(s)
    st = Stats()
    for _ in range(iterations):
        it = newton_step(s, smp, it, sigma, tau, solver, st, precondition)
    return it, st
