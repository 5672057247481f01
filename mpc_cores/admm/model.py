"""ADMM golden models (Algorithm 2 of 002 with the per-component penalty rho_j = 2^k_j of mpc_cores/admm/design.py).

AdmmFixed is the bit-exact model an ADMM core must match word for word: integer words with b fraction bits,
every product rounded by shift_round, every right shift rounded the same way, pairwise adder trees, saturation
with flags. AdmmFloat runs the same iteration in float64, on the exact or on the quantised data.

Order of operations of one solve (w: nw parameter words; one = 2^b; rnd(p) = shift_round(p, b, rounding);
sh(a, k) = a << k for k >= 0, shift_round(a, -k, rounding) for k < 0; sat(., W) clamps to W bits and flags):

  0. w  = clip(w_in, wlo, whi)                              (input saturation, flag `sat`)
     w1 = (w, one), zero-padded to n_A                      (G~ has nw + 1 columns)
     gw_r = tree_sum_j sat(rnd(G~_rj w1_j), W_sum)          (once per solve; partial sums saturate to W_sum)
  1. warm start: (z, nu) = the previous solve's (z, nu) shifted by one stage (drop the decision input v_0 (du_0,
     or u_0 without the rate augmentation) and (x~_0, delta_0), repeat v_{N-1} and (x~_N, delta_N)); cold start:
     z = proj(0), nu = 0
  then Imax times, all components in parallel:
  2. v_j  = sat(sh(z_j, k_j) - nu_j, W_v)                   (rho_j z - nu; a shift, no multiplier)
  3. y_r  = sat(tree_sum_j sat(rnd(M11_rj v_j), W_sum) + gw_r, W_y)      (Algorithm 2 line 2)
  4. q_j  = sat(y_j + sh(nu_j, -k_j), W_q)                  (y + nu / rho_j)
  5. z    = sat(proj(q), W_z)                               (line 3): BOX: clip(q, lo, hi); FREE: q;
     soft pair (x, d) with centre c, radius r (words), see proj_soft:
        t = x - c, a = |t|, e = a - r, s = e + d
        d >= 0 and d >= e   -> (x, d)                         inside
        e <= 0              -> (x, 0)                         below the flat edge
        s <= 0              -> (c +- r, 0)                    beyond the corner (sign of t)
        else m = shift_round(s, 1, rounding) -> (c +- (r + m), m)    onto the slanted edge, halving rounded
  6. nu_j = sat(nu_j + sh(sat(y_j - z_j, W_d), k_j), W_nu)  (line 4: nu + rho_j (y - z))
Methods (config "method", mpc_cores/admm/design.py): step 2 is the method's operand, the rest is shared:
  admm      v_j = sat(sh(z_j, k_j) - nu_j, W_v)
  ama       v_j = sat(-nu_j, W_v)
  vucondat  v_j = sat(sh(y_j + z_j, k_j) - nu_j, W_v), y the previous iteration's y of step 3 (cold start: y = z,
            warm: shifted like z), k_j the shifts of sigma_j
The core returns z (and keeps (z, nu), and y for vucondat, for the next warm start); its first nu words are du_0
in the rate-augmented form (config "rate", absent: true) and u_0 otherwise (applied_input). A saturation in steps
0-6 other than the input clip sets `overflow` (and the flag of that signal); the input clip sets `sat`.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mpc_cores.admm.problem import BOX, project_K, project_soft
from mpc_cores.fixed import saturate, shift_round, tree_sum

_WIDTH_KEYS = ("v", "y", "q", "z", "d", "nu", "sum")


# The iterate words whose widths come from simulation (002 gives no analytic bound for them, IV-C2).
ESTIMATED = ("v", "y", "q", "z", "d", "nu", "msum")


def wide_widths() -> dict:
    """Widths that never saturate in the int64 model (for the sizing runs)."""
    return {k: 62 for k in _WIDTH_KEYS}


def shift_by(a: np.ndarray, k: np.ndarray, rounding: str) -> np.ndarray:
    """a 2^k_j per component (last axis); right shifts rounded like products."""
    out = np.empty_like(a)
    for kk in np.unique(k):
        m = k == kk
        kk = int(kk)
        out[..., m] = a[..., m] << kk if kk >= 0 else shift_round(a[..., m], -kk, rounding)
    return out


def shift_stages(v: np.ndarray, N: int, nu: int) -> np.ndarray:
    """Warm start: drop the first stage (v_0; x~_0, delta_0), repeat the last (v_{N-1}; x~_N, delta_N); v_k the
    decision input, du_k or u_k: the layout of both forms is N blocks of nu, then N + 1 equal stages."""
    du, st = v[..., : N * nu], v[..., N * nu:]
    stage = st.shape[-1] // (N + 1)
    return np.concatenate([du[..., nu:], du[..., -nu:], st[..., stage:], st[..., -stage:]], axis=-1)


def proj_soft(x, d, c, r, rounding: str):
    """Integer projection of (x, d) onto {|x - c| <= r + d, d >= 0}; the result lies in the set exactly."""
    t = x - c
    neg = t < 0
    e = np.abs(t) - r
    s = e + d
    inside = (d >= 0) & (d >= e)
    flat = ~inside & (e <= 0)
    corner = ~inside & ~flat & (s <= 0)
    m = shift_round(s, 1, rounding)
    mag = r + np.where(corner, 0, m)
    xo = np.where(inside | flat, x, np.where(neg, c - mag, c + mag))
    do = np.where(inside, d, np.where(corner | flat, 0, m))
    return xo, do


@dataclass
class AdmmSolveResult:
    z: np.ndarray               # final iterate words (n,)
    nu: np.ndarray              # final multiplier words (n,)
    sat: bool                   # a parameter word was outside the accepted box and saturated
    overflow: bool              # a datapath word saturated
    flags: dict = field(default_factory=dict)   # which signals saturated
    iterates: list | None = None  # z_0..z_Imax words when recorded
    y: np.ndarray | None = None   # vucondat: the last y (part of the warm start)


MOM_TABLE = 256       # accelerated: momentum words (a_i - 1) / a_(i+1), i = iterations since the (re)start
# accelerated: the states each method extrapolates (Goldstein et al.; docs/methods.md), and the residual test's
# factor eta = 1 - 2^-ETA_SHIFT (ADMM, Vu-Condat: restart unless c < eta c_prev; after a restart the threshold grows
# by 1 + 2^-ETA_SHIFT)
ACC_STATES = {"ama": ("nu",), "admm": ("z", "nu"), "vucondat": ("y", "z", "nu")}
ETA_SHIFT = 10


def _rho_weighted(a: np.ndarray, k: np.ndarray) -> np.ndarray:
    """a 2^k for non-negative a: a left shift, or a floor right shift"""
    return np.where(k >= 0, a << np.maximum(k, 0), a >> np.maximum(-k, 0))


def momentum_words(b: int, rounding: str = "nearest") -> np.ndarray:
    """Nesterov's momentum of fast AMA as b-bit words: a_0 = 1, a_(i+1) = (1 + sqrt(1 + 4 a_i^2)) / 2,
    mom_i = (a_i - 1) / a_(i+1) (mom_0 = 0); the index saturates at MOM_TABLE - 1."""
    a = [1.0]
    for _ in range(MOM_TABLE):
        a.append(0.5 * (1.0 + np.sqrt(1.0 + 4.0 * a[-1] ** 2)))
    return np.array([int(np.floor((a[i] - 1.0) / a[i + 1] * (1 << b) + 0.5)) for i in range(MOM_TABLE)],
                    dtype=np.int64)


@dataclass
class AdmmBatchResult:
    z: np.ndarray               # (S, n)
    nu: np.ndarray
    sat: np.ndarray             # (S,)
    overflow: np.ndarray        # (S,)
    flags: dict
    peaks: dict                 # largest |word| per signal over the batch and all iterations
    iterates: list | None = None
    y: np.ndarray | None = None  # vucondat: the last y
    restarts: np.ndarray | None = None  # accelerated: per row, the iterations whose gradient test restarted


class AdmmFixed:
    """Bit-exact model of one ADMM core instance, including its warm-start state."""

    def __init__(self, d):
        cfg = d if isinstance(d, dict) else d.config()
        self.cfg = cfg
        self.n, self.nw, self.nu, self.N = int(cfg["n"]), int(cfg["nw"]), int(cfg["nu"]), int(cfg["N"])
        self.b = int(cfg["frac_bits"])
        self.rounding = cfg["rounding"]
        self.widths = dict(cfg["widths"])
        self.iterations = int(cfg["iterations"])
        self.warm_start = bool(cfg["warm_start"])
        n = self.n
        self.M11 = np.array(cfg["M11"], dtype=np.int64).reshape(n, n)
        self.G = np.array(cfg["G"], dtype=np.int64).reshape(n, self.nw + 1)
        self.k = np.array(cfg["shift"], dtype=np.int64)
        self.kind = np.array(cfg["kind"], dtype=np.int64)
        self.lo = np.array(cfg["lo"], dtype=np.int64)
        self.hi = np.array(cfg["hi"], dtype=np.int64)
        self.sx = np.array(cfg["soft_x"], dtype=np.int64)
        self.sd = np.array(cfg["soft_d"], dtype=np.int64)
        self.sc = np.array(cfg["soft_c"], dtype=np.int64)
        self.sr = np.array(cfg["soft_r"], dtype=np.int64)
        self.wlo = np.array(cfg["wlo"], dtype=np.int64)
        self.whi = np.array(cfg["whi"], dtype=np.int64)
        self.method = cfg.get("method", "admm")
        # the QP's form: rate-augmented (w = (x, u_prev, r), du_0 out) or not (w = (x, r), u_0 out); configs
        # written before the plain form existed are all rate-augmented
        self.rate = bool(cfg.get("rate", True))
        # fast AMA with the gradient restart of O'Donoghue and Candes (method ama only)
        self.accelerated = bool(cfg.get("accelerated", False))
        self.mom = np.array(cfg["momentum"], dtype=np.int64) if self.accelerated else None
        # chunks per row: the row unit's lanes = ceil(max(n_A, nw + 1) / chunks) multipliers take a row in `chunks`
        # cycles; the chunks' tree sums add exactly and the total saturates (AdmmCore)
        self.chunks = int(cfg.get("chunks", 1))
        self.lanes = -(-max(n, self.nw + 1) // self.chunks)
        self.prev: tuple | None = None       # (z, nu[, y]) of the last solve; None: no valid warm start

    def reset(self) -> None:
        self.prev = None

    # ---- datapath pieces (leading batch axis)
    def _dot(self, M: np.ndarray, V: np.ndarray, chunk: int = 16):
        """Rows of M times each V[s], padded to n_A operands, rounded products, pairwise tree."""
        W = self.widths["sum"]
        cols = max(self.n, self.lanes * self.chunks)
        Vp = np.zeros((V.shape[0], cols), dtype=np.int64)
        Vp[:, : V.shape[1]] = V
        Mp = np.zeros((M.shape[0], cols), dtype=np.int64)
        Mp[:, : M.shape[1]] = M
        out = np.empty((V.shape[0], M.shape[0]), dtype=np.int64)
        flag, peak = False, 0
        for i in range(0, V.shape[0], chunk):
            p, f1 = saturate(shift_round(Mp[None] * Vp[i:i + chunk, None, :], self.b, self.rounding), W)
            peak = max(peak, int(np.abs(p).sum(axis=-1).max()))   # bounds every partial sum of the row
            if self.chunks == 1:
                out[i:i + chunk], f2 = tree_sum(p, W)
            else:   # per chunk of lanes a tree, then the exact sum of the chunks, saturated once
                part, f2 = tree_sum(p.reshape(p.shape[:-1] + (self.chunks, self.lanes)), W)
                out[i:i + chunk], f3 = saturate(part.sum(axis=-1), W)
                f2 = f2 or f3
            flag |= f1 or f2
        return out, flag, peak

    def proj(self, q: np.ndarray) -> np.ndarray:
        z = np.where(self.kind == BOX, np.clip(q, self.lo, self.hi), q)
        if self.sx.size:
            z[..., self.sx], z[..., self.sd] = proj_soft(q[..., self.sx], q[..., self.sd], self.sc, self.sr, self.rounding)
        return z

    def cold_start(self, S: int) -> tuple[np.ndarray, np.ndarray]:
        return self.proj(np.zeros((S, self.n), dtype=np.int64)), np.zeros((S, self.n), dtype=np.int64)

    def solve_batch(self, W, imax: int | None = None, warm_from=None, track: bool = False,
                    record: bool = False) -> AdmmBatchResult:
        """Independent solves of the parameter rows of W; warm_from = (z, nu) (vucondat: (z, nu, y)) of each row's
        previous solve."""
        imax = self.iterations if imax is None else int(imax)
        wd, rnd, k = self.widths, self.rounding, self.k
        W_in = np.atleast_2d(np.asarray(W, dtype=np.int64))
        S = W_in.shape[0]
        w = np.clip(W_in, self.wlo, self.whi)
        sat = np.any(w != W_in, axis=1)
        w1 = np.hstack([w, np.full((S, 1), 1 << self.b, dtype=np.int64)])
        flags = dict.fromkeys(_WIDTH_KEYS, False)
        gw, flags["sum"], _ = self._dot(self.G, w1)
        if warm_from is not None:
            z, nu, *ys = (shift_stages(np.asarray(a, dtype=np.int64), self.N, self.nu) for a in warm_from)
            y = ys[0] if ys else z.copy()
        else:
            z, nu = self.cold_start(S)
            y = z.copy()
        peaks = dict.fromkeys(ESTIMATED, 0)
        its = [z.copy()] if record else None

        def step(key, val):
            val, f = saturate(val, wd[key])
            flags[key] |= f
            if track:
                peaks[key] = max(peaks[key], int(np.abs(val).max()))
            return val

        if self.accelerated:            # the states hold x^, what an iteration reads; prev the last iteration's x
            keys = ACC_STATES[self.method]
            prev = {"y": y.copy(), "z": z.copy(), "nu": nu.copy()}
            idx, restarts = np.zeros(S, dtype=np.int64), np.zeros(S, dtype=np.int64)
            thr = np.full(S, -1, dtype=np.int64)          # the residual test's threshold (-1: none yet)
        for it in range(imax):
            hat = {"y": y, "z": z, "nu": nu}
            if self.method == "ama":
                v = step("v", -nu)
            elif self.method == "vucondat":
                v = step("v", shift_by(y + z, k, rnd) - nu)
            else:
                v = step("v", shift_by(z, k, rnd) - nu)
            s, f, pk = self._dot(self.M11, v)
            flags["sum"] |= f
            peaks["msum"] = max(peaks["msum"], pk)
            y = step("y", s + gw)
            q = step("q", y + shift_by(nu, -k, rnd))
            z = step("z", self.proj(q))
            d = step("d", y - z)
            nu = step("nu", nu + shift_by(d, k, rnd))
            if self.accelerated:
                cur = {"y": y, "z": z, "nu": nu}
                diff = {key: cur[key] - prev[key] for key in keys}
                cand = {key: step(key, cur[key] + shift_round(self.mom[idx][:, None] * diff[key], self.b, rnd))
                        for key in keys}
                if self.method == "ama":
                    # the gradient test <nu - nu^, nu - prev>_(1/rho) >= 0, nu - nu^ = rho d
                    ok = ((d * diff["nu"]) >> self.b).sum(axis=1) >= 0
                else:
                    # the combined residual sum_j rho_j |x_j - x^_j|^2 (nu: 1 / rho_j), below the threshold
                    c = sum(_rho_weighted((cur[key] - hat[key]) ** 2 >> self.b, -k if key == "nu" else k)
                            for key in keys).sum(axis=1)
                    ok = (thr < 0) | (c < thr)
                    thr = np.where(ok, c - (c >> ETA_SHIFT), thr + (thr >> ETA_SHIFT))
                if it < imax - 1:
                    # the next x^: the candidate x + mom_idx (x - prev) when the test held, else x (restart, the
                    # momentum index back to 0)
                    prev = cur
                    nxt = {key: np.where(ok[:, None], cand[key], cur[key]) for key in keys}
                    y, z, nu = nxt.get("y", y), nxt.get("z", z), nxt.get("nu", nu)
                    idx = np.where(ok, np.minimum(idx + 1, len(self.mom) - 1), 0)
                    restarts += ~ok
            if record:
                its.append(z.copy())
        overflow = np.full(S, any(flags.values()))
        return AdmmBatchResult(z=z, nu=nu, sat=sat, overflow=overflow, flags=flags, peaks=peaks, iterates=its,
                               y=y if self.method == "vucondat" else None,
                               restarts=restarts if self.accelerated else None)

    def solve(self, w_words, imax: int | None = None, warm: bool | None = None, record: bool = False) -> AdmmSolveResult:
        warm = self.warm_start if warm is None else bool(warm)
        w = np.asarray(w_words, dtype=np.int64)
        assert w.shape == (self.nw,), f"expected {self.nw} words, got {w.shape}"
        wf = None if not (warm and self.prev is not None) else tuple(a[None] for a in self.prev)
        r = self.solve_batch(w[None], imax, warm_from=wf, record=record)
        z, nu = r.z[0], r.nu[0]
        y = None if r.y is None else r.y[0].copy()
        self.prev = (z.copy(), nu.copy()) + ((y,) if y is not None else ())
        its = None if r.iterates is None else [a[0] for a in r.iterates]
        return AdmmSolveResult(z=z, nu=nu, sat=bool(r.sat[0]), overflow=bool(r.overflow[0]), flags=r.flags,
                               iterates=its, y=y)


class AdmmFloat:
    """Algorithm 2 of 002 in float64 with rho_j = 2^k_j: on the exact data (quantised=False) or on the words of
    the core scaled back to reals (quantised=True, the exact-arithmetic reference of eq. (17))."""

    def __init__(self, d, quantised: bool = False):
        self.d = d
        self.quantised = quantised
        one = float(1 << d.b)
        self.rho = d.rho_vec
        if quantised:
            self.M11, self.G = d.M11 / one, d.G / one
        else:
            self.M11, self.G = d.M11f, d.Gf
        self.prev: tuple | None = None

    def proj(self, q: np.ndarray) -> np.ndarray:
        d = self.d
        if not self.quantised:
            return project_K(d.qp, q)
        one = float(1 << d.b)
        z = np.where(d.kind == BOX, np.clip(q, d.lo / one, d.hi / one), q)
        if d.qp.ns:
            z[d.qp.soft_x], z[d.qp.soft_d] = project_soft(q[d.qp.soft_x], q[d.qp.soft_d], d.soft_c / one,
                                                          d.soft_r / one)
        return z

    def solve(self, w, imax: int | None = None, warm: bool | None = None, z0=None, nu0=None,
              record: bool = False):
        """(z, nu, iterates) from w in reals (d.qp.w: (x, u_prev, r) or (x, r); clipped to the accepted box when
        quantised)."""
        d = self.d
        imax = d.iterations if imax is None else int(imax)
        warm = d.warm_start if warm is None else bool(warm)
        w = np.asarray(w, dtype=float)
        if self.quantised:
            one = float(1 << d.b)
            w = np.clip(w, d.wlo / one, d.whi / one)
        gw = self.G @ np.append(w, 1.0)
        if z0 is not None:
            z, nu = np.asarray(z0, dtype=float).copy(), np.zeros(d.n) if nu0 is None else np.asarray(nu0, float).copy()
            y = z.copy()
        elif warm and self.prev is not None:
            z, nu, y = (shift_stages(a, d.N, d.nu) for a in self.prev)
        else:
            z, nu = self.proj(np.zeros(d.n)), np.zeros(d.n)
            y = z.copy()
        its = [z.copy()] if record else None
        rho = self.rho        # the datapath's steps 2^k_j (vucondat: sigma_j)
        method = getattr(d, "method", "admm")
        for _ in range(imax):
            v = -nu if method == "ama" else rho * (y + z) - nu if method == "vucondat" else rho * z - nu
            y = self.M11 @ v + gw
            z = self.proj(y + nu / rho)
            nu = nu + rho * (y - z)
            if record:
                its.append(z.copy())
        self.prev = (z.copy(), nu.copy(), y.copy())
        return z, nu, its


def applied_input(d, z, u_prev) -> np.ndarray:
    """The input to apply from the first nu entries of z (d: a design or an AdmmQP, whose `rate` says the form).
    Rate-augmented: u_0 = clip(u_prev + du_0, umin, umax), which meets the rate and the input box even when z is
    not converged (du_0 lies in its box, and clipping towards the box only shrinks the step from u_prev inside
    it). Otherwise z starts with u_0 itself: clip(u_0, umin, umax) (u_prev unused)."""
    p = d.problem
    u0 = np.asarray(z, dtype=float)[: d.nu]
    return np.clip(np.asarray(u_prev, dtype=float) + u0 if d.rate else u0, p.umin, p.umax)


__all__ = ["AdmmFixed", "AdmmFloat", "AdmmSolveResult", "applied_input", "proj_soft", "shift_by", "shift_stages",
           "wide_widths"]
