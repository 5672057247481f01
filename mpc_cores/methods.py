"""The splitting family of 004 (ADMM, AMA, Vu-Condat; Stathopoulos et al. 2016) and the dual gradient projection of
003, in float64, with and without acceleration and preconditioning, for the comparison of `make methods`.

Splitting family, on the sparse QP of mpc_cores.admm.problem (min 1/2 z'Hz + h(w)'z s.t. F z = b(w), z in K), with
per-component steps rho_j = 2^k_j, gw = G~ (w, 1) and M11 from mpc_cores.admm.design.kkt_blocks (matrix H + diag(rho),
or H alone for AMA), rows of a batch of solves at once:

  ADMM        v = rho z - nu;  y = M11 v + gw;  z = proj(y + nu / rho);  nu += rho (y - z)
  AMA         v = -nu;         y = M11 v + gw (M11, G~ of the unaugmented KKT matrix);  same z and nu steps;
              rho uniform, the largest power of two below 2 mu, mu = lambda_min(Z'HZ), Z a basis of Ker F
  Vu-Condat   (Chambolle-Pock with L = I, tau = 1/rho, sigma = rho/2; cold start y = z = proj(0), nu = 0)
              v = sigma (y + z) - nu;  y = M11 v + gw;  z = proj(y + nu / sigma);  nu += sigma (y - z)

Acceleration: Nesterov's sequence a' = (1 + sqrt(1 + 4 a^2)) / 2, momentum (a - 1) / a', on the state the next
iteration reads: (z, nu) for ADMM (fast ADMM, Goldstein, O'Donoghue, Setzer, Baraniuk 2014, Algorithm 8), nu for AMA
(fast AMA, their Algorithm 9), (y, z, nu) for Vu-Condat (inertial). Adaptive restart (a = 1, momentum dropped):
  "residual" (ADMM, Vu-Condat): the combined residual of Goldstein et al., c = ||x - x^||^2 in the metric of the
        method (ADMM: ||nu - nu^||^2_{1/rho} + ||z - z^||^2_rho; Vu-Condat: sigma ||y - y^||^2 + sigma ||z - z^||^2
        + ||nu - nu^||^2_{1/sigma}), restart when c >= eta c_prev (eta = 0.999; c_prev then grows by 1/eta). The
        restart continues from the current iterate; Algorithm 8 goes back to the previous one ("residual-back"),
        which measured slower here (it drops one iteration per restart).
  "gradient" (AMA, the DGP): O'Donoghue and Candes (2015): restart when the step of the map opposes the momentum,
        <x_new - x^, x_new - x_old> < 0 (AMA: nu in the metric 1/rho; it is a proximal gradient method on the dual).
  "none": Nesterov's momentum without restart.
Preconditioning (offline): Ruiz equilibration of the KKT matrix [[H, F'], [F, 0]] (rows and columns scaled by
1/sqrt of their infinity norms, 25 sweeps), then a cost scale c, every factor rounded to a power of two. The QP is
solved in z = D z~: H~ = c D H D, h~ = c D h, F~ = E F D, b~ = E b, the boxes and the soft sets divided by D (both
members of a soft pair share one factor, so the projection stays that of 002). E has no effect on any of the three
iterations (the y-step meets F y = b exactly); D and c amount to steps rho_j / (c D_j^2), again powers of two.

Dual gradient projection (mpc_cores.dgp.model.dgp_float, without its stopping tests): plain (the averaged primal
of (20) of 003 is the output) and accelerated (Nesterov, beta_k = k/(k+3), gradient restart). Its preconditioner
is a Ruiz equilibration of the dual Hessian G Q^-1 G' (rows of the constraints scaled by powers of two), followed
by the uniform scaling to L = 1 of mpc_cores.dgp.problem; a scaling of z would leave the dual problem unchanged.

The study and the tables are in mpc_cores.methods_table; `mpc-cores methods --out build/reports`.
"""
from __future__ import annotations

if __name__ == "__main__":
    # `python -m mpc_cores.methods`: one BLAS thread (the products are small batches; extra threads only contend,
    # several times slower on a 2-core machine); set before numpy is imported
    import os

    for _k in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(_k, "1")

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from mpc_cores.admm.design import kkt_blocks
from mpc_cores.admm.model import shift_stages
from mpc_cores.admm.precondition import (RUIZ_SWEEPS, Pow2Scaling, pow2_below, reduced_curvature, round_log2,
                                         ruiz_pow2, scale_qp)
from mpc_cores.admm.problem import BOX, AdmmQP, project_soft
from mpc_cores.closedloop import Controller
from mpc_cores.dgp.problem import DgpQP
from mpc_cores.problem import InputRate, MpcProblem

SPLITTING = ("admm", "ama", "vucondat")
METHOD_NAMES = {"admm": "ADMM", "ama": "AMA", "vucondat": "Vu-Condat", "dgp": "DGP"}
ETA_SHIFT = 10            # restart factor of Goldstein et al., eta = 1 - 2^-10 (the cores' words: AdmmFixed)
RESTART = {"admm": "residual", "ama": "gradient", "vucondat": "residual"}   # the table's restart schemes
BETA_CAP = 255            # accelerated DGP: k saturates at 255 (the core's beta table)


# --------------------------------------------------------------------------
# the QP of the splitting family


def splitting_problem(p: MpcProblem) -> MpcProblem:
    """The problem the splitting family solves: p itself when it has an input_rate section; else p with a rate
    box that cannot bind (|du| <= umax - umin) and a zero rate weight, so that the sparse QP of
    mpc_cores.admm.problem has the same inputs as the optimum of p (its parameter also carries u_prev, which then
    changes only du_0)."""
    if p.input_rate is not None:
        return p
    span = np.asarray(p.umax - p.umin, dtype=float)
    rate = InputRate(dumin=-span, dumax=span, weight=np.zeros((p.nu, p.nu)))
    return dataclasses.replace(p, input_rate=rate)


def project_batch(qp: AdmmQP, Q: np.ndarray) -> np.ndarray:
    """pi_K row by row (mpc_cores.admm.problem.project_K on a batch)."""
    Z = np.where(qp.kind == BOX, np.clip(Q, qp.lo, qp.hi), Q)
    if qp.ns:
        Z[..., qp.soft_x], Z[..., qp.soft_d] = project_soft(Q[..., qp.soft_x], Q[..., qp.soft_d], qp.soft_c, qp.soft_r)
    return Z


# --------------------------------------------------------------------------
# splitting iterations


@dataclass(frozen=True, eq=False)
class SplitSetup:
    """What one splitting variant iterates with: qp is the (scaled, when preconditioned) QP; rho its steps."""
    method: str
    base: AdmmQP
    qp: AdmmQP
    scaling: Pow2Scaling | None
    rho: np.ndarray
    M11: np.ndarray
    G: np.ndarray
    mu: float | None = None        # AMA: lambda_min(Z'HZ) of qp

    @property
    def n(self) -> int:
        return self.base.n

    def unscale(self, z: np.ndarray) -> np.ndarray:
        return z if self.scaling is None else z * self.scaling.D

    def to_original(self, y, z, nu):
        """(y, z, nu) of the scaled QP in the units of the original one (nu~ = c D nu)."""
        if self.scaling is None:
            return y, z, nu
        D, c = self.scaling.D, self.scaling.cost
        return y * D, z * D, nu / (c * D)

    def from_original(self, y, z, nu):
        if self.scaling is None:
            return y, z, nu
        D, c = self.scaling.D, self.scaling.cost
        return y / D, z / D, nu * (c * D)

    @property
    def effective_rho(self) -> np.ndarray:
        """The steps in the units of the original QP: rho_j / (c D_j^2) when preconditioned (see the docstring)."""
        return self.rho if self.scaling is None else self.rho / (self.scaling.cost * self.scaling.D ** 2)

    @property
    def step_label(self) -> str:
        k = sorted({int(v) for v in np.round(np.log2(self.effective_rho))})
        return "rho = " + ", ".join(f"2^{v}" for v in k)


def split_setup(qp: AdmmQP, method: str, rho_vec: np.ndarray, precondition: bool = False,
                accelerated: bool = False) -> SplitSetup:
    """The data of one method: ADMM and Vu-Condat take rho_vec (the design's rho_j); AMA its uniform step from mu."""
    if method not in SPLITTING:
        raise ValueError(f"unknown splitting method {method!r} (expected one of {SPLITTING})")
    sc = ruiz_pow2(qp) if precondition else None
    q = scale_qp(qp, sc) if sc is not None else qp
    mu = None
    if method == "ama":
        mu = reduced_curvature(q)
        if not mu > 0:
            raise ValueError(f"AMA needs H positive definite on Ker F: lambda_min(Z'HZ) = {mu:.3g}")
        # Tseng's bound 2 mu; fast AMA (accelerated) mu, the dual gradient's 1 / Lipschitz constant
        rho = np.full(qp.n, pow2_below(mu if accelerated else 2.0 * mu))
        M11, G = kkt_blocks(q, np.zeros(qp.n))
    else:
        rho = np.asarray(rho_vec, dtype=float)
        M11, G = kkt_blocks(q, rho)
    return SplitSetup(method=method, base=qp, qp=q, scaling=sc, rho=rho, M11=M11, G=G, mu=mu)


@dataclass
class SplitState:
    """Iterates of a batch (rows) in the units of the QP the setup iterates on."""
    y: np.ndarray
    z: np.ndarray
    nu: np.ndarray


class Tracker:
    """Relative errors ||z_k - z*|| / max(||z*||, 1e-9) per row and, per tolerance, the last iteration at which the
    error was above it (or not a number): iterations(tol) = the first k >= 1 from which the error stays <= tol up to
    the last iteration run (None: still above at the last one)."""

    def __init__(self, z_star: np.ndarray, tols):
        self.z_star = np.atleast_2d(np.asarray(z_star, dtype=float))
        self.norm = np.maximum(np.linalg.norm(self.z_star, axis=1), 1e-9)
        self.tols = tuple(float(t) for t in tols)
        S = self.z_star.shape[0]
        self.last_above = {t: np.zeros(S, dtype=np.int64) for t in self.tols}
        self.k = 0
        self.final = np.full(S, np.inf)

    def __call__(self, z: np.ndarray) -> None:
        self.k += 1
        err = np.linalg.norm(z - self.z_star, axis=1) / self.norm
        self.final = err
        for t in self.tols:
            self.last_above[t][~(err <= t)] = self.k     # a nan (diverged) row counts as above

    def iterations(self, tol: float) -> list:
        la = self.last_above[float(tol)]
        return [None if int(v) >= self.k else int(v) + 1 for v in la]


def _nesterov(a: np.ndarray) -> np.ndarray:
    return 0.5 * (1.0 + np.sqrt(1.0 + 4.0 * a * a))


def split_cold(st: SplitSetup, S: int) -> SplitState:
    z = project_batch(st.qp, np.zeros((S, st.n)))
    return SplitState(y=z.copy(), z=z, nu=np.zeros((S, st.n)))


def split_run(st: SplitSetup, W, imax: int, accelerated: bool, start: SplitState | None = None,
              track: Tracker | None = None, restart: str | None = None) -> SplitState:
    """imax iterations of the setup's method from `start` (None: cold) for the parameter rows W (S x nw); the
    tracker, if any, sees the unscaled z after every iteration. Returns the final iterates (scaled units)."""
    W = np.atleast_2d(np.asarray(W, dtype=float))
    S = W.shape[0]
    gw = np.hstack([W, np.ones((S, 1))]) @ st.G.T
    M, rho, q = st.M11, st.rho, st.qp
    x = start if start is not None else split_cold(st, S)
    y, z, nu = x.y.copy(), x.z.copy(), x.nu.copy()
    method = st.method
    sig = rho / 2.0
    restart = RESTART[method] if restart is None else restart
    if restart not in ("residual", "residual-back", "gradient", "none"):
        raise ValueError(f"unknown restart scheme {restart!r} (residual, gradient or none)")

    def T(yh, zh, nuh):
        """one plain iteration from (y, z, nu)"""
        if method == "admm":
            v = rho * zh - nuh
        elif method == "ama":
            v = -nuh
        else:
            v = sig * (yh + zh) - nuh
        yn = v @ M + gw
        step = sig if method == "vucondat" else rho
        zn = project_batch(q, yn + nuh / step)
        return yn, zn, nuh + step * (yn - zn)

    if not accelerated:
        for _ in range(imax):
            y, z, nu = T(y, z, nu)
            if track is not None:
                track(st.unscale(z))
        return SplitState(y, z, nu)

    # the state the next iteration reads, and the metric of the restart tests
    if method == "admm":
        comps, wts = ("z", "nu"), (rho, 1.0 / rho)
    elif method == "ama":
        comps, wts = ("nu",), (1.0 / rho,)
    else:
        comps, wts = ("y", "z", "nu"), (sig, sig, 1.0 / sig)
    cur = {"y": y, "z": z, "nu": nu}
    hat = dict(cur)
    prev = dict(cur)
    a = np.ones(S)
    thr = np.full(S, np.inf)        # residual restart: c must stay below eta c_prev (grown by 1 + 2^-10 on a restart)
    for _ in range(imax):
        y, z, nu = T(hat["y"], hat["z"], hat["nu"])
        cur = {"y": y, "z": z, "nu": nu}
        if restart.startswith("residual"):
            # combined residual of Goldstein et al. (their Algorithms 8 and 9): ||x - x^||^2 in the metric
            c = sum(np.sum(wt * (cur[k] - hat[k]) ** 2, axis=1) for k, wt in zip(comps, wts))
            ok = c < thr
            thr = np.where(ok, c * (1.0 - 2.0 ** -ETA_SHIFT), thr * (1.0 + 2.0 ** -ETA_SHIFT))
            back = ~ok if restart == "residual-back" else np.zeros(S, dtype=bool)
        elif restart == "gradient":
            # O'Donoghue and Candes: the step of the map opposes the momentum
            inner = sum(np.sum(wt * (cur[k] - hat[k]) * (cur[k] - prev[k]), axis=1) for k, wt in zip(comps, wts))
            ok = inner >= 0
            back = np.zeros(S, dtype=bool)  # restart from the current iterate
        else:
            ok = np.ones(S, dtype=bool)
            back = np.zeros(S, dtype=bool)
        a1 = np.where(ok, _nesterov(a), 1.0)
        mom = np.where(ok, (a - 1.0) / a1, 0.0)[:, None]
        hat = {k: np.where(back[:, None], prev[k], cur[k] + mom * (cur[k] - prev[k])) for k in cur}
        a = a1
        prev = cur
        if track is not None:
            track(st.unscale(z))
    return SplitState(y, z, nu)


class SplitController(Controller):
    """A splitting variant in the closed loop of mpc_cores.closedloop: w = (x, u_prev, r), imax iterations
    warm-started from the previous solve's (y, z, nu) shifted by one stage (in the original units; momentum
    reset), u = clip(u_prev + du_0, umin, umax) as the ADMM cores apply it (mpc_cores.admm.control)."""
    name = "splitting"

    def __init__(self, st: SplitSetup, imax: int, accelerated: bool, warm: bool = True, restart: str | None = None):
        self.st = st
        self.restart = restart
        self.p = st.base.problem
        self.imax = int(imax)
        self.accelerated = accelerated
        self.warm = warm
        self.nu = st.base.nu
        self.reset()

    def reset(self) -> None:
        self.u_prev = np.zeros(self.nu)
        self.prev: tuple | None = None

    async def step(self, x, r):
        st = self.st
        w = np.concatenate([x, self.u_prev, r])[None]
        start = None
        if self.warm and self.prev is not None:
            y, z, nu = (shift_stages(a, st.base.N, st.base.nu) for a in self.prev)
            start = SplitState(*st.from_original(y, z, nu))
        res = split_run(st, w, self.imax, self.accelerated, start=start, restart=self.restart)
        self.prev = st.to_original(res.y, res.z, res.nu)
        z = st.unscale(res.z)[0]
        u = np.clip(self.u_prev + z[: self.nu], self.p.umin, self.p.umax)
        self.u_prev = u
        return u


# --------------------------------------------------------------------------
# dual gradient projection


def dgp_precondition(qp: DgpQP, sweeps: int = RUIZ_SWEEPS) -> tuple[DgpQP, np.ndarray]:
    """(the DGP QP with its constraint rows scaled by E = 2^e, e): E from a Ruiz equilibration of the dual Hessian
    G Q^-1 G', rounded to powers of two, then the uniform scaling to L = 2 lambda_max(G Q^-1 G') = 1 of
    mpc_cores.dgp.problem (folded into the coefficients, as there). The QP's solution z* is unchanged."""
    Mh = qp.G @ np.linalg.solve(qp.Q, qp.G.T)
    A = np.abs(Mh)
    s = np.ones(qp.mc)
    for _ in range(sweeps):
        r = (s[:, None] * A * s[None, :]).max(axis=1)
        s *= 1.0 / np.sqrt(np.where(r > 0, r, 1.0))
    e = round_log2(s)
    E = np.ldexp(1.0, e)
    G = E[:, None] * qp.G
    L = 2.0 * float(np.linalg.eigvalsh(G @ np.linalg.solve(qp.Q, G.T))[-1])
    t = 1.0 / math.sqrt(L)
    f = t * E
    return dataclasses.replace(qp, G=t * G, lo0=f * qp.lo0, hi0=f * qp.hi0, Lw=f[:, None] * qp.Lw,
                               sigma=qp.sigma * t), e


@dataclass
class DgpState:
    y: np.ndarray       # (S, 2 mc): the dual (upper rows, lower rows)


def dgp_run(qp: DgpQP, W, imax: int, accelerated: bool, y0=None, track: Tracker | None = None):
    """Iteration (35) of 003 on a batch, as mpc_cores.dgp.model.dgp_float without its stopping tests and without
    the dual box (ud = None: y and the extrapolated dual are kept >= 0 only): returns (output z (S, n), final y).
    The output is the averaged primal (plain) or the last z (accelerated); the tracker sees the output after every
    iteration."""
    W = np.atleast_2d(np.asarray(W, dtype=float))
    S, mc = W.shape[0], qp.mc
    K, Fe = qp.K, qp.Fe
    c = W @ qp.Lw.T
    lo, hi = qp.lo0 + c, qp.hi0 + c
    e = W @ Fe.T
    y = np.zeros((S, 2 * mc)) if y0 is None else np.array(y0, dtype=float).reshape(S, 2 * mc)
    wy = y.copy()
    k = np.zeros(S)
    Sz = np.zeros((S, qp.n))
    out = np.zeros((S, qp.n))
    for it in range(imax):
        z = (wy[:, :mc] - wy[:, mc:]) @ K.T + e
        s = z @ qp.G.T
        g = np.hstack([s - hi, lo - s])
        y_new = np.maximum(wy + g, 0.0)
        if accelerated:
            out = z
            restart = np.sum(g * (y_new - y), axis=1) < 0
            k = np.where(restart, 0.0, np.minimum(k + 1.0, BETA_CAP))
            beta = (k / (k + 3.0))[:, None]
            wy = np.where(restart[:, None], y_new, np.maximum(y_new + beta * (y_new - y), 0.0))
        else:
            Sz += z
            out = Sz / (it + 1)
            wy = y_new
        y = y_new
        if track is not None:
            track(out)
    return out, y


class DgpFloatController(Controller):
    """The DGP in the closed loop: imax iterations warm-started from the previous solve's final dual (the core's
    warm start), u = the first nu entries of the output."""
    name = "dgp-float"

    def __init__(self, qp: DgpQP, imax: int, accelerated: bool, warm: bool = True):
        self.qp = qp
        self.imax = int(imax)
        self.accelerated = accelerated
        self.warm = warm
        self.y = None

    def reset(self) -> None:
        self.y = None

    async def step(self, x, r):
        w = np.concatenate([np.asarray(x, dtype=float), np.asarray(r, dtype=float)])
        z, y = dgp_run(self.qp, w, self.imax, self.accelerated, y0=self.y if self.warm else None)
        self.y = y
        return z[0, : self.qp.nu]


__all__ = ["DgpFloatController", "Pow2Scaling", "SPLITTING", "SplitController", "SplitSetup", "SplitState", "Tracker",
           "dgp_precondition", "dgp_run", "pow2_below", "project_batch", "reduced_curvature",
           "ruiz_pow2", "scale_qp", "split_cold", "split_run", "split_setup", "splitting_problem"]
