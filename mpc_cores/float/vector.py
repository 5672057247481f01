"""Vectorised arithmetic on arrays of raw words of a floating-point Format (mpc_cores/float/model.py): add, sub,
mul, div and sqrt, correctly rounded to nearest even with subnormals, every NaN result the canonical quiet NaN, as
the float library's RTL and its scalar model. For golden models that run many operations (the MINRES core's).

Method: the operands are decoded exactly to float64, the operation runs in float64 (correctly rounded by the
CPU), and the float64 result is rounded to the format with integer bit operations (ties to even, gradual
underflow, overflow to infinity). The double rounding is innocuous for + - * / and sqrt when float64 has at least
2p + 2 significand bits for the format's p = manW + 1 (Figueroa's theorem: 53 >= 2p + 2, so manW <= 24), and
float64 must hold every exact operand, sum, product, quotient and root of the format without overflowing or
becoming subnormal where the format could still round to a nonzero value: expW <= 10. Formats outside these
bounds are refused (the scalar model covers them).

Words are numpy arrays of unsigned integers (any integer dtype is accepted; results are uint64). Flags are not
computed.
"""
from __future__ import annotations

import numpy as np

from mpc_cores.float.model import Format

MAX_MANW, MAX_EXPW = 24, 10
_U = np.uint64


def check(f: Format) -> Format:
    """`f` if float64 rounds its operations innocuously, else ValueError with the rule."""
    if f.manW > MAX_MANW or f.expW > MAX_EXPW:
        raise ValueError(f"float.vector: needs manW <= {MAX_MANW} (53 >= 2p + 2) and expW <= {MAX_EXPW} (float64 "
                         f"range): got expW={f.expW}, manW={f.manW}")
    return f


def decode(f: Format, w) -> np.ndarray:
    """Raw words -> their exact float64 values (infinities and NaN included)."""
    check(f)
    w = np.asarray(w).astype(_U)
    sign = (w >> _U(f.width - 1)) & _U(1)
    e = ((w >> _U(f.manW)) & _U(f.emax_field)).astype(np.int64)
    m = (w & _U((1 << f.manW) - 1)).astype(np.float64)
    sub = e == 0
    sig = np.where(sub, m, m + float(1 << f.manW))
    exp = np.where(sub, 1 - f.bias - f.manW, e - f.bias - f.manW)
    v = np.ldexp(sig, exp)
    v = np.where(e == f.emax_field, np.where(m == 0, np.inf, np.nan), v)
    return np.where(sign == 1, -v, v)


def encode(f: Format, x) -> np.ndarray:
    """float64 values -> words of the format, rounded to nearest even (subnormals, overflow to infinity, NaN as
    the canonical quiet NaN, signs of zeros kept)."""
    check(f)
    x = np.asarray(x, dtype=np.float64)
    b = x.view(_U) if x.ndim else np.array([x]).view(_U)
    sign = b >> _U(63)
    e64 = ((b >> _U(52)) & _U(0x7FF)).astype(np.int64)
    m = (b & _U((1 << 52) - 1)) | _U(1 << 52)
    E = e64 - 1023                                   # unbiased exponent of the leading bit
    emin = 1 - f.bias                                # the format's smallest normal exponent
    # bits of the 53-bit significand below the format's last kept bit: more below its normal range
    sh = (52 - f.manW) + np.maximum(emin - E, 0)
    sh = np.minimum(sh, 60).astype(_U)               # beyond 54 everything is below half an ulp anyway
    kept = m >> sh
    rem = m & ((_U(1) << sh) - _U(1))
    half = _U(1) << (sh - _U(1))
    up = (rem > half) | ((rem == half) & ((kept & _U(1)) == _U(1)))
    kept = kept + up.astype(_U)
    normal = E >= emin
    # normal: field from the exponent, a rounding carry to 2^(manW+1) moves into it; subnormal: kept <= 2^manW
    # packs as it is (2^manW being the smallest normal)
    carry = normal & ((kept >> _U(f.manW + 1)) == _U(1))
    kept = np.where(carry, kept >> _U(1), kept)
    field = np.where(normal, E + f.bias + carry, 0)
    mag = np.where(normal, (np.maximum(field, 0).astype(_U) << _U(f.manW)) | (kept & _U((1 << f.manW) - 1)), kept)
    inf = _U(f.emax_field << f.manW)
    mag = np.where(normal & (field >= f.emax_field), inf, mag)
    mag = np.where(e64 == 0, _U(0), mag)             # float64 zeros and subnormals: far below the format's range
    mag = np.where(e64 == 0x7FF, inf, mag)
    out = (sign << _U(f.width - 1)) | mag
    out = np.where(np.isnan(x.reshape(b.shape)), _U(f.qnan), out)
    return out.reshape(x.shape)


def _op(f: Format, fn, *ws) -> np.ndarray:
    with np.errstate(all="ignore"):
        return encode(f, fn(*(decode(f, w) for w in ws)))


def add(f: Format, a, b) -> np.ndarray:
    return _op(f, np.add, a, b)


def sub(f: Format, a, b) -> np.ndarray:
    return _op(f, np.subtract, a, b)


def mul(f: Format, a, b) -> np.ndarray:
    return _op(f, np.multiply, a, b)


def div(f: Format, a, b) -> np.ndarray:
    return _op(f, np.divide, a, b)


def sqrt(f: Format, a) -> np.ndarray:
    return _op(f, np.sqrt, a)


def neg(f: Format, a) -> np.ndarray:
    """Sign flip (exact; a NaN stays a NaN word with the sign flipped, as the RTL's bit flip)."""
    return np.asarray(a).astype(_U) ^ _U(f.sign_bit)


def is_finite(f: Format, w) -> np.ndarray:
    return ((np.asarray(w).astype(_U) >> _U(f.manW)) & _U(f.emax_field)) != _U(f.emax_field)
