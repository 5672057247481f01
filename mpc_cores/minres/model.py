"""MINRES (Paige and Saunders, in the form of Elman, Silvester and Wathen, Alg. 2.4) on the banded KKT system:
a float64 reference and the bit-exact model of the core in its float format.

The bit-exact model performs the core's operations in the core's format and order, so that the RTL matches it
word for word. binary32 runs on numpy float32 (correctly rounded to nearest even with gradual underflow, as the
float library; tests/test_float_vector.py checks float32 against mpc_cores.float.vector word for word); any other
format e<E>m<M> runs on raw words with mpc_cores.float.vector. NaN results are compared by NaN-ness and the core
returns the canonical quiet NaN (0x7FC00000 in binary32).

Operation order (x_0 = 0; one "init" pass, then Imax iterations j = 1..Imax):

    init:   u = (b - 0*0) - 0*0;  nrm2 = acc(u*u);  g' = sqrt(nrm2);  v_1 = u / g'
            state: c = c_prev = 1, s = s_prev = 0, g = g', eta = g'
    iter j: y_i = tree(coef_i,s * v_(i+o_s))            matvec: the K slots of the row's key (band.py), pairwise tree
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

from dataclasses import dataclass, field

import numpy as np

from mpc_cores.float import vector as fv
from mpc_cores.float.model import Format
from mpc_cores.minres.band import band_patterns
from mpc_cores.minres.kkt import Layout

f32 = np.float32
QNAN32 = 0x7FC00000
BINARY32 = Format(8, 23)
TABLE_ID_BITS = 7   # the id bits that choose a problem's coefficient table (MinresParams.TableIdBits)


class F32Ops:
    """binary32 arithmetic on numpy float32 values (the fast path; the same words as mpc_cores.float.vector)."""
    fmt = BINARY32
    zero, one = f32(0.0), f32(1.0)

    def value(self, x):
        """float values (any type) rounded to the format"""
        return np.asarray(x, dtype=f32)

    def from_words(self, ws):
        return np.asarray([int(w) & 0xFFFFFFFF for w in np.ravel(ws)], dtype=np.uint32).view(f32)

    def words(self, x) -> list[int]:
        return words(x)

    def to_float(self, x):
        return np.asarray(x, dtype=f32)

    def finite(self, x) -> bool:
        return bool(np.all(np.isfinite(x)))

    def zeros(self, shape):
        return np.zeros(shape, dtype=f32)

    add = staticmethod(np.add)
    sub = staticmethod(np.subtract)
    mul = staticmethod(np.multiply)
    div = staticmethod(np.divide)
    sqrt = staticmethod(np.sqrt)
    neg = staticmethod(np.negative)


class WordOps:
    """Arithmetic of any format on raw words (uint64 arrays) with mpc_cores.float.vector."""

    def __init__(self, fmt: Format):
        self.fmt = fv.check(fmt)
        self.zero = np.uint64(0)
        self.one = np.uint64(fmt.bias << fmt.manW)

    def value(self, x):
        return fv.encode(self.fmt, np.asarray(x, dtype=np.float64))

    def from_words(self, ws):
        return np.asarray([int(w) & ((1 << self.fmt.width) - 1) for w in np.ravel(ws)], dtype=np.uint64)

    def words(self, x) -> list[int]:
        x = np.ravel(np.asarray(x, dtype=np.uint64))
        return [self.fmt.qnan if self.fmt.is_nan(int(w)) else int(w) for w in x]

    def to_float(self, x):
        return fv.decode(self.fmt, x)

    def finite(self, x) -> bool:
        return bool(np.all(fv.is_finite(self.fmt, x)))

    def zeros(self, shape):
        return np.zeros(shape, dtype=np.uint64)

    def add(self, a, b):
        return fv.add(self.fmt, a, b)

    def sub(self, a, b):
        return fv.sub(self.fmt, a, b)

    def mul(self, a, b):
        return fv.mul(self.fmt, a, b)

    def div(self, a, b):
        return fv.div(self.fmt, a, b)

    def sqrt(self, a):
        return fv.sqrt(self.fmt, a)

    def neg(self, a):
        return fv.neg(self.fmt, a)


def ops_for(fmt: Format | None):
    """The arithmetic of a format: numpy float32 for binary32, raw words otherwise."""
    return F32Ops() if fmt in (None, BINARY32) else WordOps(fmt)


def tree(terms: np.ndarray, ops=None) -> np.ndarray:
    """Pairwise reduction over the last axis in the order of DotProductTree: pairs (0,1), (2,3), ... of a level
    (one vector operation per level), an odd last element passed on."""
    add = (ops or F32Ops()).add
    level = np.asarray(terms)
    with np.errstate(all="ignore"):
        while level.shape[-1] > 1:
            k = level.shape[-1] // 2
            nxt = add(level[..., 0:2 * k:2], level[..., 1:2 * k:2])
            if level.shape[-1] % 2:
                nxt = np.concatenate([nxt, level[..., -1:]], axis=-1)
            level = nxt
    return level[..., 0]


def acc(terms: np.ndarray, L: int, ops=None):
    """The core's streaming sum of `terms` (values of the format, in stream order) with L partial sums: term k goes
    into partial k mod L (the first L onto +0), rounds of L terms at a time."""
    ops = ops or F32Ops()
    n = len(terms)
    assert n > L, f"the accumulator needs more than L={L} terms, got {n}"
    part = ops.zeros(L)
    with np.errstate(all="ignore"):
        for r in range(0, n, L):
            chunk = terms[r:r + L]
            part[:len(chunk)] = ops.add(chunk, part[:len(chunk)])
        order = [(n - L + q) % L for q in range(L)]
        return tree(part[order][None, :], ops)[0] if L > 1 else part[0]


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
    x: np.ndarray     # the solution's values (float32 in binary32, float64 otherwise)
    flag: bool        # a non-finite input word or a non-finite solution
    words: list = field(default_factory=list)  # the solution as the core sends it (raw words of the format)


def format_of(cfg: dict) -> Format:
    """The float format of a config.json / core.json (binary32 when absent)."""
    return Format(int(cfg.get("exp_width", 8)), int(cfg.get("man_width", 23)))


class MinresCoreModel:
    """Bit-exact model of the core for one problem size and float format (default binary32). `rom`: the constant
    columns (kkt.const_rom), any float type (rounded to the format here, as the design flow does). `tables`:
    several such ROMs of the same layout (MinresDesign.tables; `rom` is the first), a problem multiplying by table
    `table_of(id)` of its id word: `table` of band, matrix, solve and solve_warm chooses one."""

    @classmethod
    def from_config(cls, cfg: dict) -> "MinresCoreModel":
        """The model of a generated core, from its config.json (the ROM as raw words of the format)."""
        n, m, T = int(cfg["n"]), int(cfg["m"]), int(cfg["T"])
        ops = ops_for(format_of(cfg))
        shape = (2 * n + m, Layout(n, m, T).M - 1)
        roms = [ops.to_float(ops.from_words(r)).reshape(shape) for r in cfg.get("roms", [cfg["rom"]])]
        return cls(n, m, T, roms[0], int(cfg["lat_add"]), format_of(cfg), tables=roms)

    def __init__(self, n: int, m: int, T: int, rom: np.ndarray, lat_add: int, fmt: Format | None = None,
                 tables=None):
        self.ops = o = ops_for(fmt)
        self.fmt = o.fmt
        self.L = Layout(n, m, T)
        self.n, self.m, self.T = n, m, T
        self.N, self.M = self.L.N, self.L.M
        self.lat_add = lat_add
        roms = [o.value(r) for r in (tables if tables is not None and len(tables) else [rom])]
        self.rom = roms[0]
        assert all(r.shape == (2 * n + m, self.M - 1) for r in roms)
        # the sparse rows (mpc_cores.minres.band): per row i and slot s the column, whether the product is taken,
        # the constant coefficient (per table) and whether it is the variable diagonal
        pats = band_patterns(n, m, T, [o.to_float(r) for r in roms])
        self.pattern = pats[0]
        self.cols, self.inrange, _, isdiag = self.pattern.rows()
        self.coefs = [o.value(pat.rows()[2]) for pat in pats]
        pos = np.full(self.N, -1, dtype=np.int64)
        self.primal = self.L.primal_rows()
        pos[self.primal] = np.arange(len(self.primal))
        self.diag_rows, self.diag_slots = np.nonzero(isdiag)
        self.diag_pos = pos[self.diag_rows]

    def table_of(self, pid: int) -> int:
        """The table of a problem with id word `pid` (MinresParams.tableIdBits): (id mod 2^7) mod tables."""
        return (int(pid) % (1 << TABLE_ID_BITS)) % len(self.coefs)

    def to_words(self, x) -> list[int]:
        """float values rounded to the format, as raw words (what the testbench sends)."""
        return self.ops.words(self.ops.value(x))

    def band(self, diag: np.ndarray, table: int = 0) -> np.ndarray:
        """N x K coefficients of every row's slots (mpc_cores.minres.band), +0 where no product is taken, in the
        arithmetic's representation (float32 values or raw words); `diag`: float values of the variable column."""
        return self._band(self.ops.value(diag), table)

    def _band(self, diag, table: int = 0) -> np.ndarray:
        B = self.coefs[table].copy()
        B[self.diag_rows, self.diag_slots] = diag[self.diag_pos]
        B[~self.inrange] = self.ops.zero
        return B

    def matvec(self, band: np.ndarray, v: np.ndarray) -> np.ndarray:
        o = self.ops
        win = np.where(self.inrange, v[self.cols], o.zero).astype(band.dtype)
        with np.errstate(all="ignore"):
            return tree(o.mul(band, win), o)

    def matrix(self, diag, table: int = 0) -> np.ndarray:
        """The matrix the core multiplies by, in float64 (its entries are values of the format)."""
        N = self.N
        K = np.zeros((N, N))
        B = np.asarray(self.ops.to_float(self.band(diag, table)), dtype=float)
        rows = np.repeat(np.arange(N)[:, None], self.pattern.K, axis=1)
        K[rows[self.inrange], self.cols[self.inrange]] = B[self.inrange]
        return K

    def solve(self, diag, b, imax: int, table: int = 0) -> Result:
        o = self.ops
        diag = o.value(diag)
        b = o.value(b)
        bad_in = not (o.finite(diag) and o.finite(b))
        z = o.zeros(self.N)
        with np.errstate(all="ignore"):
            band = self._band(diag, table)
            u = o.sub(o.sub(b, o.mul(z, z)), o.mul(z, z))   # the init pass: r_0 = b - A x_0 with x_0 = 0
            x, _ = self.iterate(band, u, imax)
        flag = bad_in or not o.finite(x)
        return Result(o.to_float(x), bool(flag), o.words(x))

    def solve_warm(self, diag, d, b, z0, imax: int, table: int = 0) -> tuple[Result, float]:
        """The interior-point core's form (MinresParams warm): MINRES on (D A D) y = b from y_0 = D^-1 z0, D =
        diag(d), so that its init pass forms r_0 = b - d (A z0); returns the solution x = y - y_0 (flagged as
        `solve`) and ||r_0|| (the word the core sends after x)."""
        o = self.ops
        diag, d, b, z0 = (o.value(v) for v in (diag, d, b, z0))
        bad_in = not all(o.finite(v) for v in (diag, d, b, z0))
        with np.errstate(all="ignore"):
            band = self._band(diag, table)
            u = o.sub(b, o.mul(d, self.matvec(band, z0)))
            x, res = self.iterate(band, u, imax, scale=d)
        flag = bad_in or not o.finite(x)
        return Result(o.to_float(x), bool(flag), o.words(x)), res

    def iterate(self, band, u, imax: int, scale=None):
        """MINRES from the initial residual u (x_0 = 0 in the returned x): the init norm and v_1, then imax
        iterations. `scale` (d, or None): the matrix is D A D, the streamed vector scaled by d before the band and
        each row's product by d_i after it (the interior-point core's equilibration), delta = (d v) . (A d v).
        Returns (x, ||u||)."""
        o = self.ops
        add, sub, mul, div, sqrt = o.add, o.sub, o.mul, o.div, o.sqrt
        L = self.lat_add
        z = o.zeros(self.N)
        with np.errstate(all="ignore"):
            nrm2 = acc(mul(u, u), L, o)
            g = sqrt(nrm2)
            res = g
            v = div(u, g)
            vprev = z.copy()
            w, wprev = z.copy(), z.copy()
            x = z.copy()
            c = cp = o.one
            s = sp = o.zero
            eta = g
            for j in range(1, imax + 1):
                if scale is None:
                    y = self.matvec(band, v)
                    delta = acc(mul(v, y), L, o)
                else:                       # delta = v . (D A D v) as (D v) . (A D v), the feed's words
                    sv = mul(scale, v)
                    ay = self.matvec(band, sv)
                    y = mul(scale, ay)
                    delta = acc(mul(sv, ay), L, o)
                u = sub(sub(y, mul(delta, v)), mul(g, vprev if j > 1 else z))
                nrm2 = acc(mul(u, u), L, o)
                g1 = sqrt(nrm2)
                a0 = sub(mul(c, delta), mul(mul(cp, s), g))
                a1 = sqrt(add(mul(a0, a0), nrm2))
                a2 = add(mul(s, delta), mul(mul(cp, c), g))
                a3 = mul(sp, g)
                c1 = div(a0, a1)
                s1 = div(g1, a1)
                ceta = mul(c1, eta)
                eta = o.neg(mul(s1, eta))
                vnew = div(u, g1)
                wm1 = wprev if j > 2 else z
                wj = w if j > 1 else z
                wnew = div(sub(sub(v, mul(a3, wm1)), mul(a2, wj)), a1)
                x = add(x if j > 1 else z, mul(ceta, wnew))
                vprev, v = v, vnew
                wprev, w = w, wnew
                cp, c = c, c1
                sp, s = s, s1
                g = g1
        return x, res


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
