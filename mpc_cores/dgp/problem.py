"""The QP a DGP core solves: the condensed MPC problem of mpc_cores.problem with two-sided general constraints

    min_z 1/2 z' Q z + (Phi w)' z   s.t.   lo0 + Lw w <= G z <= hi0 + Lw w,     w = (x, r)

with rows for the input box (u_k, k = 0..N-1) and for the `hard_states` box at stages 1..N. In the one-sided form
A z <= b of 003, A = [G; -G] and b = [hi; -lo], and the dual vector is y = (y+, y-) >= 0 (upper, lower rows).

Scaling (section VI-A of 003): the rows of G, lo0, hi0 and Lw are multiplied by sigma = 1 / sqrt(L) with
L = lambda_max(A Q^-1 A') = 2 lambda_max(G Q^-1 G'), so that the dual gradient is 1-Lipschitz and the step 1/L is 1.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from mpc_cores.problem import MpcProblem, _prediction, condense


@dataclass(frozen=True, eq=False)
class DgpQP:
    Q: np.ndarray        # n x n, the condensed Hessian (cost 1/2 z'Qz)
    Phi: np.ndarray      # n x nw, linear term q = Phi w
    G: np.ndarray        # mc x n, scaled constraint rows
    lo0: np.ndarray      # mc, scaled
    hi0: np.ndarray      # mc, scaled
    Lw: np.ndarray       # mc x nw, scaled dependence of both bounds on w
    sigma: float         # the row scaling
    n: int
    nw: int
    nu: int
    N: int
    n_input_rows: int    # the first rows are the input box (identity rows)

    @property
    def mc(self) -> int:
        return self.G.shape[0]

    @property
    def m(self) -> int:
        """dual dimension of 003's one-sided form"""
        return 2 * self.mc

    @property
    def K(self) -> np.ndarray:
        """z = K v + e(w), v = y+ - y-: K = -Q^-1 G' (E of (31) is [K, -K])"""
        return -np.linalg.solve(self.Q, self.G.T)

    @property
    def Fe(self) -> np.ndarray:
        """e(w) = Fe w = -Q^-1 Phi w"""
        return -np.linalg.solve(self.Q, self.Phi)

    def bounds(self, w) -> tuple[np.ndarray, np.ndarray]:
        c = self.Lw @ np.asarray(w, dtype=float)
        return self.lo0 + c, self.hi0 + c


def dgp_qp(p: MpcProblem) -> DgpQP:
    """The scaled two-sided form of a spec (inputs box always, hard state box when the spec has one)."""
    qp = condense(p)
    n, nw, N = qp.n, qp.nw, p.N
    rows = [np.eye(n)]
    lo = [qp.lb]
    hi = [qp.ub]
    Lw = [np.zeros((n, nw))]
    if p.hard_states is not None:
        Sx, Su = _prediction(p)
        idx = [k * p.nx + i for k in range(N) for i in p.hard_states.indices]
        rows.append(Su[idx])
        lo.append(np.tile(p.hard_states.xmin, N))
        hi.append(np.tile(p.hard_states.xmax, N))
        Lw.append(np.hstack([-Sx[idx], np.zeros((len(idx), nw - p.nx))]))
    G = np.vstack(rows)
    Qm = qp.H
    L = 2.0 * float(np.linalg.eigvalsh(G @ np.linalg.solve(Qm, G.T))[-1])
    s = 1.0 / math.sqrt(L)
    return DgpQP(Q=Qm, Phi=qp.Phi, G=s * G, lo0=s * np.concatenate(lo), hi0=s * np.concatenate(hi),
                 Lw=s * np.vstack(Lw), sigma=s, n=n, nw=nw, nu=qp.nu, N=N, n_input_rows=n)


def _osqp(qp: DgpQP, w, eps: float):
    """OSQP's result for the scaled problem at w (adaptive rho, scaling and polish on: OSQP's defaults and ours)"""
    import osqp

    from mpc_cores.quiet import c_output_silenced

    lo, hi = qp.bounds(w)
    prob = osqp.OSQP()
    prob.setup(P=sp.triu(sp.csc_matrix(qp.Q), format="csc"), q=qp.Phi @ np.asarray(w, dtype=float),
               A=sp.csc_matrix(qp.G), l=lo, u=hi, verbose=False, eps_abs=eps, eps_rel=eps, max_iter=200_000,
               polishing=True)
    with c_output_silenced():
        return prob.solve(raise_error=False)


def solve_osqp(qp: DgpQP, w, eps: float = 1e-9):
    """(z*, y*+, y*-, status) of the scaled problem by OSQP (y in the scaled problem's units); status 'solved' or
    OSQP's word for what went wrong (an infeasible state, or OSQP stopping short: solve_qp tells them apart)."""
    import osqp

    res = _osqp(qp, w, eps)
    st = "solved" if res.info.status_val == osqp.SolverStatus.OSQP_SOLVED else str(res.info.status)
    y = res.y if res.y is not None else np.zeros(qp.mc)
    return res.x, np.maximum(y, 0.0), np.maximum(-y, 0.0), st


def feasible(qp: DgpQP, w) -> tuple[bool, float]:
    """Whether some z meets lo(w) <= G z <= hi(w), decided by an LP (mpc_cores.mpc_qp.slack_lp): (feasible, the
    largest slack t*), t* in the scaled problem's units (divide by sigma for the spec's)."""
    from mpc_cores.mpc_qp import slack_lp

    lo, hi = qp.bounds(w)
    return slack_lp(qp.G, lo, hi)


def kkt_residual(qp: DgpQP, z, y, w) -> float:
    """The largest relative KKT residual of (z, y), y = y+ - y- (scaled units): stationarity Q z + q + G'y = 0,
    the bounds, and complementarity (which also catches a multiplier of the wrong sign)."""
    w = np.asarray(w, dtype=float)
    lo, hi = qp.bounds(w)
    s = qp.G @ z
    terms = (qp.Q @ z, qp.Phi @ w, qp.G.T @ y)
    stat = float(np.abs(sum(terms)).max()) / (1.0 + max(float(np.abs(t).max()) for t in terms))
    size = max(1.0, float(np.abs(np.concatenate([lo[np.isfinite(lo)], hi[np.isfinite(hi)]])).max(initial=0.0)))
    gap = np.zeros(qp.mc)
    u, d = y > 0, y < 0
    gap[u] = y[u] * (hi[u] - s[u])
    gap[d] = -y[d] * (s[d] - lo[d])
    comp = float(np.abs(gap).max(initial=0.0)) / (size * (1.0 + float(np.abs(y).max(initial=0.0))))
    return max(stat, violation(qp, z, w) / size, comp)


def dual_active_set(qp: DgpQP, w):
    """(z*, y*) of the QP at w, y = y+ - y-, by the dual active-set method of Goldfarb and Idnani (quadprog):
    exact up to rounding where OSQP's first-order iterations stall on large multipliers; None when quadprog finds
    the constraints inconsistent."""
    import quadprog

    w = np.asarray(w, dtype=float)
    lo, hi = qp.bounds(w)
    up, dn = np.flatnonzero(np.isfinite(hi)), np.flatnonzero(np.isfinite(lo))
    C = np.vstack([-qp.G[up], qp.G[dn]]).T          # C'z >= b: -G z >= -hi, G z >= lo
    try:
        z, _, _, _, lam, _ = quadprog.solve_qp(np.array(qp.Q, dtype=float), -(qp.Phi @ w), C,
                                               np.concatenate([-hi[up], lo[dn]]), 0)
    except ValueError:
        return None
    y = np.zeros(qp.mc)
    y[up] += lam[: up.size]
    y[dn] -= lam[up.size:]
    return z, y


def _retries(qp: DgpQP, w, eps: float):
    """Answers to a feasible QP that OSQP left unsolved at eps: OSQP to a looser tolerance (large multipliers can
    keep the dual residual above a tight eps however long it runs, while a looser one is reached, and OSQP's
    polish then solves the KKT system of the active set exactly); the dual active-set method."""
    res = _osqp(qp, w, max(eps, 1e-4))
    if res.x is not None and res.y is not None:
        yield res.x, res.y
    ans = dual_active_set(qp, w)
    if ans is not None:
        yield ans


@dataclass(frozen=True, eq=False)
class QpAnswer:
    """What solve_qp found at one w (y+, y- in the scaled problem's units)"""
    z: np.ndarray | None
    yp: np.ndarray
    ym: np.ndarray
    status: str                  # 'solved', 'infeasible' (the LP proved it) or OSQP's word for its failure
    margin: float | None = None  # the LP's slack t* (feasible), when the LP was run


def solve_qp(qp: DgpQP, w, eps: float = 1e-9) -> QpAnswer:
    """The QP at w by OSQP; where OSQP does not return 'solved', an LP (feasible) decides whether the state is
    infeasible, and a feasible QP is solved again (_retries), an answer being taken when its KKT residual is at
    most max(eps, 1e-9)."""
    z, yp, ym, st = solve_osqp(qp, w, eps)
    if st == "solved":
        return QpAnswer(z, yp, ym, st)
    ok, t = feasible(qp, w)
    if not ok:
        return QpAnswer(None, yp, ym, "infeasible", t)
    for zr, yr in _retries(qp, w, eps):
        if np.all(np.isfinite(zr)) and np.all(np.isfinite(yr)) and kkt_residual(qp, zr, yr, w) <= max(eps, 1e-9):
            return QpAnswer(zr, np.maximum(yr, 0.0), np.maximum(-yr, 0.0), "solved", t)
    return QpAnswer(z, yp, ym, st, t)


def objective(qp: DgpQP, z, w) -> float:
    z = np.asarray(z, dtype=float)
    return float(0.5 * z @ qp.Q @ z + z @ (qp.Phi @ np.asarray(w, dtype=float)))


def violation(qp: DgpQP, z, w) -> float:
    """||[A z - b]+||_inf in the scaled problem's units"""
    lo, hi = qp.bounds(w)
    s = qp.G @ np.asarray(z, dtype=float)
    return float(max(0.0, np.max(s - hi), np.max(lo - s)))
