"""MINRES (Paige and Saunders, in the form of Elman, Silvester and Wathen, Alg. 2.4) on the banded KKT system:
a float64 reference and the bit-exact binary32 model of the core.

The bit-exact model performs the core's float32 operations in the core's order, so that the RTL matches it word
for word. numpy float32 arithmetic is correctly rounded to nearest even with gradual underflow, as the float
library (mpc_cores/float/model.py checks them against each other); NaN results are compared by NaN-ness and the core
returns the canonical quiet NaN 0x7FC00000.

Operation order (x_0 = 0; one "init" pass, then Imax iterations j = 1..Imax):

    init:   u = (b - 0*0) - 0*0;  nrm2 = acc(u*u);  g' = sqrt(nrm2);  v_1 = u / g'
            state: c = c_prev = 1, s = s_prev = 0, g = g', eta = g'
    iter j: y_i = tree(coef_i,t * v_(i+t-(M-1)))         matvec, 2M-1 products, pairwise tree
            delta = acc(v_i * y_i)
            u = (y - delta*v_j) - g*v_(j-1)               v_0 = 0
            nrm2 = acc(u*u);  g' = sqrt(nrm2)
            a0 = c*delta - (c_prev*s)*g;  a1 = sqrt(a0*a0 + nrm2)
            a2 = s*delta + (c_prev*c)*g;  a3 = s_prev*g
            c' = a0/a1;  s' = g'/a1;  ceta = c'*eta;  eta' = -(s'*eta)
            v_(j+1) = u / g';  w_(j+1) = ((v_j - a3*w_(j-1)) - a2*w_j) / a1;  x += ceta*w_(j+1)
                                                           w_0 = w_(-1) = 0

tree(): the pairwise adder tree of linalg/DotProductTree: pairs (0,1), (2,3), ... at each level, an odd last
element passed on. acc(): the streaming accumulator of the core (MinresCore): L = lat_add partial sums, term k
into partial k mod L (the first L terms added to +0), then the last L outputs in arrival order (terms N-L..N-1)
reduced by tree().

A problem whose input words are not all finite, or whose solution is not, is flagged.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mpc_cores.minres.kkt import Layout

f32 = np.float32
QNAN32 = 0x7FC00000


def tree(terms: np.ndarray) -> np.ndarray:
    """Pairwise reduction over the last axis in the order of DotProductTree."""
    level = [terms[..., t] for t in range(terms.shape[-1])]
    while len(level) > 1:
        nxt = [level[k] + level[k + 1] for k in range(0, len(level) - 1, 2)]
        if len(level) % 2:
            nxt.append(level[-1])
        level = nxt
    return level[0]


def acc(terms: np.ndarray, L: int) -> np.float32:
    """The core's streaming sum of `terms` (float32, in stream order) with L partial sums."""
    n = len(terms)
    assert n > L, f"the accumulator needs more than L={L} terms, got {n}"
    part = np.zeros(L, dtype=f32)
    with np.errstate(all="ignore"):
        for k in range(n):
            part[k % L] = terms[k] + part[k % L]
        order = [(n - L + q) % L for q in range(L)]
        return tree(part[order][None, :])[0] if L > 1 else part[0]


def words(x: np.ndarray) -> list[int]:
    """Raw binary32 words, NaN as the canonical quiet NaN."""
    x = np.asarray(x, dtype=f32)
    w = x.view(np.uint32).astype(np.int64)
    return [QNAN32 if np.isnan(v) else int(u) for v, u in zip(x, w)]


def from_words(ws) -> np.ndarray:
    return np.array([int(w) & 0xFFFFFFFF for w in ws], dtype=np.uint32).view(f32)


def finite_word(w: int) -> bool:
    return (int(w) >> 23) & 0xFF != 0xFF


@dataclass
class Result:
    x: np.ndarray     # float32 solution
    flag: bool        # a non-finite input word or a non-finite solution


class MinresCoreModel:
    """Bit-exact model of the core for one problem size. `rom`: the constant columns (kkt.const_rom), any
    float type (rounded to binary32 here, as the generator does)."""

    @classmethod
    def from_config(cls, cfg: dict) -> "MinresCoreModel":
        """The model of a generated core, from its config.json (the ROM as raw binary32 words)."""
        n, m, T = int(cfg["n"]), int(cfg["m"]), int(cfg["T"])
        rom = from_words(np.array(cfg["rom"]).ravel()).reshape(2 * n + m, Layout(n, m, T).M - 1)
        return cls(n, m, T, rom, int(cfg["lat_add"]))

    def __init__(self, n: int, m: int, T: int, rom: np.ndarray, lat_add: int):
        self.L = Layout(n, m, T)
        self.n, self.m, self.T = n, m, T
        self.N, self.M = self.L.N, self.L.M
        self.lat_add = lat_add
        self.rom = np.asarray(rom, dtype=f32)
        assert self.rom.shape == (2 * n + m, self.M - 1)
        # constant half-CDS columns d = 1..M-1 of every row (lambda rows generated, rows past the end zero)
        N, M = self.N, self.M
        C = np.zeros((N, M), dtype=f32)
        for i in range(N):
            kind, q = self.L.row_kind(i)
            if kind == "lam":
                C[i, n] = f32(-1.0)
            elif kind == "x":
                C[i, 1:] = self.rom[q]
            elif kind == "u":
                C[i, 1:] = self.rom[n + q]
            else:
                C[i, 1:] = self.rom[n + m + q]
        for d in range(M):
            C[N - d:, d] = f32(0.0)
        self.Cconst = C
        self.primal = self.L.primal_rows()
        # band index t = 0..2M-2 is offset o = t - (M-1); in-range mask
        o = np.arange(2 * M - 1) - (M - 1)
        cols = np.arange(N)[:, None] + o[None, :]
        self.inrange = (cols >= 0) & (cols < N)
        self.cols = np.clip(cols, 0, N - 1)
        self.offs = o

    def band(self, diag: np.ndarray) -> np.ndarray:
        """N x (2M-1) coefficients of every row, offsets -(M-1)..M-1, +0 outside the matrix."""
        C = self.Cconst.copy()
        C[self.primal, 0] = np.asarray(diag, dtype=f32)
        N, M = self.N, self.M
        B = np.zeros((N, 2 * M - 1), dtype=f32)
        rows = np.arange(N)
        for t, o in enumerate(self.offs):
            if o >= 0:
                B[:, t] = C[:, o]
            else:
                src = rows + o
                ok = src >= 0
                B[ok, t] = C[src[ok], -o]
        B[~self.inrange] = f32(0.0)
        return B

    def matvec(self, band: np.ndarray, v: np.ndarray) -> np.ndarray:
        win = np.where(self.inrange, v[self.cols], f32(0.0)).astype(f32)
        return tree(band * win)

    def matrix(self, diag) -> np.ndarray:
        """The float32 matrix the core multiplies by (for the references)."""
        N, M = self.N, self.M
        K = np.zeros((N, N))
        B = self.band(diag)
        for t, o in enumerate(self.offs):
            idx = np.arange(N)
            ok = self.inrange[:, t]
            K[idx[ok], idx[ok] + o] = B[ok, t]
        return K

    def solve(self, diag, b, imax: int) -> Result:
        diag = np.asarray(diag, dtype=f32)
        b = np.asarray(b, dtype=f32)
        bad_in = not (np.all(np.isfinite(diag)) and np.all(np.isfinite(b)))
        L = self.lat_add
        z = np.zeros(self.N, dtype=f32)
        with np.errstate(all="ignore"):
            band = self.band(diag)
            # init
            u = (b - z * z) - z * z
            nrm2 = acc(u * u, L)
            g = np.sqrt(nrm2)
            v = u / g
            vprev = z.copy()
            w, wprev = z.copy(), z.copy()
            x = z.copy()
            c = cp = f32(1.0)
            s = sp = f32(0.0)
            eta = g
            for j in range(1, imax + 1):
                y = self.matvec(band, v)
                delta = acc(v * y, L)
                u = (y - delta * v) - g * (vprev if j > 1 else z)
                nrm2 = acc(u * u, L)
                g1 = np.sqrt(nrm2)
                a0 = c * delta - (cp * s) * g
                a1 = np.sqrt(a0 * a0 + nrm2)
                a2 = s * delta + (cp * c) * g
                a3 = sp * g
                c1 = a0 / a1
                s1 = g1 / a1
                ceta = c1 * eta
                eta = -(s1 * eta)
                vnew = u / g1
                wm1 = wprev if j > 2 else z
                wj = w if j > 1 else z
                wnew = ((v - a3 * wm1) - a2 * wj) / a1
                x = (x if j > 1 else z) + ceta * wnew
                vprev, v = v, vnew
                wprev, w = w, wnew
                cp, c = c, c1
                sp, s = s, s1
                g = g1
        flag = bad_in or not np.all(np.isfinite(x))
        return Result(x.astype(f32), bool(flag))


def minres64(K: np.ndarray, b: np.ndarray, imax: int) -> np.ndarray:
    """The same MINRES in float64 (reference for convergence)."""
    b = np.asarray(b, dtype=float)
    N = len(b)
    z = np.zeros(N)
    g = np.linalg.norm(b)
    v, vprev = b / g, z.copy()
    w, wprev, x = z.copy(), z.copy(), z.copy()
    c = cp = 1.0
    s = sp = 0.0
    eta = g
    for _ in range(imax):
        y = K @ v
        delta = v @ y
        u = y - delta * v - g * vprev
        nrm2 = u @ u
        g1 = np.sqrt(nrm2)
        a0 = c * delta - cp * s * g
        a1 = np.sqrt(a0 * a0 + nrm2)
        a2 = s * delta + cp * c * g
        a3 = sp * g
        c1, s1 = a0 / a1, g1 / a1
        wnew = (v - a3 * wprev - a2 * w) / a1
        x = x + c1 * eta * wnew
        eta = -s1 * eta
        vprev, v = v, (u / g1 if g1 > 0 else z)
        wprev, w = w, wnew
        cp, c, sp, s, g = c, c1, s, s1, g1
        if g1 == 0:
            break
    return x
