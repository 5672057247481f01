"""The MPC problem of a spec with every constraint section, in float64: the reference every kind's core is checked
against (mpc_cores.check, the gallery).

Sparse form over v = (u_0..u_{N-1}, x_1..x_N, s_1..s_N), s_k the slacks of the `soft_states` at stage k:

    minimise  sum_{k<N} (x_k - xs)'Q(x_k - xs) + (u_k - us)'R(u_k - us) + du_k' W du_k
              + (x_N - xs)'QN(x_N - xs) + sum_{k=0..N} sigma1 1's_k + sigma2 ||s_k||^2
    subject to x_{k+1} = A x_k + B u_k (x_0 = x), umin <= u_k <= umax, dumin <= u_k - u_{k-1} <= dumax (u_{-1} =
               u_prev), xmin_i <= x_k,i <= xmax_i (hard states, k = 1..N), |x_k,i - c_i| <= r_i + s_k,i, s >= 0,

the cost of mpc_cores.closedloop.loop_stage_cost summed over the horizon (s_0 is the stage-0 violation, a constant).
`solve` returns the optimal value with its constants, so that two plans are compared on the cost itself; `u0=`
fixes the first input (the rest optimal): the cost of applying a core's answer. Feasibility is decided by an LP
(scipy's HiGHS), never by a solver that ran out of iterations.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import osqp
import scipy.sparse as sp
from scipy.optimize import linprog

from mpc_cores.problem import MpcProblem, steady_state_maps
from mpc_cores.quiet import c_output_silenced


FEAS_TOL = 1e-9      # the LP's slack below which the constraint set is empty (relative to the bounds' size)


def slack_lp(A, lo, hi, tol: float = FEAS_TOL) -> tuple[bool, float]:
    """Whether some v meets lo <= A v <= hi, decided by an LP (HiGHS): the largest slack t <= 1 with A v <= hi - t
    and A v >= lo + t on the finite bounds (rows with lo = hi hold t <= 0). Returns (t* >= -tol max(1, |bounds|),
    t*)."""
    A = sp.csr_matrix(A)
    up, dn = np.isfinite(hi), np.isfinite(lo)
    b = np.concatenate([hi[up], -lo[dn]])
    if b.size == 0:
        return True, 1.0
    M = sp.hstack([sp.vstack([A[up], -A[dn]]), np.ones((b.size, 1))], format="csr")
    c = np.zeros(A.shape[1] + 1)
    c[-1] = -1.0
    res = linprog(c, A_ub=M, b_ub=b, bounds=[(None, None)] * A.shape[1] + [(None, 1.0)], method="highs")
    # a slack t = min(b - A v) exists for any v and t <= 1 bounds the objective: any status but 0 (optimal) is
    # HiGHS failing, not an answer about the constraints
    if res.status != 0:
        raise RuntimeError(f"the feasibility LP failed: HiGHS status {res.status} ({res.message})")
    t = -float(res.fun)
    return t >= -tol * max(1.0, float(np.abs(b).max())), t


class Infeasible(ValueError):
    """No plan meets the hard constraints from this state (decided by an LP)."""


@dataclass
class Plan:
    u: np.ndarray        # (N, nu)
    x: np.ndarray        # (N + 1, nx), x_0 included
    cost: float          # the horizon cost with its constants


def _soft_penalty(p: MpcProblem, x) -> float:
    S = p.soft_states
    if S is None:
        return 0.0
    v = np.maximum(0.0, np.abs(np.asarray(x, dtype=float)[list(S.indices)] - S.center) - S.radius)
    return float(S.sigma1 * v.sum() + S.sigma2 * v @ v)


#: OSQP settings tried in turn when the defaults leave a feasible QP unsolved
RETRIES = ({"eps_abs": 1e-7, "eps_rel": 1e-7, "rho": 1e-3, "adaptive_rho_interval": 25},
           {"eps_abs": 1e-6, "eps_rel": 1e-6, "rho": 10.0, "scaling": 0})


class MpcQP:
    """The sparse QP of a problem, set up once; `solve(x, r, u_prev, u0)` per state."""

    def __init__(self, p: MpcProblem, eps: float = 1e-9):
        self.p = p
        N, nx, nu = p.N, p.nx, p.nu
        S = p.soft_states
        self.ns = ns = 0 if S is None else len(S.indices)
        self.nv = N * nu + N * nx + N * ns
        self.iu, self.ix, self.isl = 0, N * nu, N * nu + N * nx
        W = p.input_rate.weight if p.input_rate is not None else np.zeros((nu, nu))
        # quadratic part: R on each u_k, W on the differences, Q on x_1..x_{N-1}, QN on x_N, sigma2 on the slacks
        D = sp.diags([np.ones(N), -np.ones(N - 1)], [0, -1], shape=(N, N))
        Pu = sp.kron(sp.eye(N), p.R) + sp.kron(D.T @ D, W)
        Px = sp.block_diag([sp.kron(sp.eye(N - 1), p.Q), sp.csc_matrix(p.QN)]) if N > 1 else sp.csc_matrix(p.QN)
        Ps = sp.eye(N * ns) * (S.sigma2 if S else 0.0)
        self.P = 2.0 * sp.block_diag([Pu, Px, Ps], format="csc")
        self.W = W
        self.Mx, self.Mu = steady_state_maps(p)
        rows, self.lo0, self.hi0 = [], [], []
        # dynamics
        Bk = sp.kron(sp.eye(N), p.B)
        Ak = sp.kron(sp.eye(N, k=-1), p.A)
        rows.append(sp.hstack([-Bk, sp.eye(N * nx) - Ak, sp.csc_matrix((N * nx, N * ns))]))
        self.n_dyn = N * nx
        self.lo0.append(np.zeros(N * nx))
        self.hi0.append(np.zeros(N * nx))
        # input box (rows n_dyn .. n_dyn + N nu)
        self.r_u = sum(r.shape[0] for r in rows)
        rows.append(sp.hstack([sp.eye(N * nu), sp.csc_matrix((N * nu, N * nx + N * ns))]))
        self.lo0.append(np.tile(p.umin, N))
        self.hi0.append(np.tile(p.umax, N))
        self.r_du = None
        if p.input_rate is not None:
            self.r_du = sum(r.shape[0] for r in rows)
            rows.append(sp.hstack([sp.kron(D, sp.eye(nu)), sp.csc_matrix((N * nu, N * nx + N * ns))]))
            self.lo0.append(np.tile(p.input_rate.dumin, N))
            self.hi0.append(np.tile(p.input_rate.dumax, N))
        if p.hard_states is not None:
            H = p.hard_states
            sel = sp.csc_matrix(np.eye(nx)[list(H.indices)])
            rows.append(sp.hstack([sp.csc_matrix((N * len(H.indices), N * nu)), sp.kron(sp.eye(N), sel),
                                   sp.csc_matrix((N * len(H.indices), N * ns))]))
            self.lo0.append(np.tile(H.xmin, N))
            self.hi0.append(np.tile(H.xmax, N))
        if S is not None:
            sel = sp.csc_matrix(np.eye(nx)[list(S.indices)])
            X = sp.kron(sp.eye(N), sel)
            Z = sp.csc_matrix((N * ns, N * nu))
            I = sp.eye(N * ns)
            rows += [sp.hstack([Z, X, -I]), sp.hstack([Z, X, I]), sp.hstack([Z, sp.csc_matrix((N * ns, N * nx)), I])]
            self.lo0 += [np.full(N * ns, -np.inf), np.tile(S.xmin, N), np.zeros(N * ns)]
            self.hi0 += [np.tile(S.xmax, N), np.full(N * ns, np.inf), np.full(N * ns, np.inf)]
        self.A = sp.vstack(rows, format="csc")
        self.lo0 = np.concatenate(self.lo0)
        self.hi0 = np.concatenate(self.hi0)
        self.eps = eps
        self.solver = osqp.OSQP()
        self.solver.setup(P=sp.triu(self.P, format="csc"), q=np.zeros(self.nv), A=self.A, l=self.lo0, u=self.hi0,
                          eps_abs=eps, eps_rel=eps, max_iter=400_000, polishing=True, verbose=False)

    def _data(self, x, r, u_prev, u0):
        p, N, nx, nu = self.p, self.p.N, self.p.nx, self.p.nu
        x = np.asarray(x, dtype=float)
        r = np.zeros(p.ny) if r is None else np.asarray(r, dtype=float)
        u_prev = np.zeros(nu) if u_prev is None else np.asarray(u_prev, dtype=float)
        xs, us = self.Mx @ r, self.Mu @ r
        q = np.zeros(self.nv)
        q[self.iu:self.ix] = -2.0 * np.tile(p.R @ us, N)
        q[self.iu:self.iu + nu] += -2.0 * self.W @ u_prev
        q[self.ix:self.isl] = -2.0 * np.concatenate([np.tile(p.Q @ xs, N - 1), p.QN @ xs])
        if self.ns:
            q[self.isl:] = p.soft_states.sigma1
        const = (float((x - xs) @ p.Q @ (x - xs)) + (N - 1) * float(xs @ p.Q @ xs) + float(xs @ p.QN @ xs)
                 + N * float(us @ p.R @ us) + float(u_prev @ self.W @ u_prev) + _soft_penalty(p, x))
        lo, hi = self.lo0.copy(), self.hi0.copy()
        lo[:nx] = hi[:nx] = p.A @ x
        if self.r_du is not None:
            lo[self.r_du:self.r_du + nu] += u_prev
            hi[self.r_du:self.r_du + nu] += u_prev
        if u0 is not None:
            u0 = np.asarray(u0, dtype=float)
            lo[self.r_u:self.r_u + nu] = hi[self.r_u:self.r_u + nu] = u0
            if self.r_du is not None:   # a given u_0 is evaluated as it is, its rate included
                lo[self.r_du:self.r_du + nu] = hi[self.r_du:self.r_du + nu] = u0
        return q, lo, hi, const

    def feasible(self, x, r=None, u_prev=None, u0=None) -> bool:
        """An LP over the constraints alone (slack_lp): is there a plan from x (with u_0 = u0 when given)?"""
        _, lo, hi, _ = self._data(x, r, u_prev, u0)
        return slack_lp(self.A, lo, hi)[0]

    def solve(self, x, r=None, u_prev=None, u0=None) -> Plan:
        """The optimal plan from x (u_0 fixed to u0 when given); Infeasible when no plan meets the hard constraints."""
        q, lo, hi, const = self._data(x, r, u_prev, u0)
        self.solver.update(q=q, l=lo, u=hi)
        with c_output_silenced():
            res = self.solver.solve(raise_error=False)
        for opts in RETRIES:
            if res.info.status_val == osqp.SolverStatus.OSQP_SOLVED:
                break
            # a QP on the edge of feasibility (a u_0 given that barely keeps a state limit) can stall OSQP's
            # defaults: a fresh solver with another step and scaling
            s = osqp.OSQP()
            s.setup(P=sp.triu(self.P, format="csc"), q=q, A=self.A, l=lo, u=hi, max_iter=1_000_000, polishing=True,
                    verbose=False, **opts)
            with c_output_silenced():
                res = s.solve(raise_error=False)
        if res.info.status_val != osqp.SolverStatus.OSQP_SOLVED:
            if not self.feasible(x, r, u_prev, u0):
                raise Infeasible(f"no plan meets the hard constraints from x = {np.round(x, 6).tolist()}")
            raise RuntimeError(f"OSQP did not solve a feasible MPC QP (status {res.info.status!r}) at "
                               f"x = {np.round(x, 6).tolist()}")
        p, N, nx, nu = self.p, self.p.N, self.p.nx, self.p.nu
        v = res.x
        u = v[self.iu:self.ix].reshape(N, nu)
        xs = np.vstack([np.asarray(x, dtype=float), v[self.ix:self.isl].reshape(N, nx)])
        return Plan(u=u, x=xs, cost=float(0.5 * v @ (self.P @ v) + q @ v + const))


__all__ = ["Infeasible", "MpcQP", "Plan", "slack_lp"]
