"""Bit-exact model of the floating-point operators of src/main/scala/float, for any (expW, manW) format.

Independent of the RTL's structure: every operation is computed exactly with Python integers (an exact sum or
product, or a quotient / square root with enough bits and a sticky remainder), then rounded once to nearest
even by `round_pack`. Policies, as in the RTL:

- subnormals supported (gradual underflow), as IEEE 754;
- every NaN result is the canonical quiet NaN (sign 0, exponent all ones, mantissa MSB 1, the rest 0);
- flags [0] invalid, [1] divByZero, [2] overflow, [3] underflow, [4] inexact; underflow = tiny before rounding
  and inexact; invalid for signalling NaN operands and for inf - inf, 0 * inf, 0/0, inf/inf, sqrt(x < 0);
- an exact zero sum is +0 unless both addends are -0 (or x - x with x = -0 - (+0)).
"""
from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from math import isqrt

INVALID, DIVZERO, OVERFLOW, UNDERFLOW, INEXACT = 1, 2, 4, 8, 16
FLAG_NAMES = ("invalid", "divByZero", "overflow", "underflow", "inexact")

# How often round_pack met each case (exact ties, subnormal results, overflow): the tests check that the
# random vectors reach them. Reset with COVERAGE.clear().
COVERAGE: dict[str, int] = {"tie": 0, "tie_up": 0, "subnormal": 0, "overflow": 0, "exact": 0}


@dataclass(frozen=True)
class Format:
    """Same rules as FloatFormat.scala."""
    expW: int = 8
    manW: int = 23

    def __post_init__(self):
        if not 2 <= self.expW <= 16:
            raise ValueError(f"FloatFormat: exponent width expW must be in [2, 16]: got expW={self.expW}")
        if not 1 <= self.manW <= 62:
            raise ValueError(f"FloatFormat: mantissa width manW must be in [1, 62]: got manW={self.manW}")
        if 1 + self.expW + self.manW > 64:
            raise ValueError(f"FloatFormat: 1 + expW + manW must be <= 64: got expW={self.expW}, manW={self.manW}")

    @property
    def width(self) -> int:
        return 1 + self.expW + self.manW

    @property
    def bias(self) -> int:
        return (1 << (self.expW - 1)) - 1

    @property
    def emax_field(self) -> int:
        return (1 << self.expW) - 1

    @property
    def qnan(self) -> int:
        return (self.emax_field << self.manW) | (1 << (self.manW - 1))

    @property
    def sign_bit(self) -> int:
        return 1 << (self.width - 1)

    def inf(self, sign: int) -> int:
        return (sign << (self.width - 1)) | (self.emax_field << self.manW)

    @property
    def tag(self) -> str:
        return f"e{self.expW}_m{self.manW}"

    # --- classification
    def fields(self, x: int) -> tuple[int, int, int]:
        return x >> (self.width - 1), (x >> self.manW) & self.emax_field, x & ((1 << self.manW) - 1)

    def is_nan(self, x: int) -> bool:
        _, e, m = self.fields(x)
        return e == self.emax_field and m != 0

    def is_snan(self, x: int) -> bool:
        _, e, m = self.fields(x)
        return e == self.emax_field and m != 0 and not (m >> (self.manW - 1)) & 1

    def is_inf(self, x: int) -> bool:
        _, e, m = self.fields(x)
        return e == self.emax_field and m == 0

    def is_zero(self, x: int) -> bool:
        return x & (self.sign_bit - 1) == 0

    def decode(self, x: int) -> tuple[int, int, int]:
        """Finite x as (sign, m, e) with |x| = m * 2^e exactly."""
        s, e, m = self.fields(x)
        if e == 0:
            return s, m, 1 - self.bias - self.manW
        return s, m | (1 << self.manW), e - self.bias - self.manW

    def to_fraction(self, x: int) -> Fraction:
        s, m, e = self.decode(x)
        v = Fraction(m) * (Fraction(2) ** e)
        return -v if s else v


def round_pack(f: Format, sign: int, m: int, e: int, sticky: bool = False) -> tuple[int, int]:
    """Round (m + delta) * 2^e, delta in (0, 1) if sticky else 0, to nearest even; return (bits, flags).
    Callers give at least two bits below the last kept one whenever sticky is set."""
    if m == 0:
        assert not sticky
        return sign << (f.width - 1), 0
    n = m.bit_length()
    biased = n - 1 + e + f.bias            # biased exponent of the leading bit
    tiny = biased < 1
    sh = n - (f.manW + 1) if not tiny else (1 - f.bias - f.manW) - e
    if sh > 0:
        kept, rem, half = m >> sh, m & ((1 << sh) - 1), 1 << (sh - 1)
        inexact = rem != 0 or sticky
        if rem == half and not sticky:
            COVERAGE["tie"] += 1
            COVERAGE["tie_up"] += kept & 1
        if rem > half or (rem == half and (sticky or kept & 1)):
            kept += 1
    else:
        assert not sticky, "round_pack: not enough bits below the result for a sticky bit"
        kept, inexact = m << -sh, False
    flags = INEXACT if inexact else 0
    COVERAGE["exact"] += not inexact
    if tiny:
        COVERAGE["subnormal"] += 1
        # kept <= 2^manW; kept == 2^manW is the smallest normal, which packs the same way
        bits = kept
        if inexact:
            flags |= UNDERFLOW
    else:
        field = biased
        if kept >> (f.manW + 1):
            kept >>= 1
            field += 1
        if field >= f.emax_field:
            COVERAGE["overflow"] += 1
            return f.inf(sign), OVERFLOW | INEXACT
        bits = (field << f.manW) | (kept & ((1 << f.manW) - 1))
    return (sign << (f.width - 1)) | bits, flags


def add(f: Format, a: int, b: int, sub: bool = False) -> tuple[int, int]:
    if sub:
        b ^= f.sign_bit
    inv = INVALID if f.is_snan(a) or f.is_snan(b) else 0
    if f.is_nan(a) or f.is_nan(b):
        return f.qnan, inv
    sa, sb = a >> (f.width - 1), b >> (f.width - 1)
    if f.is_inf(a) or f.is_inf(b):
        if f.is_inf(a) and f.is_inf(b) and sa != sb:
            return f.qnan, INVALID
        return (a if f.is_inf(a) else b), 0
    _, ma, ea = f.decode(a)
    _, mb, eb = f.decode(b)
    e = min(ea, eb)
    s = (-1) ** sa * (ma << (ea - e)) + (-1) ** sb * (mb << (eb - e))
    if s == 0:
        return (f.sign_bit if sa and sb else 0), 0
    return round_pack(f, int(s < 0), abs(s), e)


def mul(f: Format, a: int, b: int) -> tuple[int, int]:
    inv = INVALID if f.is_snan(a) or f.is_snan(b) else 0
    if f.is_nan(a) or f.is_nan(b):
        return f.qnan, inv
    s = (a ^ b) >> (f.width - 1)
    if f.is_inf(a) or f.is_inf(b):
        if f.is_zero(a) or f.is_zero(b):
            return f.qnan, INVALID
        return f.inf(s), 0
    _, ma, ea = f.decode(a)
    _, mb, eb = f.decode(b)
    return round_pack(f, s, ma * mb, ea + eb)


def div(f: Format, a: int, b: int) -> tuple[int, int]:
    inv = INVALID if f.is_snan(a) or f.is_snan(b) else 0
    if f.is_nan(a) or f.is_nan(b):
        return f.qnan, inv
    s = (a ^ b) >> (f.width - 1)
    za, zb, ia, ib = f.is_zero(a), f.is_zero(b), f.is_inf(a), f.is_inf(b)
    if (za and zb) or (ia and ib):
        return f.qnan, INVALID
    if ia:
        return f.inf(s), 0
    if ib or za:
        return s << (f.width - 1), 0
    if zb:
        return f.inf(s), DIVZERO
    _, ma, ea = f.decode(a)
    _, mb, eb = f.decode(b)
    k = f.manW + 5 + mb.bit_length() - ma.bit_length()   # quotient of >= manW + 4 bits
    q, r = divmod(ma << k, mb)
    return round_pack(f, s, q, ea - eb - k, r != 0)


def sqrt(f: Format, a: int) -> tuple[int, int]:
    if f.is_nan(a):
        return f.qnan, INVALID if f.is_snan(a) else 0
    s = a >> (f.width - 1)
    if f.is_zero(a):
        return a, 0
    if s:
        return f.qnan, INVALID
    if f.is_inf(a):
        return a, 0
    _, m, e = f.decode(a)
    if e & 1:
        m, e = m << 1, e - 1
    k = max(0, (2 * (f.manW + 4) - m.bit_length() + 1) // 2) + 1  # root of >= manW + 4 bits
    y = m << (2 * k)
    r = isqrt(y)
    return round_pack(f, 0, r, (e - 2 * k) // 2, r * r != y)


def compare(f: Format, a: int, b: int, signaling: bool = False) -> tuple[int, int]:
    """Returns ([0] lt, [1] eq, [2] le, [3] unordered; invalid flag)."""
    na, nb = f.is_nan(a), f.is_nan(b)
    if na or nb:
        inv = f.is_snan(a) or f.is_snan(b) or signaling
        return 8, INVALID if inv else 0

    def signed(x):  # exact value as (m, e) with sign folded into m; infinities beyond every finite value
        if f.is_inf(x):
            return (-1 if x >> (f.width - 1) else 1) << (f.emax_field + f.manW + 2), 0
        s, m, e = f.decode(x)
        return (-m if s else m), e + f.bias + f.manW  # e >= 0 now

    (ma, ea), (mb, eb) = signed(a), signed(b)
    va, vb = ma << ea, mb << eb
    lt, eq = va < vb, va == vb
    return int(lt) | int(eq) << 1 | int(lt or eq) << 2, 0


def evaluate(op: str, f: Format, a: int, b: int, opbit: int) -> tuple[int, int]:
    """(out, flags) as the FloatTop wrapper presents them."""
    if op == "add":
        return add(f, a, b, bool(opbit))
    if op == "mul":
        return mul(f, a, b)
    if op == "div":
        return div(f, a, b)
    if op == "sqrt":
        return sqrt(f, a)
    if op == "cmp":
        return compare(f, a, b, bool(opbit))
    raise ValueError(f"operator must be one of add, mul, div, sqrt, cmp: got '{op}'")
