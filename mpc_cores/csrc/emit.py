"""The C text the generated solvers share (mpc_cores/<kind>/c.py builds the rest).

Integer semantics are those of mpc_cores.fixed (and so of src/main/scala/fixed/FixedOps.scala): a product is rounded
back to b fraction bits by `shift_round` (truncate = floor, nearest = add half an LSB then floor), saturation clamps
to a signed width and raises a flag, and a dot product is the core's pairwise adder tree with every partial sum
saturated. Every value is held in int64_t. C99 leaves `>>` of a negative value implementation-defined and `<<` of
one undefined, so the helpers use neither: floor division by 2^s shifts p + 2^62 (non-negative, and a multiple of
2^s), multiplication by 2^k is a multiplication. That needs |p| < 2^62, which `check_headroom` proves from the
word widths before any text is written (a design outside it is refused).
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mpc_cores.errors import DesignError

# every intermediate value of the generated code stays below 2^HEADROOM_BITS in magnitude
HEADROOM_BITS = 61
INT32 = (-(1 << 31), (1 << 31) - 1)


@dataclass(frozen=True)
class Names:
    """The file stem and the C identifiers of one core's solvers."""
    module: str          # the core's module name, e.g. FgmCore_masses_n40_p1_b16
    p: str               # lower-case prefix of types and functions
    P: str               # upper-case prefix of macros

    @property
    def stem(self) -> str:
        return f"{self.module}_solver"


def names(module: str) -> Names:
    p = re.sub(r"[^0-9a-zA-Z_]", "_", module).lower()
    if not re.match(r"[a-z_]", p):
        p = "mpc_" + p
    return Names(module, p, p.upper())


# ----------------------------------------------------------------------------------------- data

def int_type(values) -> str:
    """int32_t when every value fits it, else int64_t."""
    a = np.asarray(values, dtype=np.int64)
    return "int32_t" if a.size == 0 or (a.min() >= INT32[0] and a.max() <= INT32[1]) else "int64_t"


def type_for_bits(bits: int) -> str:
    """The exact-width type that holds a signed word of `bits` bits."""
    return "int32_t" if int(bits) <= 32 else "int64_t"


def int_lit(v: int) -> str:
    """An integer literal of any int64 value (INT64_C: the type is at least 64 bits; the most negative value is
    written as an expression, a literal cannot be it)."""
    v = int(v)
    if v == -(1 << 63):
        return "(-INT64_C(9223372036854775807) - 1)"
    return f"INT64_C({v})" if not INT32[0] <= v <= INT32[1] else str(v)


def real_lit(v: float) -> str:
    """repr is the shortest decimal that reads back to the same double (C99 strtod rounds correctly)."""
    v = float(v)
    if not np.isfinite(v):
        raise DesignError(f"non-finite coefficient {v} in the float solver's data")
    s = repr(v)
    return s if any(c in s for c in ".e") else s + ".0"


def _body(values, lit, indent: str = "") -> str:
    a = np.asarray(values)
    if a.ndim > 1:
        inner = indent + "    "
        return "{\n" + ",\n".join(inner + _body(r, lit, inner) for r in a) + "\n" + indent + "}"
    items = [lit(x) for x in a.tolist()]
    if len(indent) + sum(len(i) + 2 for i in items) < 100:
        return "{" + ", ".join(items) + "}"
    lines, line = [], indent + "    "
    for it in items:
        if len(line) + len(it) + 2 > 116:
            lines.append(line.rstrip())
            line = indent + "    "
        line += it + ", "
    lines.append(line.rstrip().rstrip(","))
    return "{\n" + "\n".join(lines) + "\n" + indent + "}"


def array(name: str, values, real: bool = False, ctype: str | None = None) -> str:
    """`static const T name[R][C] = {...};` of a 1- or 2-dimensional array (an empty one gets one zero element:
    C has no zero-length arrays)."""
    a = np.asarray(values, dtype=float if real else np.int64)
    if a.size == 0:
        a = np.zeros((1,) * max(a.ndim, 1), dtype=a.dtype)
    t = ctype or ("mpc_real_t" if real else int_type(a))
    dims = "".join(f"[{d}]" for d in a.shape)
    return f"static const {t} {name}{dims} = {_body(a, real_lit if real else int_lit)};\n"


def width_macros(widths: dict, keys) -> str:
    """`#define W_<KEY>_LO/HI`: the range of a signed word of widths[key] bits."""
    out = []
    for k in keys:
        w = int(widths[k])
        out.append(f"#define W_{k.upper()}_LO ({int_lit(-(1 << (w - 1)))})\n#define W_{k.upper()}_HI "
                   f"{int_lit((1 << (w - 1)) - 1)}\n")
    return "".join(out)


def check_headroom(items: dict) -> None:
    """items: what -> bits of its largest magnitude; refuse the design when one reaches 2^HEADROOM_BITS."""
    bad = {k: v for k, v in items.items() if v > HEADROOM_BITS}
    if bad:
        raise DesignError("the C solver holds every intermediate value in int64_t below 2^"
                          f"{HEADROOM_BITS}: " + ", ".join(f"{k} needs {v} bits" for k, v in bad.items())
                          + " (reduce frac_bits or the word widths)")


def width_bits(widths: dict, key: str) -> int:
    """Bits of the magnitude of a signed word of widths[key] bits."""
    return int(widths[key]) - 1


# ----------------------------------------------------------------------------------------- integer helpers

_HELPERS = {
    "floor": """\
/* floor(p / 2^s), 0 <= s <= 62, exact for |p| < 2^62 without >> of a negative value (implementation-defined in
   C99): p + 2^62 is non-negative and a multiple of 2^s apart from p. */
#define MPC_BIAS (INT64_C(1) << 62)
static int64_t mpc_floor_shift(int64_t p, int s)
{
    return ((p + MPC_BIAS) >> s) - (MPC_BIAS >> s);
}
""",
    "rnd": {"truncate": """\
/* shift_round(p, s, truncate): p / 2^s rounded down (FixedOps.shiftRound) */
static int64_t mpc_rnd(int64_t p, int s)
{
    return mpc_floor_shift(p, s);
}
""", "nearest": """\
/* shift_round(p, s, nearest): add half an LSB, then round down (FixedOps.shiftRound) */
static int64_t mpc_rnd(int64_t p, int s)
{
    return s == 0 ? p : mpc_floor_shift(p + (INT64_C(1) << (s - 1)), s);
}
"""},
    "clip": """\
static int64_t mpc_clip(int64_t x, int64_t lo, int64_t hi)
{
    return x < lo ? lo : (x > hi ? hi : x);
}
""",
    "sat": """\
/* saturate to [lo, hi] (a signed word), raising *flag when it clamps */
static int64_t mpc_sat(int64_t x, int64_t lo, int64_t hi, uint8_t *flag)
{
    if (x < lo) {
        *flag = 1;
        return lo;
    }
    if (x > hi) {
        *flag = 1;
        return hi;
    }
    return x;
}
""",
    "shift_by": """\
/* a 2^k: a multiplication for k >= 0 (<< of a negative value is undefined in C99), rounded like a product for
   k < 0 (mpc_cores.admm.model.shift_by) */
static int64_t mpc_shift_by(int64_t a, int k)
{
    return k >= 0 ? a * (INT64_C(1) << k) : mpc_rnd(a, -k);
}
""",
    "dot": """\
/* One row of the core's matrix-vector product (mpc_cores.fixed.tree_sum): m operands, the columns from `cols` on
   zero; each product rounded by mpc_rnd(., FRAC_BITS) and saturated to [lo, hi], then summed pairwise (0,1),
   (2,3), ..., an odd last element passing on, every partial sum saturated. When the magnitudes of the products
   add up to at most hi no partial sum can saturate and the plain sum is the tree's; else the tree runs. */
static int64_t mpc_dot(const COEF_T *row, const int64_t *v, int cols, int m, int64_t lo, int64_t hi,
                       uint8_t *flag)
{
    int64_t buf[TREE_MAX], s = 0, a = 0;
    int j;
    for (j = 0; j < cols; j++) {
        int64_t p = mpc_sat(mpc_rnd((int64_t)row[j] * v[j], FRAC_BITS), lo, hi, flag);
        buf[j] = p;
        s += p;
        a += p < 0 ? -p : p;
    }
    if (a <= hi)
        return s;
    for (; j < m; j++)
        buf[j] = 0;
    while (m > 1) {
        int h = m / 2;
        for (j = 0; j < h; j++)
            buf[j] = mpc_sat(buf[2 * j] + buf[2 * j + 1], lo, hi, flag);
        if (m % 2)
            buf[h] = buf[m - 1];
        m = h + m % 2;
    }
    return buf[0];
}
""",
}


def helpers(rounding: str, *which: str) -> str:
    """The helpers named (floor, rnd, clip, sat, shift_by, dot), in dependency order; unused static functions would
    fail -Werror=unused-function, so a solver takes only those it calls. `dot` wants COEF_T, FRAC_BITS and
    TREE_MAX defined."""
    need = set(which)
    if "dot" in need:
        need |= {"sat", "rnd"}
    if need & {"rnd", "shift_by"}:
        need |= {"rnd", "floor"}
    out = []
    for k in ("floor", "rnd", "clip", "sat", "shift_by", "dot"):
        if k in need:
            h = _HELPERS[k]
            out.append(h[rounding] if isinstance(h, dict) else h)
    return "\n".join(out)


# ----------------------------------------------------------------------------------------- files

def write(out_dir, files: dict[str, str]) -> list[Path]:
    """Write name -> text into out_dir; the paths written."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, text in files.items():
        (out / name).write_text(text)
        paths.append(out / name)
    return paths
