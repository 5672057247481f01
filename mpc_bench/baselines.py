"""Software baselines of the QP solver cores on this CPU: OSQP (C library, Python API; default and tuned embedded
settings), the fast gradient method (Algorithm 1 of 002) and ADMM (Algorithm 2 of 002) in float64 numpy, all
warm-started over one closed loop, with the loop, the reference solutions and the timing (median per-solve wall
time over replays, half before and half after the hardware jobs). The MINRES baselines are
mpc_bench.baselines_minres."""
from __future__ import annotations

import gc
import math
import os
import time
from dataclasses import dataclass

import numpy as np
from tqdm import tqdm

# OSQP settings. "default": the library's (1.x: eps 1e-3, no polishing, warm start on, termination checked
# every 25 iterations, adaptive rho). "tuned": embedded settings for this warm-started loop; with a warm start
# the solver converges in a few iterations, so checking termination every 5 saves most of the default's 25;
# a fixed rho avoids refactorisations, and 0.3 was the fastest of 0.03, 0.1, 0.3 and 1 on this loop.
OSQP_DEFAULT: dict = {}
OSQP_TUNED = dict(eps_abs=1e-3, eps_rel=1e-3, polishing=False, warm_starting=True, check_termination=5,
                  adaptive_rho=False, rho=0.3)
# The same for the soft-constrained QP of masses_rate_soft: rho = 1 had the lowest median time of 0.1, 0.3, 1
# and 3 (0.3 as fast at the median, but 510 iterations at worst against 140).
OSQP_TUNED_ADMM = dict(OSQP_TUNED, rho=1.0)


class NumpyFgm:
    """Algorithm 1 of 002 in float64 numpy on the unquantised normalised data, warm-started like the core
    (previous solution shifted by one stage, the last stage repeated)."""
    name = "numpy FGM float64"

    def __init__(self, qp, nu: int, c: float, lam_max: float, imax: int):
        s = c * lam_max
        Hn = qp.H / s
        self.G = np.ascontiguousarray(np.eye(qp.n) - Hn)
        self.Phi = np.ascontiguousarray(qp.Phi / s)
        mu = float(np.linalg.eigvalsh(Hn)[0])
        self.beta = (1 - math.sqrt(mu)) / (1 + math.sqrt(mu))
        self.lb, self.ub = np.array(qp.lb, dtype=float), np.array(qp.ub, dtype=float)
        self.n, self.nu, self.imax = qp.n, nu, imax
        self.z_prev = None
        self.settings = f"Imax = {imax}, beta = {self.beta:.4f}, warm start as the core"

    def solve(self, w: np.ndarray) -> np.ndarray:
        G, lb, ub, beta = self.G, self.lb, self.ub, self.beta
        h = self.Phi @ w
        if self.z_prev is None:
            z = np.clip(np.zeros(self.n), lb, ub)
        else:
            z = np.concatenate([self.z_prev[self.nu:], self.z_prev[self.n - self.nu:]])
        y = z.copy()
        t = np.empty(self.n)
        for _ in range(self.imax):
            np.dot(G, y, out=t)
            t -= h
            np.clip(t, lb, ub, out=t)
            y = (1 + beta) * t - beta * z
            z = t.copy()
        self.z_prev = z
        return z


def soft_projection(q_x: np.ndarray, q_d: np.ndarray, c: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Projection of (x, delta) onto {|x - c| <= r + delta, delta >= 0} (Fig. 3b of 002) in closed form without
    case selection: with t = x - c and m+ = max(0, (|t| - r + delta) / 2), x' = c + clip(t, -(r + m+), r + m+),
    delta' = max(delta, m+). Equal to mpc_cores.admm.problem.project_soft (inside, below the flat edge, beyond the
    corner, onto the slanted edge), in fewer numpy calls."""
    t = q_x - c
    m = np.maximum(0.5 * (np.abs(t) - r + q_d), 0.0)
    R = r + m
    return c + np.clip(t, -R, R), np.maximum(q_d, m)


class NumpyAdmm:
    """Algorithm 2 of 002 in float64 numpy on the unquantised data (M11, G~ of the offline KKT inverse, rho_j =
    2^k_j), warm-started like the core (z and nu shifted by one stage): the iteration of
    mpc_cores.admm.model.AdmmFloat(d) without its per-call set-up."""
    name = "numpy ADMM float64"

    def __init__(self, d, imax: int | None = None):
        from mpc_cores.admm.problem import BOX

        q = d.qp
        self.M = np.ascontiguousarray(d.M11f)
        self.Gw = np.ascontiguousarray(d.Gf[:, :-1])
        self.g0 = np.array(d.Gf[:, -1])
        self.rho = np.array(d.rho_vec, dtype=float)
        self.irho = 1.0 / self.rho
        self.lo = np.where(q.kind == BOX, q.lo, -np.inf)
        self.hi = np.where(q.kind == BOX, q.hi, np.inf)
        self.sx, self.sd = np.array(q.soft_x), np.array(q.soft_d)
        self.c, self.r = np.array(q.soft_c, dtype=float), np.array(q.soft_r, dtype=float)
        self.n, self.N, self.nu = q.n, q.N, q.nu
        self.imax = d.iterations if imax is None else imax
        self.prev: tuple | None = None
        self.settings = (f"Imax = {self.imax}, rho_j = 2^k_j, k_j in {sorted(set(int(k) for k in d.shift))}, "
                         "warm start as the core")

    def proj(self, q: np.ndarray) -> np.ndarray:
        z = np.clip(q, self.lo, self.hi)
        if self.sx.size:
            z[self.sx], z[self.sd] = soft_projection(q[self.sx], q[self.sd], self.c, self.r)
        return z

    def solve(self, w: np.ndarray) -> np.ndarray:
        from mpc_cores.admm.model import shift_stages

        gw = self.Gw @ w + self.g0
        if self.prev is None:
            z, nu = self.proj(np.zeros(self.n)), np.zeros(self.n)
        else:
            z, nu = (shift_stages(a, self.N, self.nu) for a in self.prev)
        M, rho, irho = self.M, self.rho, self.irho
        for _ in range(self.imax):
            y = M @ (rho * z - nu)
            y += gw
            z = self.proj(y + nu * irho)
            y -= z
            y *= rho
            nu = nu + y
        self.prev = (z, nu)
        return z


class OsqpWarm:
    """OSQP set up once for the loop; each solve updates q = Phi w and starts from the previous solution."""

    def __init__(self, qp, name: str, settings: dict):
        import osqp
        import scipy.sparse as sp

        self.name = name
        self.Phi = qp.Phi
        self.solver = osqp.OSQP()
        self.solver.setup(P=sp.triu(sp.csc_matrix(qp.H), format="csc"), q=np.zeros(qp.n),
                          A=sp.identity(qp.n, format="csc"), l=np.array(qp.lb, dtype=float),
                          u=np.array(qp.ub, dtype=float), verbose=False, **settings)
        self.settings = _osqp_settings(self.solver)
        self.iters: list[int] = []

    def solve(self, w: np.ndarray) -> np.ndarray:
        self.solver.update(q=self.Phi @ w)
        res = self.solver.solve(raise_error=False)
        self.iters.append(res.info.iter)
        return res.x


def _osqp_settings(solver) -> str:
    st = solver.settings
    return ", ".join(f"{k} = {getattr(st, k)}" for k in (
        "eps_abs", "eps_rel", "polishing", "warm_starting", "check_termination", "adaptive_rho", "rho"))


class OsqpSoftWarm:
    """OSQP on the soft-constrained sparse QP (8) of 002 (the data of mpc_cores.admm.problem: F z = b(w), the boxes,
    three rows per soft pair), set up once; each solve updates q = h(w) and the equality bounds b(w), and starts
    from the previous solution."""

    def __init__(self, qp, name: str, settings: dict):
        import osqp
        import scipy.sparse as sp

        from mpc_cores.admm.problem import _osqp_data

        self.name, self.qp = name, qp
        A, self.l, self.u = _osqp_data(qp, np.zeros(qp.nw), hard=False)
        self.neq = qp.F.shape[0]
        # only the equality rows (first) depend on w
        _, l1, u1 = _osqp_data(qp, np.ones(qp.nw), hard=False)
        assert np.array_equal(l1[self.neq:], self.l[self.neq:]) and np.array_equal(u1[self.neq:], self.u[self.neq:])
        self.hw, self.h0, self.bw = np.asarray(qp.h_w), np.asarray(qp.h0), np.asarray(qp.b_w)
        self.solver = osqp.OSQP()
        self.solver.setup(P=sp.triu(sp.csc_matrix(qp.H), format="csc"), q=np.array(self.h0), A=A, l=self.l,
                          u=self.u, verbose=False, **settings)
        self.settings = _osqp_settings(self.solver)
        self.iters: list[int] = []

    def solve(self, w: np.ndarray) -> np.ndarray:
        b = self.bw @ w
        self.l[: self.neq] = b
        self.u[: self.neq] = b
        self.solver.update(q=self.hw @ w + self.h0, l=self.l, u=self.u)
        res = self.solver.solve(raise_error=False)
        self.iters.append(res.info.iter)
        return res.x


@dataclass
class SwResult:
    name: str
    settings: str
    times_us: np.ndarray         # (repeats, steps)
    u_err: float                 # max over the loop of |u0 - u0*|_inf
    iters: list | None = None
    u_err_median: float | None = None    # median over the loop of |u0 - u0*|_inf

    @property
    def median_us(self) -> float:
        """The smallest per-replay median: other processes on the machine only ever add time."""
        return float(np.median(self.times_us, axis=1).min())


@dataclass
class SwCase:
    """One closed loop, replayed into every solver: the parameters, the reference first inputs, the solvers."""
    kind: str
    W: np.ndarray                # parameters of each step
    u_opt: np.ndarray            # optimal first input (u0 or du0) of each step
    nu: int
    makers: list                 # () -> solver with .name, .settings, .solve(w) -> z
    meta: dict                   # what the report says about the loop


def closed_loop_qps(problem, qp, d, steps: int, hold: int, seed: int = 0) -> np.ndarray:
    """The w = (x, r) of every step of one closed loop of masses from x0 = 0 under the FGM float controller."""
    from mpc_cores.closedloop import reference_schedule

    refs = reference_schedule(problem, steps, hold, seed)
    ctrl = NumpyFgm(qp, problem.nu, d.c, d.lam_max, d.iterations)
    x = np.zeros(problem.nx)
    W = np.zeros((steps, qp.nw))
    for k in range(steps):
        W[k] = np.concatenate([x, refs[k]])
        u = ctrl.solve(W[k])[: problem.nu]
        x = problem.A @ x + problem.B @ u
    return W


def admm_closed_loop_qps(problem, d, steps: int, hold: int, seed: int = 0) -> np.ndarray:
    """The w = (x, u_prev, r) of every step of one closed loop of masses_rate_soft from x0 = 0, u_prev = 0 under
    the float ADMM controller (u = clip(u_prev + du0, umin, umax)); references anywhere in 80 % of their box, so
    the soft position limits, the input box and the rate limit all bind (Fig. 5 of 002)."""
    from mpc_cores.closedloop import reference_schedule

    refs = reference_schedule(problem, steps, hold, seed, holdable=0.0)
    ctrl = NumpyAdmm(d)
    x, u_prev = np.zeros(problem.nx), np.zeros(problem.nu)
    W = np.zeros((steps, problem.nx + problem.nu + problem.ny))
    for k in range(steps):
        W[k] = np.concatenate([x, u_prev, refs[k]])
        u_prev = np.clip(u_prev + ctrl.solve(W[k])[: problem.nu], problem.umin, problem.umax)
        x = problem.A @ x + problem.B @ u_prev
    return W


def _optimal_u0(problem, qp, W: np.ndarray) -> np.ndarray:
    s = OsqpWarm(qp, "reference", dict(eps_abs=1e-9, eps_rel=1e-9, polishing=False, max_iter=200_000))
    return np.array([s.solve(w)[: problem.nu] for w in W])


def _time_solver(make, W: np.ndarray, nu: int, u_opt: np.ndarray, repeats: int, bar=None) -> SwResult:
    times, err, solver = np.zeros((repeats, len(W))), np.zeros(len(W)), None
    for r in range(repeats):
        solver = make()
        gc.collect()
        gc.disable()
        try:
            for k, w in enumerate(W):
                t0 = time.perf_counter()
                z = solver.solve(w)
                times[r, k] = time.perf_counter() - t0
                err[k] = max(err[k], float(np.abs(z[:nu] - u_opt[k]).max()))
        finally:
            gc.enable()
        if bar is not None:
            bar.update()
    return SwResult(solver.name, solver.settings, times * 1e6, float(err.max()), getattr(solver, "iters", None),
                    float(np.median(err)))


def merge_software(a: dict | None, b: dict | None) -> dict | None:
    """Two timing sessions of the same loop (before and after the synthesis jobs) as one: every replay kept."""
    if a is None or b is None:
        return a or b
    out = dict(a, repeats=a["repeats"] + b["repeats"], load=[a["load"], b["load"]])
    out["solvers"] = [SwResult(x.name, x.settings, np.vstack([x.times_us, y.times_us]), max(x.u_err, y.u_err),
                               (x.iters or []) + (y.iters or []) or None,
                               max(x.u_err_median or 0.0, y.u_err_median or 0.0) if x.u_err_median is not None
                               else None) for x, y in zip(a["solvers"], b["solvers"])]
    return out


def prepare_fgm_software(problem, designs: dict, steps: int, hold: int) -> SwCase:
    """The masses loop for the FGM solvers, and the error of the core's golden model (per b) on it."""
    from mpc_cores.fgm.model import FgmFixed
    from mpc_cores.fixed import quantize
    from mpc_cores.problem import condense

    qp = condense(problem)
    d = designs[max(designs)]
    W = closed_loop_qps(problem, qp, d, steps, hold)
    u_opt = _optimal_u0(problem, qp, W)
    nu = problem.nu
    core_err = {}
    for b, db in sorted(designs.items()):
        m = FgmFixed(db)
        err = [float(np.abs(m.solve(quantize(w, db.b)).z[:nu] / (1 << db.b) - u_opt[k]).max())
               for k, w in enumerate(W)]
        core_err[b] = (max(err), float(np.median(err)))
    makers = [lambda: OsqpWarm(qp, "OSQP default", OSQP_DEFAULT), lambda: OsqpWarm(qp, "OSQP tuned", OSQP_TUNED),
              lambda: NumpyFgm(qp, nu, d.c, d.lam_max, d.iterations)]
    return SwCase("fgm", W, u_opt, nu, makers, {
        "core_err": core_err, "steps": steps, "hold": hold, "imax": d.iterations,
        "u_box": (float(np.min(problem.umin)), float(np.max(problem.umax)))})


def prepare_admm_software(problem, designs: dict, steps: int, hold: int) -> SwCase:
    """The masses_rate_soft loop for the ADMM solvers (OSQP on the soft QP, numpy ADMM), the error of the core's
    golden model (per b) on it, and the check that numpy ADMM is AdmmFloat's iteration."""
    from mpc_cores.admm.model import AdmmFixed, AdmmFloat
    from mpc_cores.fixed import quantize

    d = designs[max(designs)]
    qp = d.qp
    W = admm_closed_loop_qps(problem, d, steps, hold)
    ref = OsqpSoftWarm(qp, "reference", dict(eps_abs=1e-9, eps_rel=1e-9, polishing=False, max_iter=200_000))
    nu = problem.nu
    u_opt = np.array([ref.solve(w)[:nu] for w in W])
    core_err = {}
    for b, db in sorted(designs.items()):
        m = AdmmFixed(db)
        err = [float(np.abs(m.solve(quantize(w, db.b)).z[:nu] / (1 << db.b) - u_opt[k]).max())
               for k, w in enumerate(W)]
        core_err[b] = (max(err), float(np.median(err)), int(np.argmax(err)))
    a, f = NumpyAdmm(d), AdmmFloat(d)
    same = max(float(np.abs(a.solve(w) - f.solve(w)[0]).max()) for w in W[: min(len(W), 20)])
    makers = [lambda: OsqpSoftWarm(qp, "OSQP default", OSQP_DEFAULT),
              lambda: OsqpSoftWarm(qp, "OSQP tuned", OSQP_TUNED_ADMM), lambda: NumpyAdmm(d)]
    lo = float(np.min(problem.input_rate.dumin))
    hi = float(np.max(problem.input_rate.dumax))
    return SwCase("admm", W, u_opt, nu, makers, {
        "core_err": core_err, "steps": steps, "hold": hold, "imax": d.iterations, "u_box": (lo, hi),
        "ref_iters": (float(np.median(ref.iters)), max(ref.iters)), "numpy_vs_admmfloat": same,
        "active": _admm_active(problem, W)})


def _admm_active(problem, W: np.ndarray) -> dict:
    """Share of the loop's steps at which each kind of limit binds on the plant: positions beyond the soft limits,
    inputs at their box, input changes at the rate limit."""
    nx, nu = problem.nx, problem.nu
    X, Up = W[:, :nx], W[:, nx:nx + nu]
    U = np.vstack([Up[1:], Up[-1:]])
    S = problem.soft_states
    soft = np.any(np.abs(X[:, list(S.indices)] - S.center) > S.radius + 1e-6, axis=1) if S is not None else np.zeros(len(W), bool)
    box = np.any((U >= problem.umax - 1e-6) | (U <= problem.umin + 1e-6), axis=1)
    rate = np.any(np.abs(np.abs(U - Up) - problem.input_rate.dumax) < 1e-6, axis=1)
    return {"soft": float(soft.mean()), "box": float(box[:-1].mean()), "rate": float(rate[:-1].mean())}


def time_software(case: SwCase, repeats: int, log) -> dict:
    """Per-solve wall time of each solver of the case over its loop, `repeats` replays each (a progress bar on
    stderr counts the replays)."""
    with tqdm(total=len(case.makers) * repeats, desc=f"{case.kind.upper()} software timing", unit="replay",
              disable=None) as bar:
        res = [_time_solver(mk, case.W, case.nu, case.u_opt, repeats, bar) for mk in case.makers]
    for r in res:
        it = f", iterations median {np.median(r.iters):.0f} max {max(r.iters)}" if r.iters else ""
        log(f"{case.kind.upper()} {r.name}: median {r.median_us:.1f} us per solve ({r.times_us.shape[1]} solves, "
            f"best of {r.times_us.shape[0]} replays){it}")
    return {"solvers": res, "repeats": repeats, "load": os.getloadavg()[0] if hasattr(os, "getloadavg") else None}
