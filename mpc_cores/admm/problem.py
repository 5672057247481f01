"""Sparse (uncondensed) form (8) of 002 for the state-constrained MPC problem (2), and its float64 references.

Two forms, by whether the spec has an `input_rate` section (AdmmQP.rate).

Rate-augmented (input_rate): the state is augmented with the previous input, x~_k = (x_k, u_{k-1}), and the
decision input is du_k = u_k - u_{k-1},

    x~_{k+1} = A~ x~_k + B~ du_k,   A~ = [[A, B], [0, I]],   B~ = [[B], [I]],

so |du| <= dumax is a box on the decision variable and umin <= u_k <= umax a hard box on the u-part of x~_{k+1}.
Without input_rate the decision inputs are the u_k themselves (boxed by the input box) and x~_k = x_k.
Decision vector, in the order of 002 (III-B), with v_k = du_k (rate) or u_k:

    z = (v_0, ..., v_{N-1}, x~_0, delta_0, x~_1, delta_1, ..., x~_N, delta_N),   n_A = N(nu + nx~ + |S|) + nx~ + |S|.

Cost (same scaling as mpc_cores.problem.condense, i.e. no factor 1/2 on the stage terms):

    sum_{k<N} (x_k - xs)'Q(x_k - xs) + (u_k - us)'R(u_k - us) [+ du_k' W du_k] + (x_N - xs)'QN(x_N - xs)
    + sum_{k=0..N} sigma1 1'delta_k + sigma2 ||delta_k||^2 = 0.5 z'H_A z + h(w)'z + const(w),

with (xs, us) the steady state of the reference r; in the rate form R acts on u_k through the u-part of x~_{k+1},
otherwise on the decision u_k directly (R is positive definite, so every decision input carries curvature without
a rate weight). delta_0 is penalised too (a constant for given x, but it gives every slack curvature: Lemma 2 of
002 needs it). Equality F z = b(w): x~_0 = (x, u_prev) (rate) or x_0 = x, and the dynamics. The parameter
streamed to the core is w = (x, u_prev, r) in the rate form (the previously applied input is part of the state
the user sends), w = (x, r) otherwise.
K: box on the decision inputs (du: the rate box; u: the input box); hard boxes (the inputs in x~ under the rate
form, `hard_states`) on stages 1..N (stage 0 is pinned by F z = b, a constraint there could only make the problem
infeasible); soft sets |x_i - c_i| <= r_i + delta_i, delta_i >= 0 on all stages.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import osqp
import scipy.sparse as sp

from mpc_cores.problem import MpcProblem, steady_state_maps
from mpc_cores.quiet import c_output_silenced

# component kinds of z, as the projection block sees them
FREE, BOX, SOFT_X, SOFT_D = 0, 1, 2, 3


@dataclass(frozen=True, eq=False)
class AdmmQP:
    problem: MpcProblem
    N: int
    nu: int            # inputs (= size of each decision input du_k or u_k)
    nx: int            # state size per stage: nx~ = nx + nu (rate form) or nx
    ns: int            # soft components per stage |S|
    n: int             # n_A
    nw: int            # w = (x, u_prev, r) (rate form) or (x, r)
    H: np.ndarray      # H_A (n x n), PSD
    h_w: np.ndarray    # h(w) = h_w w + h0
    h0: np.ndarray
    F: np.ndarray      # (n_eq x n)
    b_w: np.ndarray    # b(w) = b_w w
    kind: np.ndarray   # FREE / BOX / SOFT_X / SOFT_D per component
    lo: np.ndarray     # box bounds (BOX components; -inf / inf elsewhere)
    hi: np.ndarray
    soft_x: np.ndarray  # z indices of the soft state components, all stages
    soft_d: np.ndarray  # z index of the matching slack
    soft_c: np.ndarray  # centre and radius per soft pair
    soft_r: np.ndarray
    wlo: np.ndarray    # box of accepted w
    whi: np.ndarray
    sigma1: float
    sigma2: float
    rate: bool = True  # the rate-augmented form (decision inputs du_k, w carries u_prev); else decision inputs u_k

    def du_index(self, k: int) -> slice:
        """the k-th decision input: du_k in the rate form, u_k otherwise"""
        return slice(k * self.nu, (k + 1) * self.nu)

    def stage_offset(self, k: int) -> int:
        return self.N * self.nu + k * (self.nx + self.ns)

    def x_index(self, k: int) -> slice:
        o = self.stage_offset(k)
        return slice(o, o + self.nx)

    def d_index(self, k: int) -> slice:
        o = self.stage_offset(k) + self.nx
        return slice(o, o + self.ns)

    def h(self, w) -> np.ndarray:
        return self.h_w @ np.asarray(w, dtype=float) + self.h0

    def b(self, w) -> np.ndarray:
        return self.b_w @ np.asarray(w, dtype=float)

    def w(self, x, u_prev, r) -> np.ndarray:
        """The parameter of this form: (x, u_prev, r) in the rate form, (x, r) otherwise (u_prev unused)."""
        parts = [x, u_prev, r] if self.rate else [x, r]
        return np.concatenate([np.asarray(a, dtype=float).reshape(-1) for a in parts])

    def inputs(self, z) -> np.ndarray:
        """u_0..u_{N-1} (N x nu) of a decision vector: the u-parts of x~_1..x~_N (rate form), or the decision
        inputs themselves."""
        z = np.asarray(z)
        if not self.rate:
            return z[: self.N * self.nu].reshape(self.N, self.nu).copy()
        nx0 = self.problem.nx
        return np.array([z[self.x_index(k + 1)][nx0:] for k in range(self.N)])

    def objective(self, z, w) -> float:
        """MPC cost (2) of z including the constant terms (equals the tracking cost of mpc_cores.problem plus the
        du weight and the slack penalties for a dynamically feasible z)."""
        z = np.asarray(z, dtype=float)
        w = np.asarray(w, dtype=float)
        return float(0.5 * z @ self.H @ z + self.h(w) @ z + _constant(self, w))


def _constant(qp: AdmmQP, w) -> float:
    p = qp.problem
    r = np.asarray(w, dtype=float)[qp.nx:]
    if r.size == 0:
        return 0.0
    Mx, Mu = steady_state_maps(p)
    xs, us = Mx @ r, Mu @ r
    return float(qp.N * (xs @ p.Q @ xs + us @ p.R @ us) + xs @ p.QN @ xs)


def build_admm_qp(p: MpcProblem) -> AdmmQP:
    """The sparse form (8) of p: rate-augmented when p has an input_rate section, else with the inputs as
    decision variables (module docstring)."""
    rate = p.input_rate is not None
    N, nx0, nu = p.N, p.nx, p.nu
    nx = nx0 + nu if rate else nx0
    soft, hard = p.soft_states, p.hard_states
    S = () if soft is None else soft.indices
    ns = len(S)
    n = N * (nu + nx + ns) + nx + ns
    ny = p.ny
    nw = nx + ny

    if rate:
        At = np.block([[p.A, p.B], [np.zeros((nu, nx0)), np.eye(nu)]])
        Bt = np.vstack([p.B, np.eye(nu)])
    else:
        At, Bt = p.A, p.B
    Mx, Mu = steady_state_maps(p)

    H = np.zeros((n, n))
    h_w = np.zeros((n, nw))
    h0 = np.zeros(n)
    kind = np.full(n, FREE)
    lo = np.full(n, -np.inf)
    hi = np.full(n, np.inf)

    def du(k):
        return slice(k * nu, (k + 1) * nu)

    def off(k):
        return N * nu + k * (nx + ns)

    for k in range(N):
        kind[du(k)] = BOX
        if rate:
            H[du(k), du(k)] = 2 * p.input_rate.weight
            lo[du(k)] = p.input_rate.dumin
            hi[du(k)] = p.input_rate.dumax
        else:                       # u_k itself: R's curvature and the input box
            H[du(k), du(k)] = 2 * p.R
            h_w[du(k), nx:] = -2 * p.R @ Mu
            lo[du(k)] = p.umin
            hi[du(k)] = p.umax
    soft_x, soft_d = [], []
    for k in range(N + 1):
        o = off(k)
        xs_ = slice(o, o + nx0)
        Qk = p.QN if k == N else p.Q
        H[xs_, xs_] = 2 * Qk
        h_w[xs_, nx:] = -2 * Qk @ Mx
        if k >= 1:
            if rate:                # u_{k-1} lives in x~_k
                us_ = slice(o + nx0, o + nx)
                H[us_, us_] = 2 * p.R
                h_w[us_, nx:] = -2 * p.R @ Mu
                kind[us_] = BOX
                lo[us_] = p.umin
                hi[us_] = p.umax
            if hard is not None:
                idx = [o + i for i in hard.indices]
                kind[idx] = BOX
                lo[idx] = hard.xmin
                hi[idx] = hard.xmax
        for j, i in enumerate(S):
            xi, di = o + i, o + nx + j
            kind[xi], kind[di] = SOFT_X, SOFT_D
            H[di, di] = 2 * soft.sigma2
            h0[di] = soft.sigma1
            soft_x.append(xi)
            soft_d.append(di)

    # F z = b(w): x~_0 = w[:nx]; x~_{k+1} - A~ x~_k - B~ v_k = 0
    neq = (N + 1) * nx
    F = np.zeros((neq, n))
    b_w = np.zeros((neq, nw))
    F[:nx, off(0):off(0) + nx] = np.eye(nx)
    b_w[:nx, :nx] = np.eye(nx)
    for k in range(N):
        rows = slice((k + 1) * nx, (k + 2) * nx)
        F[rows, off(k + 1):off(k + 1) + nx] = np.eye(nx)
        F[rows, off(k):off(k) + nx] = -At
        F[rows, du(k)] = -Bt

    npairs = (N + 1) * ns
    soft_c = np.tile(soft.center, N + 1) if ns else np.zeros(0)
    soft_r = np.tile(soft.radius, N + 1) if ns else np.zeros(0)
    wlo = np.concatenate([p.xmin, p.umin, p.rmin] if rate else [p.xmin, p.rmin])
    whi = np.concatenate([p.xmax, p.umax, p.rmax] if rate else [p.xmax, p.rmax])
    H = 0.5 * (H + H.T)
    out = AdmmQP(problem=p, N=N, nu=nu, nx=nx, ns=ns, n=n, nw=nw, H=H, h_w=h_w, h0=h0, F=F, b_w=b_w, kind=kind,
                 lo=lo, hi=hi, soft_x=np.array(soft_x, dtype=int), soft_d=np.array(soft_d, dtype=int),
                 soft_c=soft_c, soft_r=soft_r, wlo=wlo, whi=whi,
                 sigma1=0.0 if soft is None else soft.sigma1, sigma2=0.0 if soft is None else soft.sigma2, rate=rate)
    assert len(out.soft_x) == npairs
    # F has full row rank by construction: an identity block on x~_k in every block row (block triangular)
    for a in (H, h_w, h0, F, b_w, kind, lo, hi, out.soft_x, out.soft_d, soft_c, soft_r, wlo, whi):
        a.setflags(write=False)
    return out


# --------------------------------------------------------------------------
# projection onto K (float64)


def project_soft(x, d, c, r):
    """Euclidean projection of (x, d) onto {|x - c| <= r + d, d >= 0} (Fig. 3b of 002), elementwise.

    With t = x - c, s = sign(t), e = |t| - r: inside if d >= max(0, e); below the flat edge (e <= 0) -> (x, 0);
    beyond the corner (e > 0, e + d <= 0) -> (c + s r, 0); else onto the slanted edge d' = |t'| - r, the
    foot of the perpendicular: m = (e + d)/2, (c + s (r + m), m).
    """
    x, d, c, r = (np.asarray(a, dtype=float) for a in (x, d, c, r))
    t = x - c
    s = np.where(t < 0, -1.0, 1.0)
    e = np.abs(t) - r
    m = 0.5 * (e + d)
    inside = d >= np.maximum(0.0, e)
    flat = ~inside & (e <= 0)
    corner = ~inside & ~flat & (m <= 0)
    edge = ~inside & ~flat & ~corner
    xo = np.where(inside | flat, x, np.where(corner, c + s * r, c + s * (r + m)))
    do = np.where(inside, d, np.where(edge, m, 0.0))
    return xo, do


def project_K(qp: AdmmQP, q: np.ndarray) -> np.ndarray:
    """pi_K of Algorithm 2 line 3: boxes clipped, free components passed, soft pairs by project_soft."""
    z = np.where(qp.kind == BOX, np.clip(q, qp.lo, qp.hi), q)
    if qp.ns:
        z[qp.soft_x], z[qp.soft_d] = project_soft(q[qp.soft_x], q[qp.soft_d], qp.soft_c, qp.soft_r)
    return z


# --------------------------------------------------------------------------
# OSQP references


def _osqp_data(qp: AdmmQP, w, hard: bool):
    """Equality rows F z = b, box rows, and per soft pair x - delta <= c + r, x + delta >= c - r, delta >= 0
    (delta = 0 for the hard-constrained problem (4))."""
    w = np.asarray(w, dtype=float)
    box = np.flatnonzero(qp.kind == BOX)
    I = sp.identity(qp.n, format="csr")
    rows = [sp.csr_matrix(qp.F), I[box]]
    l = [qp.b(w), qp.lo[box]]
    u = [qp.b(w), qp.hi[box]]
    if qp.ns:
        m = len(qp.soft_x)
        ar = np.arange(m)
        Sx = sp.csr_matrix((np.ones(m), (ar, qp.soft_x)), shape=(m, qp.n))
        Sd = sp.csr_matrix((np.ones(m), (ar, qp.soft_d)), shape=(m, qp.n))
        rows += [Sx - Sd, Sx + Sd, Sd]
        l += [np.full(m, -np.inf), qp.soft_c - qp.soft_r, np.zeros(m)]
        u += [qp.soft_c + qp.soft_r, np.full(m, np.inf), np.zeros(m) if hard else np.full(m, np.inf)]
    return sp.vstack(rows, format="csc"), np.concatenate(l), np.concatenate(u)


def _osqp(qp: AdmmQP, w, hard: bool, eps: float):
    A, l, u = _osqp_data(qp, w, hard)
    s = osqp.OSQP()
    s.setup(P=sp.triu(sp.csc_matrix(qp.H), format="csc"), q=qp.h(w), A=A, l=l, u=u, eps_abs=eps, eps_rel=eps,
            eps_prim_inf=1e-9, eps_dual_inf=1e-9, polishing=True, verbose=False, max_iter=400_000)
    with c_output_silenced():
        return s.solve(raise_error=False)


def solve_soft_qp_osqp(qp: AdmmQP, w, eps: float = 1e-10) -> np.ndarray:
    """Optimal z of the soft-constrained QP (8) at w (qp.w: (x, u_prev, r) or (x, r))."""
    res = _osqp(qp, w, hard=False, eps=eps)
    if res.info.status_val != osqp.SolverStatus.OSQP_SOLVED:
        raise RuntimeError(f"OSQP did not solve the soft-constrained QP: status {res.info.status!r}")
    return np.asarray(res.x, dtype=float)


def solve_hard_qp_osqp(qp: AdmmQP, w, eps: float = 1e-10):
    """The hard-constrained problem (4) (all slacks fixed to 0): (z, mu) with mu >= 0 the multipliers of
    |x_i - c_i| <= r_i per soft pair, or None when it is infeasible at w."""
    res = _osqp(qp, w, hard=True, eps=eps)
    if res.info.status_val in (osqp.SolverStatus.OSQP_PRIMAL_INFEASIBLE,
                               osqp.SolverStatus.OSQP_PRIMAL_INFEASIBLE_INACCURATE):
        return None
    if res.info.status_val != osqp.SolverStatus.OSQP_SOLVED:
        raise RuntimeError(f"OSQP did not solve the hard-constrained QP: status {res.info.status!r}")
    m = len(qp.soft_x)
    y = np.asarray(res.y, dtype=float)
    o = qp.F.shape[0] + int(np.sum(qp.kind == BOX))
    mu = np.abs(y[o:o + m]) + np.abs(y[o + m:o + 2 * m])
    return np.asarray(res.x, dtype=float), mu


def exact_penalty_check(qp: AdmmQP, w, tol: float = 1e-6):
    """Theorem 1 of 002 at w: if the hard problem is feasible and sigma1 > ||mu*||_inf, the soft QP's minimiser
    has delta = 0 and equals the hard minimiser. Returns None (hard problem infeasible) or a dict of the
    multiplier bound, the largest slack and the distance between the two minimisers."""
    hard = solve_hard_qp_osqp(qp, w)
    if hard is None:
        return None
    zh, mu = hard
    zs = solve_soft_qp_osqp(qp, w)
    return {"mu_max": float(mu.max(initial=0.0)), "sigma1": qp.sigma1,
            "exact": bool(qp.sigma1 > mu.max(initial=0.0)),
            "delta_max": float(zs[qp.soft_d].max(initial=0.0)),
            "z_dist": float(np.abs(zs - zh).max()),
            "ok": bool(zs[qp.soft_d].max(initial=0.0) <= tol and np.abs(zs - zh).max() <= tol * 100)}
