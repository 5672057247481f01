"""mpc_cores/float/vector.py (vectorised arithmetic on raw words) word for word against the scalar model
mpc_cores/float/model.py and, for binary32, numpy float32: random words, random values across the exponent range
and edge cases (exact ties, subnormal results, overflow, NaN, infinities, signed zeros)."""
from __future__ import annotations

import zlib

import numpy as np
import pytest

from mpc_cores.float import model as sm
from mpc_cores.float import vector as vm
from mpc_cores.float.model import Format

FORMATS = {"binary32": Format(8, 23), "e8m17": Format(8, 17), "binary16": Format(5, 10)}
RANDOM = 3000


def specials(f: Format) -> list[int]:
    one = f.bias << f.manW
    top = (f.emax_field - 1) << f.manW | ((1 << f.manW) - 1)
    vals = [0, 1, 2, 3, (1 << f.manW) - 1, 1 << f.manW, (1 << f.manW) + 1, one, one + 1, one - 1, top, top - 1,
            f.emax_field << f.manW, f.qnan, (f.emax_field << f.manW) | 1, 2 << f.manW, (f.bias + 1) << f.manW]
    return vals + [v | f.sign_bit for v in vals]


def random_words(f: Format, rng, n: int) -> np.ndarray:
    """A third uniformly random bit patterns, a third of small exponents (subnormal and near results), a third of
    exponents near the bias (ordinary values, cancellations)."""
    k = n // 3
    raw = rng.integers(0, 1 << f.width, n, dtype=np.uint64)
    man = rng.integers(0, 1 << f.manW, n, dtype=np.uint64)
    sgn = rng.integers(0, 2, n, dtype=np.uint64) << np.uint64(f.width - 1)
    e_small = rng.integers(0, 4, n, dtype=np.uint64)
    e_mid = rng.integers(f.bias - 3, f.bias + 4, n, dtype=np.uint64)
    out = raw.copy()
    out[k:2 * k] = (sgn | (e_small << np.uint64(f.manW)) | man)[k:2 * k]
    out[2 * k:] = (sgn | (e_mid << np.uint64(f.manW)) | man)[2 * k:]
    return out


def tie_pairs(f: Format, rng, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Exact results halfway between two neighbours of the format. First half, sums: b is half an ulp of a (same
    sign). Second half, products: 1.5 2^i times (1 + k 2^-manW) 2^j with k odd is 1.5 + 1.5 k 2^-manW (times
    2^(i+j)), half an ulp above a neighbour (division and square root have no exact ties)."""
    e = rng.integers(f.manW + 2, f.emax_field - 1, n, dtype=np.uint64)
    man = rng.integers(0, 1 << f.manW, n, dtype=np.uint64)
    a = (e << np.uint64(f.manW)) | man
    b = (e - np.uint64(f.manW + 1)) << np.uint64(f.manW)
    h = n // 2
    ei = rng.integers(f.bias - 5, f.bias + 5, (2, n - h), dtype=np.uint64)
    odd = rng.integers(0, 1 << max(f.manW - 1, 0), n - h, dtype=np.uint64) * np.uint64(2) + np.uint64(1)
    a[h:] = (ei[0] << np.uint64(f.manW)) | np.uint64(1 << (f.manW - 1))
    b[h:] = (ei[1] << np.uint64(f.manW)) | odd
    return a, b


def operands(f: Format, seed: int):
    rng = np.random.default_rng(seed)
    a, b = random_words(f, rng, RANDOM), random_words(f, rng, RANDOM)
    ta, tb = tie_pairs(f, rng, 200)
    sp = np.array(specials(f), dtype=np.uint64)
    ea, eb = np.meshgrid(sp, sp)
    # products near the overflow and underflow thresholds
    hi = rng.integers(f.emax_field - 4, f.emax_field, 200, dtype=np.uint64) << np.uint64(f.manW)
    hi |= rng.integers(0, 1 << f.manW, 200, dtype=np.uint64)
    A = np.concatenate([a, ta, ea.ravel(), hi, hi])
    B = np.concatenate([b, tb, eb.ravel(), hi[::-1], random_words(f, rng, 200)])
    return A, B


def scalar(op, f, A, B=None):
    if op == "sqrt":
        return np.array([sm.sqrt(f, int(x))[0] for x in A], dtype=np.uint64)
    fn = {"add": lambda x, y: sm.add(f, x, y), "sub": lambda x, y: sm.add(f, x, y, True),
          "mul": lambda x, y: sm.mul(f, x, y), "div": lambda x, y: sm.div(f, x, y)}[op]
    return np.array([fn(int(x), int(y))[0] for x, y in zip(A, B)], dtype=np.uint64)


@pytest.mark.parametrize("fname", list(FORMATS))
@pytest.mark.parametrize("op", ["add", "sub", "mul", "div", "sqrt"])
def test_vector_matches_scalar_model(fname, op):
    f = FORMATS[fname]
    A, B = operands(f, zlib.crc32(f"{fname} {op}".encode()))
    sm.COVERAGE.clear()
    sm.COVERAGE.update({"tie": 0, "tie_up": 0, "subnormal": 0, "overflow": 0, "exact": 0})
    want = scalar(op, f, A, B)
    got = vm.sqrt(f, A) if op == "sqrt" else getattr(vm, op)(f, A, B)
    bad = np.nonzero(got != want)[0]
    assert not len(bad), (f"{op} {fname}: {len(bad)} words differ, first a={int(A[bad[0]]):#x} b={int(B[bad[0]]):#x}: "
                          f"vector {int(got[bad[0]]):#x} model {int(want[bad[0]]):#x}")
    cov = sm.COVERAGE  # what the scalar model met while rounding these operands
    assert cov["exact"] > 0, cov
    if op != "sqrt":   # a root is never subnormal, never overflows
        assert cov["subnormal"] > 0 and cov["overflow"] > 0, cov
    if op in ("add", "sub", "mul"):
        assert cov["tie"] > 40 and 0 < cov["tie_up"] < cov["tie"], cov


def _f32(fn, *ws):
    with np.errstate(all="ignore"):
        r = fn(*(np.asarray(w, dtype=np.uint64).astype(np.uint32).view(np.float32) for w in ws))
    out = r.view(np.uint32).astype(np.uint64)
    return np.where(np.isnan(r), np.uint64(0x7FC00000), out)


@pytest.mark.parametrize("op", ["add", "sub", "mul", "div", "sqrt"])
def test_binary32_matches_numpy_float32(op):
    f = FORMATS["binary32"]
    A, B = operands(f, 99)
    rng = np.random.default_rng(5)
    A = np.concatenate([A, rng.integers(0, 1 << 32, 20000, dtype=np.uint64)])
    B = np.concatenate([B, rng.integers(0, 1 << 32, 20000, dtype=np.uint64)])
    fn = {"add": np.add, "sub": np.subtract, "mul": np.multiply, "div": np.divide, "sqrt": np.sqrt}[op]
    want = _f32(fn, A) if op == "sqrt" else _f32(fn, A, B)
    got = vm.sqrt(f, A) if op == "sqrt" else getattr(vm, op)(f, A, B)
    assert np.array_equal(got, want)


def test_encode_decode_round_trip_and_rounding():
    """Every binary16 word decodes and encodes back (NaNs to the canonical one); float64 values between two
    neighbours round to nearest even; overflow and signed zeros."""
    f = FORMATS["binary16"]
    w = np.arange(1 << 16, dtype=np.uint64)
    back = vm.encode(f, vm.decode(f, w))
    nan = np.array([f.is_nan(int(x)) for x in w])
    assert np.array_equal(back[~nan], w[~nan]) and np.all(back[nan] == f.qnan)
    assert np.array_equal(vm.encode(f, np.array([1 + 2 ** -11, 1 + 3 * 2 ** -11, 65520.0, 65519.99, -0.0, 2 ** -25,
                                                 2 ** -25 * 1.0001, 3 * 2 ** -25])),
                          np.array([0x3C00, 0x3C02, 0x7C00, 0x7BFF, 0x8000, 0x0000, 0x0001, 0x0002], dtype=np.uint64))
    assert np.array_equal(vm.encode(f, np.float16(np.arange(-3, 3, 0.37)).astype(float)),
                          np.float16(np.arange(-3, 3, 0.37)).view(np.uint16).astype(np.uint64))


def test_refused_formats():
    with pytest.raises(ValueError, match="manW <= 24"):
        vm.add(Format(11, 52), np.array([0]), np.array([0]))
    with pytest.raises(ValueError, match="expW <= 10"):
        vm.decode(Format(12, 10), np.array([0]))
