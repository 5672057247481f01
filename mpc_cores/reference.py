"""Floating-point reference solutions of the condensed box-constrained QP."""

from __future__ import annotations

import numpy as np
import osqp
import scipy.sparse as sp

from mpc_cores.quiet import c_output_silenced

from .problem import CondensedQP


def _linear_term(qp: CondensedQP, w) -> np.ndarray:
    w = np.asarray(w, dtype=float).reshape(-1)
    if w.shape[0] != qp.nw:
        raise ValueError(f"w has {w.shape[0]} entries, expected nw = {qp.nw}")
    return qp.Phi @ w


def kkt_residual(qp: CondensedQP, z, w) -> float:
    """Infinity norm of the projected-gradient step z - P(z - grad); zero iff z is optimal."""
    z = np.asarray(z, dtype=float)
    g = qp.H @ z + _linear_term(qp, w)
    return float(np.abs(z - np.clip(z - g, qp.lb, qp.ub)).max())


def solve_qp_osqp(qp: CondensedQP, w, eps: float = 1e-10) -> np.ndarray:
    q = _linear_term(qp, w)
    P = sp.triu(sp.csc_matrix(qp.H), format="csc")
    A = sp.identity(qp.n, format="csc")
    solver = osqp.OSQP()
    solver.setup(P=P, q=q, A=A, l=np.array(qp.lb, dtype=float), u=np.array(qp.ub, dtype=float),
                 eps_abs=eps, eps_rel=eps, polishing=True, verbose=False, max_iter=200_000)
    with c_output_silenced():
        res = solver.solve(raise_error=False)
    if res.info.status_val != osqp.SolverStatus.OSQP_SOLVED:
        raise RuntimeError(f"OSQP did not solve the QP: status {res.info.status!r}")
    # ADMM iterates may sit a rounding error outside the box.
    return np.clip(np.asarray(res.x, dtype=float), qp.lb, qp.ub)


def _reduced_solve(qp: CondensedQP, q: np.ndarray, z: np.ndarray, tol: float):
    """Fix the variables the gradient pushes against a bound; solve the rest exactly."""
    g = qp.H @ z + q
    scale = max(1.0, float(np.abs(qp.ub - qp.lb).max()))
    at_lb = (z <= qp.lb + tol * scale) & (g > 0)
    at_ub = (z >= qp.ub - tol * scale) & (g < 0)
    fixed = at_lb | at_ub
    zc = np.where(at_lb, qp.lb, np.where(at_ub, qp.ub, z))
    free = ~fixed
    if free.any():
        Hff = qp.H[np.ix_(free, free)]
        rhs = -(q[free] + qp.H[np.ix_(free, fixed)] @ zc[fixed])
        zc[free] = np.linalg.solve(Hff, rhs)
    return zc


def solve_qp_exact(qp: CondensedQP, w, tol: float = 1e-12, max_rounds: int = 50) -> np.ndarray:
    """Fast gradient method in float64 followed by an active-set polish, independent of OSQP.

    Stops when the projected-gradient residual is below tol relative to the
    problem scale; raises RuntimeError otherwise.
    """
    q = _linear_term(qp, w)
    H = qp.H
    lam = np.linalg.eigvalsh(H)
    L, mu = float(lam[-1]), float(lam[0])
    if mu <= 0:
        raise ValueError(f"H is not positive definite: smallest eigenvalue {mu:.3g}")
    beta = (np.sqrt(L) - np.sqrt(mu)) / (np.sqrt(L) + np.sqrt(mu))
    # Enough iterations per round to contract the error by ~1e-3 at the linear FGM rate.
    iters = int(min(20_000, max(50, 7.0 * np.sqrt(L / mu))))
    scale = max(1.0, float(np.abs(q).max()), float(np.abs(qp.ub - qp.lb).max()))

    z = np.clip(np.zeros(qp.n), qp.lb, qp.ub)
    y = z.copy()
    best, best_res = z, np.inf
    for _ in range(max_rounds):
        for _ in range(iters):
            z_new = np.clip(y - (H @ y + q) / L, qp.lb, qp.ub)
            y = z_new + beta * (z_new - z)
            z = z_new
        cand = _reduced_solve(qp, q, z, 1e-9)
        for c in (z, cand, np.clip(cand, qp.lb, qp.ub)):
            if np.all(c >= qp.lb) and np.all(c <= qp.ub):
                res = kkt_residual(qp, c, w)
                if res < best_res:
                    best, best_res = c, res
        if best_res <= tol * scale:
            return best.copy()
        y = best.copy()
        z = best.copy()
    raise RuntimeError(f"solve_qp_exact did not converge: KKT residual {best_res:.3g}")
