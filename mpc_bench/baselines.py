"""Software baselines of the QP solver cores on this CPU: the fast gradient method (Algorithm 1 of 002) and ADMM
(Algorithm 2 of 002) in float64 numpy, the QP solvers of mpc_bench.qp_solvers (OSQP, DAQP, PIQP, ProxQP, Clarabel,
quadprog) and the generated C solvers (mpc_bench.c_timing), all on the same QPs of one closed loop, with the loop,
the reference solutions and the timing (per-solve wall time and each solver's own time over replays, half before
and half after the hardware jobs, the process pinned to one CPU), and the report cells that set the solvers' times
against a core. The MINRES baselines are mpc_bench.baselines_minres."""
from __future__ import annotations

import contextlib
import gc
import math
import os
import re
import time
from dataclasses import dataclass

import numpy as np
from tqdm import tqdm

from mpc_bench.qp_solvers import (  # noqa: F401  (OSQP_DEFAULT, OSQP_TUNED: mpc_bench.ipm takes them from here)
    OSQP_DEFAULT, OSQP_TUNED, SOLVERS, Osqp, box_qp, soft_qp, solver_makers,
)
from mpc_bench.report import _f, _table


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


class OsqpWarm(Osqp):
    """OSQP on the condensed box QP (mpc_cores.problem.condense) of a loop, set up once; each solve updates
    q = Phi w and starts from the previous solution."""

    def __init__(self, qp, name: str, settings: dict):
        super().__init__(box_qp(qp), name, settings)


@dataclass
class SwResult:
    name: str
    settings: str
    times_us: np.ndarray         # (repeats, steps)
    u_err: float                 # max over the loop of |u0 - u0*|_inf
    iters: list | None = None
    u_err_median: float | None = None    # median over the loop of |u0 - u0*|_inf
    own_us: np.ndarray | None = None     # (repeats, steps): the solver's own timer, None when it has none
    timer: str | None = None             # what that timer covers

    # Per timer (times in us, one row per replay): the median is the smallest of the replays' medians and the mean
    # the smallest of their means (other processes on the machine only ever add time); p99 and max over every solve
    # of every replay.
    @staticmethod
    def _median(t: np.ndarray | None) -> float | None:
        return float(np.median(t, axis=1).min()) if t is not None else None

    @staticmethod
    def _p99(t: np.ndarray | None) -> float | None:
        return float(np.percentile(t, 99)) if t is not None else None

    @staticmethod
    def _mean(t: np.ndarray) -> float:
        return float(np.mean(t, axis=1).min())

    @property
    def median_us(self) -> float:
        return self._median(self.times_us)

    @property
    def p99_us(self) -> float:
        return self._p99(self.times_us)

    @property
    def mean_us(self) -> float:
        """wall time per solve over the loop solved back to back"""
        return self._mean(self.times_us)

    @property
    def own_median_us(self) -> float | None:
        return self._median(self.own_us)

    @property
    def own_p99_us(self) -> float | None:
        return self._p99(self.own_us)

    @property
    def own_max_us(self) -> float | None:
        return float(self.own_us.max()) if self.own_us is not None else None

    # The figures every ratio against a core takes: the solver's own timer where it has one (its solve, without
    # the Python call), else the wall time.
    @property
    def ref_us(self) -> np.ndarray:
        return self.own_us if self.own_us is not None else self.times_us

    @property
    def basis(self) -> str:
        """which timer the ratios take: 'own' or 'wall'"""
        return "own" if self.own_us is not None else "wall"

    @property
    def ref_median_us(self) -> float:
        return self._median(self.ref_us)

    @property
    def ref_p99_us(self) -> float:
        return self._p99(self.ref_us)

    @property
    def ref_mean_us(self) -> float:
        return self._mean(self.ref_us)


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


# The reference of every loop: OSQP at eps 1e-9.
REFERENCE = dict(eps_abs=1e-9, eps_rel=1e-9, polishing=False, max_iter=200_000)


def _optimal_u0(problem, qp, W: np.ndarray) -> np.ndarray:
    s = OsqpWarm(qp, "reference", REFERENCE)
    return np.array([s.solve(w)[0][: problem.nu] for w in W])


def _time_solver(make, W: np.ndarray, nu: int, u_opt: np.ndarray, repeats: int, bar=None) -> SwResult:
    """Replays of the loop into fresh solvers: wall time per solve (time.perf_counter around solve(w)), the solver's
    own time when solve returns (z, own seconds or a function giving them), the error of u0 against u_opt."""
    times, own, err, solver = np.zeros((repeats, len(W))), np.full((repeats, len(W)), np.nan), np.zeros(len(W)), None
    for r in range(repeats):
        solver = make()
        gc.collect()
        gc.disable()
        try:
            for k, w in enumerate(W):
                t0 = time.perf_counter()
                z = solver.solve(w)
                times[r, k] = time.perf_counter() - t0
                if isinstance(z, tuple):
                    z, t_own = z
                    t_own = t_own() if callable(t_own) else t_own      # read after the wall clock stopped
                    own[r, k] = np.nan if t_own is None else t_own
                err[k] = max(err[k], float(np.abs(z[:nu] - u_opt[k]).max()))
        finally:
            gc.enable()
        if bar is not None:
            bar.update()
    return SwResult(solver.name, solver.settings, times * 1e6, float(err.max()), getattr(solver, "iters", None),
                    float(np.median(err)), None if np.isnan(own).any() else own * 1e6, getattr(solver, "timer", None))


def merge_software(a: dict | None, b: dict | None) -> dict | None:
    """Two timing sessions of the same loop (before and after the synthesis jobs) as one: every replay kept."""
    if a is None or b is None:
        return a or b
    out = dict(a, repeats=a["repeats"] + b["repeats"], load=[a["load"], b["load"]])
    if a.get("cpu") != b.get("cpu"):
        out["cpu"] = f"{a.get('cpu')} and {b.get('cpu')}"
    out["solvers"] = [SwResult(x.name, x.settings, np.vstack([x.times_us, y.times_us]), max(x.u_err, y.u_err),
                               (x.iters or []) + (y.iters or []) or None,
                               max(x.u_err_median or 0.0, y.u_err_median or 0.0) if x.u_err_median is not None
                               else None,
                               np.vstack([x.own_us, y.own_us]) if x.own_us is not None and y.own_us is not None
                               else None, x.timer) for x, y in zip(a["solvers"], b["solvers"])]
    return out


def _makers(problem: str, lqp, numpy_maker) -> tuple[list, list[str]]:
    """The solvers of `problem` in mpc_bench.qp_solvers.SOLVERS with the numpy method after the OSQP rows (the
    order of the report's tables and plots before the other solvers came)."""
    makers, missing = solver_makers(problem, lqp)
    k = sum(c is Osqp for _, c, _ in SOLVERS[problem])
    return makers[:k] + [numpy_maker] + makers[k:], missing


def _with_c(kind: str, d, makers: list, missing: list) -> tuple[list, list]:
    """The generated C solvers of the design after the others (mpc_bench.c_timing; not run without gcc)."""
    from mpc_bench.c_timing import c_makers

    cm, cmiss = c_makers(kind, d)
    return makers + cm, missing + cmiss


def _with_tinympc(problem, makers: list, missing: list) -> tuple[list, list]:
    """TinyMPC on the spec's model after the others, where its package is installed (built from its source)"""
    from mpc_bench.qp_solvers import TinyMpc, installed

    if not installed(TinyMpc):
        return makers, missing + ["TinyMPC (tinympc)"]
    return makers + [lambda: TinyMpc(problem, "TinyMPC", {})], missing


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
    makers, missing = _with_c("fgm", d, *_makers("box", box_qp(qp), lambda: NumpyFgm(qp, nu, d.c, d.lam_max,
                                                                                    d.iterations)))
    makers, missing = _with_tinympc(problem, makers, missing)
    return SwCase("fgm", W, u_opt, nu, makers, {
        "core_err": core_err, "steps": steps, "hold": hold, "imax": d.iterations, "missing": missing,
        "u_box": (float(np.min(problem.umin)), float(np.max(problem.umax)))})


def prepare_admm_software(problem, designs: dict, steps: int, hold: int) -> SwCase:
    """The masses_rate_soft loop for the ADMM solvers (the solvers of the soft QP, numpy ADMM), the error of the
    core's golden model (per b) on it, and the check that numpy ADMM is AdmmFloat's iteration."""
    from mpc_cores.admm.model import AdmmFixed, AdmmFloat
    from mpc_cores.fixed import quantize

    d = designs[max(designs)]
    qp = d.qp
    W = admm_closed_loop_qps(problem, d, steps, hold)
    lqp = soft_qp(qp)
    ref = Osqp(lqp, "reference", REFERENCE)
    nu = problem.nu
    u_opt = np.array([ref.solve(w)[0][:nu] for w in W])
    core_err = {}
    for b, db in sorted(designs.items()):
        m = AdmmFixed(db)
        err = [float(np.abs(m.solve(quantize(w, db.b)).z[:nu] / (1 << db.b) - u_opt[k]).max())
               for k, w in enumerate(W)]
        core_err[b] = (max(err), float(np.median(err)), int(np.argmax(err)))
    a, f = NumpyAdmm(d), AdmmFloat(d)
    same = max(float(np.abs(a.solve(w) - f.solve(w)[0]).max()) for w in W[: min(len(W), 20)])
    makers, missing = _with_c("admm", d, *_makers("soft", lqp, lambda: NumpyAdmm(d)))
    lo = float(np.min(problem.input_rate.dumin))
    hi = float(np.max(problem.input_rate.dumax))
    return SwCase("admm", W, u_opt, nu, makers, {
        "core_err": core_err, "steps": steps, "hold": hold, "imax": d.iterations, "u_box": (lo, hi),
        "missing": missing, "ref_iters": (float(np.median(ref.iters)), max(ref.iters)), "numpy_vs_admmfloat": same,
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


@contextlib.contextmanager
def pinned():
    """Every thread of the process on one CPU, the highest-numbered it may run on, while the block runs (yields that
    CPU, None where the system has no affinity calls); the former affinities after."""
    if not hasattr(os, "sched_setaffinity"):
        yield None
        return
    tids = [int(t) for t in os.listdir("/proc/self/task")] if os.path.isdir("/proc/self/task") else [0]
    before = {}
    for t in tids:
        with contextlib.suppress(OSError):
            before[t] = os.sched_getaffinity(t)
    cpu = max(os.sched_getaffinity(0))
    for t in before:
        with contextlib.suppress(OSError):
            os.sched_setaffinity(t, {cpu})
    try:
        yield cpu
    finally:
        for t, cpus in before.items():
            with contextlib.suppress(OSError):
                os.sched_setaffinity(t, cpus)


def time_software(case: SwCase, repeats: int, log) -> dict:
    """Per-solve wall time (and own time) of each solver of the case over its loop, `repeats` replays each, the
    process pinned to one CPU (a progress bar on stderr counts the replays)."""
    from mpc_cores.quiet import c_output_silenced

    # the solvers' C chatter (OSQP's polishing note, TinyMPC's convergence line) off; the log and the bar are stderr's
    with pinned() as cpu, c_output_silenced(), tqdm(total=len(case.makers) * repeats,
                                                    desc=f"{case.kind.upper()} software timing", unit="replay",
                                                    disable=None) as bar:
        res = [_time_solver(mk, case.W, case.nu, case.u_opt, repeats, bar) for mk in case.makers]
    for r in res:
        it = f", iterations median {np.median(r.iters):.0f} max {max(r.iters)}" if r.iters else ""
        own = f", own timer median {r.own_median_us:.1f} us" if r.own_us is not None else ""
        log(f"{case.kind.upper()} {r.name}: median {r.median_us:.1f} us per solve ({r.times_us.shape[1]} solves, "
            f"best of {r.times_us.shape[0]} replays){own}{it}")
    return {"solvers": res, "repeats": repeats, "cpu": cpu,
            "load": os.getloadavg()[0] if hasattr(os, "getloadavg") else None}


# ----------------------------------------------------------------------------------------- report cells
# The solvers' times against a core, for the FGM and ADMM sections (records and tables).

def slug(name: str) -> str:
    """'DAQP hot start' -> 'daqp_hot_start' (the CSV keys of a solver)."""
    return re.sub(r"[^a-z0-9]+", "_", name.lower()).strip("_")


def own_columns(sw: dict | None, loop: dict | None = None) -> dict:
    """Per solver of `sw` with a timer of its own: its median, p99 and max per solve by that timer
    (`<solver>_own_median_us`, ...), and, given the core's latency over the same loop (`loop`: median, p99 and max
    in us), each over the core's (`<solver>_own_median_over_core`, ...: above 1 the core is ahead)."""
    out = {}
    for r in (sw or {}).get("solvers", []):
        k = slug(r.name)
        own = {"median": r.own_median_us, "p99": r.own_p99_us, "max": r.own_max_us}
        for q, v in own.items():
            out[f"{k}_own_{q}_us"] = v
            core = (loop or {}).get(q)
            out[f"{k}_own_{q}_over_core"] = v / core if v is not None and core else None
    return out


def core_ratios(lat_us: float | None, sw: dict | None, rate: float | None = None) -> dict:
    """The record fields of one core against every solver of `sw`: the core latency the ratios use and the core's
    solves per second (`rate`; by default one QP in flight: 1 / latency), and per solver its median and p99 wall
    time per solve, its own timer's figures (own_columns), and the ratios, by its own timer where it has one (else
    by wall time; `<solver>_basis`), of its median and p99 to the core's latency and the throughput ratio, core
    solves/s over the solver's solves/s at its median (solver over core: above 1 the core is ahead)."""
    rate = rate if rate is not None else (1e6 / lat_us if lat_us else None)
    out = {"core_latency_us": lat_us, "core_solves_per_s": rate, **own_columns(sw)}
    for r in (sw or {}).get("solvers", []):
        k = slug(r.name)
        med, p99 = r.ref_median_us, r.ref_p99_us
        out.update({f"{k}_median_us": r.median_us, f"{k}_p99_us": r.p99_us, f"{k}_basis": r.basis,
                    f"{k}_median_over_core": med / lat_us if lat_us else None,
                    f"{k}_p99_over_core": p99 / lat_us if lat_us else None,
                    f"{k}_throughput_ratio": rate / (1e6 / med) if rate and med else None})
    if sw and sw.get("solvers"):
        best = min(sw["solvers"], key=lambda s: s.ref_median_us)
        out.update(fastest_solver=best.name, fastest_median_over_core=out[f"{slug(best.name)}_median_over_core"],
                   fastest_p99_over_core=out[f"{slug(best.name)}_p99_over_core"])
    return out


def fastest_cell(r: dict) -> str:
    """The summary cell of a core: the solver with the lowest median (own timer where it has one), its median and
    p99 over the core's latency."""
    if not r.get("fastest_solver"):
        return "-"
    return (f"{r['fastest_solver']} {_f(r.get('fastest_median_over_core'), '{:.1f}x')}, "
            f"{_f(r.get('fastest_p99_over_core'), '{:.1f}x')}")


def timer_table(sw: dict) -> list[str]:
    """Per solver: median, p99 and max time per solve by its own timer (n/a without one) and by wall time, and the
    error reached over the loop."""
    body = []
    for r in sw["solvers"]:
        own = [_f(v, "{:.1f}", "n/a") for v in (r.own_median_us, r.own_p99_us, r.own_max_us)]
        body.append([r.name, *own, f"{r.median_us:.1f}", f"{r.p99_us:.1f}", f"{r.times_us.max():.1f}",
                     f"{r.u_err:.2e}", r.timer or "n/a"])
    return _table(["solver", "own median us", "own p99 us", "own max us", "wall median us", "wall p99 us",
                   "wall max us", "error max", "own timer covers"], body)


def ratio_table(recs: list[dict], sw: dict, lat_label: str) -> list[str]:
    """Per core and solver: the core's latency and solves/s (core_ratios), the solver's median and p99 by the timer
    the ratios take (own where it has one), and the ratios."""
    body = []
    for r in recs:
        for s in sw["solvers"]:
            k = slug(s.name)
            body.append([str(r["P"]), str(r["b"]), _f(r.get("core_latency_us"), "{:.2f}"),
                         _f(r.get("core_solves_per_s"), "{:.0f}"), s.name, s.basis, f"{s.ref_median_us:.1f}",
                         f"{s.ref_p99_us:.1f}", _f(r.get(f"{k}_median_over_core"), "{:.1f}x"),
                         _f(r.get(f"{k}_p99_over_core"), "{:.1f}x"), _f(r.get(f"{k}_throughput_ratio"), "{:.1f}x")])
    return _table(["P", "b", f"core us ({lat_label})", "core solves/s", "solver", "timer", "median us", "p99 us",
                   "median / core", "p99 / core", "core solves/s / solver's"], body)


def software_notes(sw: dict) -> list[str]:
    """What the timer and ratio tables rest on: the pinning, the timers, the ratios, the solvers not installed."""
    miss = sw.get("missing") or []
    return [f"Every replay ran with the process pinned to CPU {sw.get('cpu', '?')} (os.sched_setaffinity on each of "
            "its threads) and the solvers single-threaded (thread options set to 1 where they have one). Own: the "
            "solver's own timer (what it covers in the last column); wall: time.perf_counter around the call, "
            "including the update of q(w) (and b(w)) and the Python call. Median: the smallest of the replays' "
            "medians; p99 and max over all solves of all replays. Every ratio against a core takes the solver's own "
            "timer where it has one (timer: own), else its wall time (timer: wall). Error: max over the loop of "
            "|u0 - u0*| against the reference solutions."
            + (f" Not installed, not run: {', '.join(miss)}." if miss else ""), ""]


RATIO_NOTE = ("median / core and p99 / core: the solver's wall time over the core's latency; the last column: the "
              "core's solves per second over the solver's at its median (for a core with one QP in flight the same "
              "number as median / core). Above 1 the core is ahead.")


def solver_section(recs: list[dict], sw: dict, lat_label: str, qp_text: str, core_text: str) -> list[str]:
    """The software part of a QP section: what the solvers get (`qp_text`), the timer table, the notes, the ratio
    table against the cores (core latency labelled `lat_label`, explained by `core_text`) and the ratios' meaning."""
    return (["", "#### Per-solve time by timer, and against the core", "", qp_text, ""] + timer_table(sw)
            + [""] + software_notes(sw) + ratio_table(recs, sw, lat_label)
            + ["", f"{core_text} {RATIO_NOTE}", ""])
