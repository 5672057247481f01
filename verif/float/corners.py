"""Directed operand pairs for the multiplier's rounding path, and their classification.

The multiplier (src/main/scala/float/FMul.scala) normalises a subnormal operand before the product, keeps the
product's top manW + 3 bits and the OR of the rest, and then shifts right once: by 0 or 1 for a normal result,
by the distance below the normal range for a tiny one. Its corners are where those pieces meet: a subnormal
times a normal on both sides of the normal range, two subnormals, every shift distance, exact ties and ties
broken only by bits far below the guard bit, rounding up into the smallest normal, and the overflow boundary.

`mul_pairs(f)` builds them by placing chosen significand products at chosen result exponents; `mul_labels`
says what the exact product of a pair is (from the operands only, with integers, as the model rounds it), so
that a test can show that every corner is really reached.
"""
from __future__ import annotations

import numpy as np

from mpc_cores.float.model import Format

SEED = 20240


def _word(f: Format, sig: int, field: int, sign: int = 0) -> int:
    """The word of significand `sig` (hidden bit included for field >= 1) and exponent field `field`."""
    assert (field == 0 and sig < 1 << f.manW) or (1 <= field < f.emax_field and sig >> f.manW == 1)
    return (sign << (f.width - 1)) | (field << f.manW) | (sig & ((1 << f.manW) - 1))


def _place(f: Format, sa: int, sb: int, lead: int, rng) -> list[tuple[int, int]]:
    """Pairs with significands sa, sb (normal ones carry the hidden bit, subnormal ones are < 2^manW) whose
    exact product has its leading bit at biased exponent `lead` (< 1: tiny; >= emax_field: overflow), in the
    operand classes the significands allow (both normal: balanced and lopsided exponents)."""
    m, bias = f.manW, f.bias
    n = (sa * sb).bit_length()
    # lead = (n - 1) - 2 m + ea + eb + bias, with ea = field - bias (normal) or 1 - bias (subnormal)
    s = lead - bias - (n - 1) + 2 * m          # ea + eb
    fields = s + 2 * bias                       # fa + fb for normal operands
    sub_a, sub_b = sa >> m == 0, sb >> m == 0
    out = []
    if sub_a and sub_b:
        return [(_word(f, sa, 0), _word(f, sb, 0))] if lead == (n - 1) - 2 * m + 2 * (1 - bias) + bias else []
    if sub_a or sub_b:
        fb = fields - 1                          # the subnormal's exponent is that of field 1
        if 1 <= fb < f.emax_field:
            x, y = (_word(f, sa, 0), _word(f, sb, fb)) if sub_a else (_word(f, sa, fb), _word(f, sb, 0))
            out.append((x, y))
        return out
    choices = {fields // 2, 1, f.emax_field - 1, int(rng.integers(1, f.emax_field))}
    for fa in sorted(choices):
        fb = fields - fa
        if 1 <= fa < f.emax_field and 1 <= fb < f.emax_field:
            out.append((_word(f, sa, fa), _word(f, sb, fb)))
    return out


def _odd_with_length(rng, bits: int) -> int:
    return int(rng.integers(1 << max(bits - 1, 0), 1 << bits)) | 1


def _tie_factors(f: Format, length: int, rng, tries: int = 64) -> list[tuple[int, int]]:
    """Odd u, v < 2^(manW+1) with u * v of exactly `length` bits: placed so that the product keeps
    length - 1 bits, its last bit is the guard bit and nothing lies below it, an exact tie."""
    out = []
    for _ in range(tries):
        lu = int(rng.integers(1, min(length, f.manW + 1) + 1))
        lv = length - lu + int(rng.integers(0, 2))
        if not 1 <= lv <= f.manW + 1:
            continue
        u, v = _odd_with_length(rng, lu), _odd_with_length(rng, lv)
        if (u * v).bit_length() == length:
            out.append((u, v))
            if len(out) == 3:
                break
    return out


def factor_pairs(t: int, bits: int, limit: int = 1 << 16) -> list[tuple[int, int]]:
    """Factorisations t = u * v with u, v < 2^bits (trial division up to `limit`; none if t is prime)."""
    return [(u, t // u) for u in range(3, min(limit, int(t ** 0.5)) + 1, 2)
            if t % u == 0 and t // u < 1 << bits]


def _near_tie(f: Format, d: int, rng) -> list[tuple[int, int]]:
    """Normal significands u, v (hidden bit set) whose product is K 2^(manW + d) + c with K odd of
    manW + 2 - d bits and 0 < c < 2^(manW - 1): at shift distance d the bits below K's last one (the guard
    bit) are zero down to the last manW - 1, then not all zero: half an ulp plus a little, seen only far
    below the guard bit. Empty if the random try fails."""
    m = f.manW
    if m < 2 or d > m + 1:
        return []
    t = m + d
    k = _odd_with_length(rng, m + 2 - d)
    u = int(rng.integers(1 << m, 1 << (m + 1)))
    u &= ~((1 << int(rng.integers(0, m // 2 + 1))) - 1)  # some trailing zeros: room for a subnormal form
    u |= 1 << m
    v = -(-(k << t) // u)
    c = u * v - (k << t)
    return [(u, v)] if (1 << m) <= v < (1 << (m + 1)) and 0 < c < (1 << (m - 1)) else []


def _as_normal(f: Format, u: int) -> int:
    return u << (f.manW + 1 - u.bit_length())


def _as_subnormal(f: Format, u: int, rng) -> int:
    """u shifted to a random place below the hidden bit (u < 2^manW needed)."""
    room = f.manW - u.bit_length()
    return u << int(rng.integers(0, room + 1)) if room >= 0 else 0


def mul_pairs(f: Format) -> list[tuple[int, int]]:
    """Directed pairs (positive operands; the callers add signs) for the multiplier: see the module text."""
    m, E = f.manW, f.emax_field
    rng = np.random.default_rng(SEED + 100 * f.expW + m)
    full = (1 << (m + 1)) - 1
    # significands: 1, 1 + ulp, 1.5, all ones, one low bit, alternating bits, random
    normal = {1 << m, (1 << m) + 1, 3 << (m - 1), full, (1 << m) | 1 << (m // 2), (1 << m) | (((1 << m) - 1) // 3),
              *(int(x) | 1 << m for x in rng.integers(0, 1 << m, 4))}
    sub = {1, 2, 3, (1 << m) - 1, 1 << (m - 1), ((1 << m) - 1) // 3 or 1,
           *(int(x) for x in rng.integers(1, 1 << m, 3))}
    pairs: list[tuple[int, int]] = []
    leads = range(-(m + 4), 2)                   # shift distances 0 .. m + 5 below the normal range, and above
    for sa in sorted(normal | sub):
        for sb in sorted(normal):
            for lead in leads:
                pairs += _place(f, sa, sb, lead, rng)
    for sa in sorted(sub):                       # two subnormals: always tiny, usually zero
        for sb in sorted(sub):
            pairs += _place(f, sa, sb, (sa * sb).bit_length() - 1 - 2 * m + 2 * (1 - f.bias) + f.bias, rng)
    # at every shift distance d (0: a normal result): exact ties rounded down and up, and ties broken only by
    # the product's bits far below the guard bit; with normal operands and with a subnormal one
    for d in range(0, m + 2):
        for sub_op in (False, True):
            need = {"tie": 3, "tie_up": 3, "far_sticky": 3}
            for _ in range(2000):
                if not any(need.values()):
                    break
                uv = _tie_factors(f, m + 2 - d, rng, 8) if need["tie"] or need["tie_up"] else []
                uv = [(_as_normal(f, u), _as_normal(f, v)) for u, v in uv[:1]] + _near_tie(f, d, rng)
                for u, v in uv:
                    core = u >> ((u & -u).bit_length() - 1)
                    sa = (_as_subnormal(f, core, rng) if core.bit_length() <= m else 0) if sub_op else u
                    lead = 1 - d if d else int(rng.integers(1, E))
                    for x, y in _place(f, sa, v, lead, rng) if sa else []:
                        hit = [k for k in need if need[k] and k in mul_labels(f, x, y)]
                        for k in hit:
                            need[k] -= 1
                        if hit:
                            pairs.append((x, y))
    # the overflow boundary: leading bit at emax_field - 1 (largest binade) and emax_field (overflow)
    for sa in sorted(normal):
        for sb in sorted(normal):
            for lead in (E - 2, E - 1, E):
                pairs += _place(f, sa, sb, lead, rng)
    for u, v in factor_pairs((1 << (m + 2)) - 1, m + 1):  # max normal + half an ulp: a tie that overflows
        pairs += _place(f, _as_normal(f, u), _as_normal(f, v), E - 1, rng)
    return sorted(set(pairs))


def mul_labels(f: Format, a: int, b: int) -> set[str]:
    """What the exact product of finite nonzero a, b is: operand classes ('sub*normal', 'sub*sub',
    'normal*normal'), 'shift=<d>' (0 for a normal result, else the distance of its leading bit below the
    normal range, capped at manW + 3), 'tiny', 'tie', 'tie_up', 'far_sticky' (above half an ulp only by bits
    more than manW + 2 places below the product's leading bit, which the multiplier has folded into its sticky
    bit before the shift), 'to_min_normal' (tiny, rounds to 2^emin), 'overflow', 'to_max' (rounds to the largest
    finite value), 'exact'."""
    m, bias = f.manW, f.bias
    if f.is_zero(a) or f.is_zero(b) or f.fields(a)[1] == f.emax_field or f.fields(b)[1] == f.emax_field:
        return set()
    _, ma, ea = f.decode(a)
    _, mb, eb = f.decode(b)
    sub = (ma >> m == 0) + (mb >> m == 0)
    lab = {("normal*normal", "sub*normal", "sub*sub")[sub]}
    p, e = ma * mb, ea + eb
    n = p.bit_length()
    lead = n - 1 + e + bias
    tiny = lead < 1
    lab.add(f"shift={min(1 - lead, m + 3) if tiny else 0}")
    sh = (1 - bias - m) - e if tiny else n - (m + 1)
    if sh <= 0:
        lab.add("exact")
        return lab | ({"tiny"} if tiny else set())
    kept, rem, half = p >> sh, p & ((1 << sh) - 1), 1 << (sh - 1)
    if tiny:
        lab.add("tiny")
    if rem == 0:
        lab.add("exact")
    if rem == half:
        lab.add("tie")
        if kept & 1:
            lab.add("tie_up")
    if rem > half and rem - half < 1 << max(n - (m + 3), 0):
        lab.add("far_sticky")
    up = rem > half or (rem == half and kept & 1)
    if tiny and kept + up == 1 << m:
        lab.add("to_min_normal")
    if not tiny:
        k, lead2 = kept + up, lead
        if k >> (m + 1):
            k, lead2 = k >> 1, lead2 + 1
        if lead2 >= f.emax_field:
            lab.add("overflow")
        elif lead2 == f.emax_field - 1 and k == (1 << (m + 1)) - 1:
            lab.add("to_max")
    return lab
