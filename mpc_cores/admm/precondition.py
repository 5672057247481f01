"""Diagonal preconditioning of the splitting family's QP (004): a Ruiz equilibration of the KKT matrix
[[H, F'], [F, 0]] with every factor a power of two, so that it stays shifts.

For ADMM, AMA and Vu-Condat the scaled QP (z = D z~, cost times c, rows of F times E) iterates exactly as the
original one with the steps rho_j / (c D_j^2): the preconditioner is a change of the per-component steps, which
the core's shifts k_j already are (`design_admm(..., precondition=True)`; docs/methods.md)."""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from mpc_cores.admm.problem import AdmmQP

RUIZ_SWEEPS = 25


def reduced_curvature(qp: AdmmQP) -> float:
    """mu = lambda_min(Z'HZ), Z an orthonormal basis of Ker F: the strong convexity of the y-step's function."""
    Z = scipy.linalg.null_space(qp.F)
    return float(np.linalg.eigvalsh(Z.T @ qp.H @ Z)[0])


def pow2_below(x: float) -> float:
    """The largest power of two strictly below x > 0."""
    k = math.floor(math.log2(x))
    return 2.0 ** (k - 1 if 2.0 ** k >= x else k)


def round_log2(s: np.ndarray) -> np.ndarray:
    return np.round(np.log2(s)).astype(np.int64)


@dataclass(frozen=True, eq=False)
class Pow2Scaling:
    """z = D z~ (D = 2^d), rows of F scaled by E = 2^e, cost by 2^c."""
    d: np.ndarray
    e: np.ndarray
    c: int

    @property
    def D(self) -> np.ndarray:
        return np.ldexp(1.0, self.d)

    @property
    def E(self) -> np.ndarray:
        return np.ldexp(1.0, self.e)

    @property
    def cost(self) -> float:
        return 2.0 ** self.c


def ruiz_pow2(qp: AdmmQP, sweeps: int = RUIZ_SWEEPS) -> Pow2Scaling:
    """Ruiz equilibration of the KKT matrix [[H, F'], [F, 0]], soft pairs tied, factors rounded to powers of two;
    then the cost scale 1 / (mean infinity norm of the nonzero columns of D H D), rounded likewise."""
    n, m = qp.n, qp.F.shape[0]
    K = np.abs(np.block([[qp.H, qp.F.T], [qp.F, np.zeros((m, m))]]))
    s = np.ones(n + m)
    for _ in range(sweeps):
        r = (s[:, None] * K * s[None, :]).max(axis=1)
        t = 1.0 / np.sqrt(np.where(r > 0, r, 1.0))
        if qp.ns:
            g = np.sqrt(t[qp.soft_x] * t[qp.soft_d])
            t[qp.soft_x] = t[qp.soft_d] = g
        s *= t
    d, e = round_log2(s[:n]), round_log2(s[n:])
    D = np.ldexp(1.0, d)
    cols = np.abs(D[:, None] * qp.H * D[None, :]).max(axis=0)
    cols = cols[cols > 0]
    c = -int(np.round(np.log2(cols.mean()))) if cols.size else 0
    return Pow2Scaling(d=d, e=e, c=c)


def scale_qp(qp: AdmmQP, sc: Pow2Scaling) -> AdmmQP:
    """The QP in z~ = D^-1 z (same optimum after unscaling, see the module docstring)."""
    D, E, c = sc.D, sc.E, sc.cost
    Dx = D[qp.soft_x]
    return dataclasses.replace(
        qp, H=c * D[:, None] * qp.H * D[None, :], h_w=c * D[:, None] * qp.h_w, h0=c * D * qp.h0,
        F=E[:, None] * qp.F * D[None, :], b_w=E[:, None] * qp.b_w, lo=qp.lo / D, hi=qp.hi / D,
        soft_c=qp.soft_c / Dx, soft_r=qp.soft_r / Dx)
