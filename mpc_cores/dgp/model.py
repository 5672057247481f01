"""DGP golden models: iteration (35) of 003 on the two-sided form of mpc_cores.dgp.problem.

DgpFixed is the bit-exact model of a DGP core: integer words with p = frac_bits fraction bits, every product
rounded to nearest (rnd(a b) = floor((a b + 2^(p-1)) / 2^p)), row sums exact (the accumulator is wide enough by
construction), data words saturated to W = r + p bits with a flag. dgp_float runs the same iteration in float64.

One solve (w: nw parameter words; y = (y+, y-) the 2 mc dual words, upper rows then lower rows):
  0. w = clip(w_in, wlo, whi) (flag `sat`); e = sat(sum_j rnd(Fe_ij w_j)); c = sum_j rnd(Lb_ij w_j);
     lo = sat(lo0 + c), hi = sat(hi0 + c), with Lb = Lw - G Fe (design.bound_rows): the bounds relative to G e,
     so that the iteration takes s = G (z - e) (in exact arithmetic G z - G e)
  1. start: cold y = 0, warm y = the previous solve's final y; the operand dual wy = y; k = 0. A solve whose
     starting dual is all zero (`zero_start`: every cold start) has z = e and s = 0 in its first iteration (v = 0,
     z - e = 0, every product rnd(c 0) = 0), so the core skips that iteration's passes K and G; the words are the
     same either way
  then for nu = 0, 1, ..., Imax - 1:
  2. v = wy+ - wy-;  z = sat(sum_j rnd(K_ij v_j) + e_i);  s = sat(sum_j rnd(G_ij (z_j - e_j)))
  3. g = (sat(s - hi), sat(lo - s));  y_new = clip(wy + g, 0, ud)                     ((35), L = 1)
  plain (the averaged primal of (20) and the test (32c)):
  4. Sz += z; Sg += g; T += eg;  wy = y = y_new;  stop when Sg_i <= T for every i
     output zbar = floor((2 Sz + (nu + 1)) / (2 (nu + 1)))   (Sz / (nu + 1) rounded to nearest)
  accelerated (Nesterov with the gradient restart scheme of O'Donoghue and Candes):
  4. stop when g_i <= eg for every i (the test of (32c) on the last iterate) and
     gap = -sum_i rnd(wy_i g_i) <= eV (the duality gap V(z) - Phi(wy) of z = argmin L(., wy), which bounds
     V(z) - V*, the test of GPAD); output z
     restart = sum_i rnd(g_i (y_new_i - y_i)) < 0;  k = 0 if restart else min(k + 1, 255)
     wy = y_new if restart else clip(y_new + rnd(beta_k (y_new - y)), 0, ud);  y = y_new
     (the extrapolated dual stays in the dual box [0, ud], so that the gap -wy'g bounds V(z) - V* by weak duality)
At Imax without the test met, the output is that of the last iteration. The status reports the iterations run.
  5. the output words are clamped to the quantised input box: z_out = clip(z_out, out_lo, out_hi) (z is all
     inputs u_k; the box of design.output_box). Only the output: the iteration's z, Sz and y are unclamped.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mpc_cores.fixed import saturate


def mul_round(a: np.ndarray, b: np.ndarray, p: int) -> np.ndarray:
    """floor((a b + 2^(p-1)) / 2^p) exactly in int64 for |a| < 2^31 and |b| < 2^40 (broadcasting): b is split
    into a signed high part and a 20-bit low part."""
    k = min(20, p)
    bh = b >> k
    bl = b & ((1 << k) - 1)
    t = a * bh                                   # a b = t 2^k + a bl
    hi = t >> (p - k)
    rem = (t & ((1 << (p - k)) - 1)) << k        # < 2^p
    return hi + ((rem + a * bl + (1 << (p - 1))) >> p)


def row_sums(C: np.ndarray, V: np.ndarray, p: int) -> np.ndarray:
    """(S, R): sum_j rnd(C_rj V_sj) for the rows of C (R x c) and the operands V (S x c)."""
    out = np.zeros((V.shape[0], C.shape[0]), dtype=np.int64)
    for j in range(C.shape[1]):
        out += mul_round(C[None, :, j], V[:, j:j + 1], p)
    return out


def dot_round(a: np.ndarray, b: np.ndarray, p: int) -> np.ndarray:
    """sum_i rnd(a_si b_si) per row s"""
    return mul_round(a, b, p).sum(axis=1)


@dataclass
class DgpResult:
    z: np.ndarray               # (S, n) output words: the averaged primal (plain) or the last z (accelerated),
                                #   clamped to the quantised input box [out_lo, out_hi]
    iterations: np.ndarray      # (S,) iterations run
    met: np.ndarray             # (S,) the stopping test held
    sat: np.ndarray             # (S,) an input word saturated
    overflow: np.ndarray        # (S,) a data word saturated
    y: np.ndarray               # (S, 2 mc) final dual words (the next warm start)
    zraw: np.ndarray | None = None   # (S, n) the output words before the clamp (the iteration's own answer)
    zero_start: np.ndarray | None = None   # (S,) the starting dual was all zero (the core skips the first pass K)


class DgpFixed:
    """Bit-exact model of one DGP core instance, with its warm-start state."""

    def __init__(self, d, clamp: bool = True):
        """clamp: clamp the output words to the quantised input box (the core's behaviour); False: return the
        iteration's own answer (for the analysis of the algorithm, whose guarantees are on that answer)"""
        cfg = d if isinstance(d, dict) else d.config()
        self.clamp = clamp
        self.cfg = cfg
        self.n, self.nw, self.nu, self.mc = int(cfg["n"]), int(cfg["nw"]), int(cfg["nu"]), int(cfg["mc"])
        self.b = int(cfg["frac_bits"])
        self.W = int(cfg["widths"]["data"])
        self.iterations = int(cfg["iterations"])
        self.accelerated = bool(cfg["accelerated"])
        self.warm_start = bool(cfg["warm_start"])
        i64 = lambda k, *shape: np.array(cfg[k], dtype=np.int64).reshape(*shape)  # noqa: E731
        self.K = i64("K", self.n, self.mc)
        self.G = i64("G", self.mc, self.n)
        self.Fe = i64("Fe", self.n, self.nw)
        self.Lb = i64("Lb", self.mc, self.nw)
        self.lo0, self.hi0, self.ud = i64("lo0", -1), i64("hi0", -1), i64("ud", -1)
        self.beta = i64("beta", -1)
        self.xlo, self.xhi = i64("xlo", -1), i64("xhi", -1)
        self.out_lo, self.out_hi = i64("out_lo", -1), i64("out_hi", -1)
        self.shift_src = np.array(cfg.get("shift_src", []), dtype=np.int64)
        self.eg = int(cfg["eg"])
        self.eV = int(cfg["eV"])
        self.y_prev: np.ndarray | None = None   # warm start (None after reset)

    def reset(self) -> None:
        self.y_prev = None

    def solve(self, w, imax: int | None = None, warm: bool | None = None) -> DgpResult:
        """One solve of the core instance (warm start state kept), w: nw words."""
        warm = self.warm_start if warm is None else warm
        y0 = self.warm_dual(self.y_prev)[None] if (warm and self.y_prev is not None) else None
        r = self.solve_batch(np.asarray(w, dtype=np.int64)[None], imax=imax, y0=y0)
        self.y_prev = r.y[0].copy()
        return r

    def warm_dual(self, y: np.ndarray) -> np.ndarray:
        """The starting dual of a warm start from the final dual y of the previous solve: y itself, or with the
        design's warm_shift each word from its shift source (design.shift_sources; zero where none), clipped to its
        own dual box."""
        if not self.shift_src.size:
            return y
        src = np.maximum(self.shift_src, 0)
        return np.where(self.shift_src >= 0, np.minimum(np.asarray(y)[..., src], self.ud), 0)

    def solve_batch(self, W, imax: int | None = None, y0=None) -> DgpResult:
        """Independent solves of the rows of W (S x nw) from y0 (S x 2 mc; None: cold)."""
        imax = self.iterations if imax is None else int(imax)
        p, Wd = self.b, self.W
        W = np.asarray(W, dtype=np.int64)
        S = W.shape[0]
        w = np.clip(W, self.xlo, self.xhi)
        sat = np.any(w != W, axis=1)
        ovf = np.zeros(S, dtype=bool)

        def sat_w(x):
            c = np.clip(x, -(1 << (Wd - 1)), (1 << (Wd - 1)) - 1)
            ovf[:] |= np.any(c != x, axis=1)
            return c

        e = sat_w(row_sums(self.Fe, w, p))
        c = row_sums(self.Lb, w, p)
        lo, hi = sat_w(self.lo0 + c), sat_w(self.hi0 + c)
        y = np.zeros((S, 2 * self.mc), dtype=np.int64) if y0 is None else np.array(y0, dtype=np.int64)
        wy = y.copy()
        zero_start = ~np.any(y, axis=1)
        k = np.zeros(S, dtype=np.int64)
        Sz = np.zeros((S, self.n), dtype=np.int64)
        Sg = np.zeros((S, 2 * self.mc), dtype=np.int64)
        T = 0
        live = np.ones(S, dtype=bool)
        iters = np.full(S, imax, dtype=np.int64)
        met = np.zeros(S, dtype=bool)
        zout = np.zeros((S, self.n), dtype=np.int64)
        mc = self.mc
        for it in range(imax):
            v = wy[:, :mc] - wy[:, mc:]
            z = sat_w(row_sums(self.K, v, p) + e)
            s = sat_w(row_sums(self.G, z - e, p))
            g = np.concatenate([sat_w(s - hi), sat_w(lo - s)], axis=1)
            y_new = np.clip(wy + g, 0, self.ud)
            if self.accelerated:
                stop = np.all(g <= self.eg, axis=1) & (-dot_round(wy, g, p) <= self.eV)
                out = z
                restart = dot_round(g, y_new - y, p) < 0
                k = np.where(restart, 0, np.minimum(k + 1, len(self.beta) - 1))
                ext = np.clip(y_new + mul_round(self.beta[k][:, None], y_new - y, p), 0, self.ud)
                wy_new = np.where(restart[:, None], y_new, ext)
            else:
                Sz += z
                Sg += g
                T += self.eg
                stop = np.all(Sg <= T, axis=1)
                out = np.floor_divide(2 * Sz + (it + 1), 2 * (it + 1))
                wy_new = y_new
            # stopped solves keep their state; a solve stops at the test or at Imax
            upd = live
            fin = live & (stop | (it == imax - 1))
            zout[fin] = out[fin]
            iters[fin] = it + 1
            met[fin & stop] = True
            y[upd] = y_new[upd]
            wy[upd] = wy_new[upd]
            live = live & ~fin
            if not live.any():
                break
        # the output only: the state above is unclamped
        zc = np.clip(zout, self.out_lo, self.out_hi) if self.clamp else zout
        return DgpResult(z=zc, iterations=iters, met=met, sat=sat, overflow=ovf, y=y, zraw=zout,
                         zero_start=zero_start)


def dgp_float(qp, w, imax: int, accelerated: bool, eps_g: float, eps_V: float, ud=None, y0=None):
    """Iteration (35) in float64 on the scaled problem (ud: alpha d; None: no upper bound). Returns
    (z, iterations, met, y): the averaged primal (plain) or the last z (accelerated)."""
    K, Fe = qp.K, qp.Fe
    lo, hi = qp.bounds(w)
    e = Fe @ np.asarray(w, dtype=float)
    mc = qp.mc
    y = np.zeros(2 * mc) if y0 is None else np.array(y0, dtype=float)
    up = np.full(2 * mc, np.inf) if ud is None else np.asarray(ud, dtype=float)
    wy = y.copy()
    k = 0
    Sz = np.zeros(qp.n)
    Sg = np.zeros(2 * mc)
    eg = eps_g * qp.sigma
    z = out = np.zeros(qp.n)
    for it in range(imax):
        z = K @ (wy[:mc] - wy[mc:]) + e
        s = qp.G @ z
        g = np.concatenate([s - hi, lo - s])
        y_new = np.clip(wy + g, 0, up)
        if accelerated:
            stop = bool(np.all(g <= eg)) and -float(wy @ g) <= eps_V
            out = z
            restart = float(g @ (y_new - y)) < 0
            k = 0 if restart else min(k + 1, 255)
            wy = y_new if restart else np.clip(y_new + k / (k + 3) * (y_new - y), 0, up)
        else:
            Sz += z
            Sg += g
            stop = bool(np.all(Sg <= (it + 1) * eg))
            out = Sz / (it + 1)
            wy = y_new
        y = y_new
        if stop:
            return out, it + 1, True, y
    return out, imax, False, y
