"""Operand vectors for the floating-point operators: random mixes that make cancellations, ties, overflow and
underflow frequent, an explicit edge-case list, and the numpy reference for binary32 (float32) and binary16
(float16; numpy computes those in float32 and rounds once more, which is exact for +, -, *, /, sqrt since
24 >= 2 * 11 + 2)."""
from __future__ import annotations

import numpy as np

from mpc_cores.float import model
from mpc_cores.float.model import Format
from verif.float import corners

NUMPY_TYPES = {(8, 23): (np.float32, np.uint32), (5, 10): (np.float16, np.uint16)}


def enc(f: Format, m: int, e: int, sign: int = 0) -> int:
    """m * 2^e (must be exact in the format) as bits."""
    bits, flags = model.round_pack(f, sign, m, e)
    assert flags == 0, f"{m} * 2^{e} is not exact in {f}"
    return bits


def edge_values(f: Format) -> list[int]:
    """Zeros, subnormals, normals at both ends, infinities, NaNs and values around 1, both signs."""
    m = f.manW
    one = f.bias << m
    pos = [
        0, 1, 2, 3, (1 << m) - 1, 1 << (m - 1),                        # zero, subnormals
        1 << m, (1 << m) + 1, (2 << m) - 1,                            # smallest normals
        f.inf(0) - 1, f.inf(0) - 2, (f.emax_field - 1) << m,           # largest normals
        one, one + 1, one - 1, one + (1 << (m - 1)), one + (1 << m),   # 1, 1+ulp, 1-ulp/2, 1.5, 2
        one - (1 << m), one - (1 << m) + (1 << (m - 1)) + 1,           # 0.5, ~0.75
        f.inf(0), f.qnan, f.qnan | 1, f.inf(0) | 1,                    # inf, quiet NaNs, signalling NaN
    ]
    return sorted({v for p in pos for v in (p, p | f.sign_bit)})


def tie_pairs(f: Format) -> list[tuple[int, int]]:
    """Operand pairs whose exact result lies halfway between two neighbours (or sits on a boundary)."""
    m, b = f.manW, f.bias
    one = enc(f, 1, 0)
    half_ulp = enc(f, 1, -(m + 1))
    one_ulp = enc(f, (1 << m) + 1, -m)
    maxn = f.inf(0) - 1
    half_ulp_max = enc(f, 1, f.emax_field - 1 - b - m - 1)
    onehalf = enc(f, 3, -1)
    one_plus = enc(f, (1 << m) + 1, -m)
    half = enc(f, 1, -1)
    return [
        (one, half_ulp), (one_ulp, half_ulp), (maxn, half_ulp_max),    # add: to even (down), to even (up), overflow
        (one, one_ulp), (one ^ f.sign_bit, one_ulp), (maxn, maxn),
        (onehalf, one_plus),                                           # mul: 1.5 * (1 + ulp) is a tie
        (1, half), (3, half), (5, half), ((1 << m) | 1, half),         # mul: halving subnormals (ties)
        (1, enc(f, 1, 1)), (3, enc(f, 1, 1)), (maxn, half),            # div by 2 (ties), overflow by / 0.5
        (1 << m, enc(f, 1, 2)), (enc(f, 1, 0), enc(f, 3, 0)),
    ]


def _rand_bits(rng: np.random.Generator, n: int, width: int) -> np.ndarray:
    hi = rng.integers(0, 1 << 32, n, dtype=np.uint64)
    lo = rng.integers(0, 1 << 32, n, dtype=np.uint64)
    v = (hi << np.uint64(32)) | lo
    return v & np.uint64((1 << width) - 1) if width < 64 else v


def random_operands(f: Format, op: str, n: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """n random (a, b, opbit) as uint64: 25 % uniform bit patterns, 30 % exponents within manW+3 of each
    other with truncated mantissas (cancellation, ties), 15 % near-cancellation (b within a few ulps of a),
    15 % short mantissas (exact products, ties), 15 % exponents at the ends of the range (overflow, subnormal
    results)."""
    rng = np.random.default_rng(seed)
    m, E = f.manW, f.emax_field
    u64 = np.uint64
    a = _rand_bits(rng, n, f.width)
    b = _rand_bits(rng, n, f.width)
    grp = rng.choice(5, size=n, p=[0.25, 0.30, 0.15, 0.15, 0.15])
    sgn = lambda k: rng.integers(0, 2, k, dtype=np.uint64) << u64(f.width - 1)  # noqa: E731
    man = lambda k: _rand_bits(rng, k, m)  # noqa: E731

    def trunc(x):  # clear a random number of low mantissa bits
        t = rng.integers(0, m + 1, x.size, dtype=np.uint64)
        return (x >> t) << t

    # close exponents
    i = np.flatnonzero(grp == 1)
    ea = rng.integers(0, E, i.size)
    eb = np.clip(ea + rng.integers(-(m + 3), m + 4, i.size), 0, E - 1)
    a[i] = sgn(i.size) | (ea.astype(u64) << u64(m)) | trunc(man(i.size))
    b[i] = sgn(i.size) | (eb.astype(u64) << u64(m)) | trunc(man(i.size))
    # near cancellation: b = +-(a + d ulps)
    i = np.flatnonzero(grp == 2)
    ea = rng.integers(0, E, i.size)
    a[i] = sgn(i.size) | (ea.astype(u64) << u64(m)) | man(i.size)
    d = rng.integers(-4, 5, i.size)
    mag = np.clip((a[i] & u64((1 << (f.width - 1)) - 1)).astype(np.int64) + d, 0, (E << m) - 1).astype(u64)
    b[i] = sgn(i.size) | mag
    # short mantissas, moderate exponents
    i = np.flatnonzero(grp == 3)
    for x in (a, b):
        k = rng.integers(0, max(1, m // 2) + 1, i.size).astype(u64)
        e = np.clip(f.bias + rng.integers(-2 * m - 4, 2 * m + 5, i.size), 0, E - 1).astype(u64)
        x[i] = sgn(i.size) | (e << u64(m)) | ((man(i.size) >> (u64(m) - k)) << (u64(m) - k))
    # ends of the range; b near 1 or at either end
    i = np.flatnonzero(grp == 4)
    band = min(m + 3, E // 2)
    low = rng.integers(0, band, i.size)
    high = E - 1 - rng.integers(0, band, i.size)
    ea = np.where(rng.integers(0, 2, i.size) == 1, low, high)
    a[i] = sgn(i.size) | (ea.astype(u64) << u64(m)) | trunc(man(i.size))
    eb = np.where(rng.integers(0, 2, i.size) == 1,
                  np.clip(f.bias + rng.integers(-(m + 2), m + 3, i.size), 0, E - 1),
                  np.where(rng.integers(0, 2, i.size) == 1, low, high))
    b[i] = sgn(i.size) | (eb.astype(u64) << u64(m)) | trunc(man(i.size))
    opbit = rng.integers(0, 2, n, dtype=np.uint64)
    if op == "div":
        # small a over a power of two: exact quotients shifted into the subnormal range (ties there)
        i = np.flatnonzero(rng.random(n) < 0.05)
        ea = rng.integers(1, min(m + 4, E - 1), i.size).astype(u64)
        a[i] = sgn(i.size) | (ea << u64(m)) | trunc(man(i.size))
        eb = np.clip(f.bias + rng.integers(1, m + 4, i.size), 0, E - 1).astype(u64)
        b[i] = sgn(i.size) | (eb << u64(m))
    if op == "sqrt":
        # mostly nonnegative operands (a negative one only tests the NaN path)
        a &= np.where(rng.random(n) < 0.9, np.uint64(f.sign_bit - 1), ~np.uint64(0))
        # squares of short integers at random even exponents: exact roots
        k = max(1, (m + 1) // 2)
        lo, hi = -(f.bias // 2), f.bias // 2 - k
        for j in np.flatnonzero(rng.random(n) < 0.05) if hi > lo else []:
            r = int(rng.integers(1, 1 << k))
            a[j] = enc(f, r * r, 2 * int(rng.integers(lo, hi)))
    return a, b, opbit


def edge_operands(f: Format, op: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every pair of edge values with both op bits, then the tie pairs (both orders, both op bits); for
    multiply also the directed corners of verif/float/corners.py (both orders, the second negative)."""
    ev = edge_values(f)
    pairs = [(x, y) for x in ev for y in ev]
    pairs += [p for x, y in tie_pairs(f) for p in ((x, y), (y, x))]
    if op == "mul":
        pairs += [p for x, y in corners.mul_pairs(f) for p in ((x, y), (y | f.sign_bit, x))]
    if op == "sqrt":
        pairs = [(x, 0) for x in ev] + [(enc(f, r * r, 2 * j), 0) for r in range(1, 16) for j in (-4, 0, 3)]
        pairs += [(x, 0) for x, _ in tie_pairs(f)]
    a = np.array([p[0] for p in pairs] * 2, dtype=np.uint64)
    b = np.array([p[1] for p in pairs] * 2, dtype=np.uint64)
    opbit = np.array([0] * len(pairs) + [1] * len(pairs), dtype=np.uint64)
    return a, b, opbit


def model_results(f: Format, op: str, a, b, opbit) -> tuple[np.ndarray, np.ndarray]:
    out = np.empty(len(a), dtype=np.uint64)
    flg = np.empty(len(a), dtype=np.uint64)
    ev = model.evaluate
    for j, (x, y, o) in enumerate(zip(a.tolist(), b.tolist(), opbit.tolist())):
        out[j], flg[j] = ev(op, f, x, y, o)
    return out, flg


def numpy_results(f: Format, op: str, a, b, opbit) -> np.ndarray:
    """numpy's results as bits (cmp: [0] lt, [1] eq, [2] le, [3] unordered) for binary32 / binary16."""
    ft, ut = NUMPY_TYPES[(f.expW, f.manW)]
    x = a.astype(ut).view(ft)
    y = b.astype(ut).view(ft)
    with np.errstate(all="ignore"):
        if op == "add":
            r = np.where(opbit == 1, x - y, x + y)
        elif op == "mul":
            r = x * y
        elif op == "div":
            r = x / y
        elif op == "sqrt":
            r = np.sqrt(x)
        elif op == "cmp":
            return ((x < y).astype(np.uint64) | ((x == y).astype(np.uint64) << np.uint64(1))
                    | ((x <= y).astype(np.uint64) << np.uint64(2))
                    | ((np.isnan(x) | np.isnan(y)).astype(np.uint64) << np.uint64(3)))
        else:
            raise ValueError(op)
    return r.astype(ft).view(ut).astype(np.uint64)


def mismatches_vs_numpy(f: Format, op: str, a, b, opbit, out) -> np.ndarray:
    """Indices where `out` differs from numpy: bits exactly, except NaN results compared by NaN-ness only
    (numpy keeps payloads, the operators return the canonical NaN)."""
    ref = numpy_results(f, op, a, b, opbit)
    if op == "cmp":
        return np.flatnonzero(ref != out)
    nan = lambda v: (((v >> np.uint64(f.manW)) & np.uint64(f.emax_field)) == f.emax_field) & \
        ((v & np.uint64((1 << f.manW) - 1)) != 0)  # noqa: E731
    bad = (ref != out) & ~(nan(ref) & nan(out))
    return np.flatnonzero(bad)
