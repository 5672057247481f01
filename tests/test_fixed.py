"""Unit tests of mpc_cores/fixed.py against plain Python integer arithmetic."""
import math
from fractions import Fraction

import numpy as np
import pytest

from mpc_cores.fixed import (
    ROUNDING_MODES,
    bits_for,
    quantize,
    saturate,
    shift_round,
    to_real,
    tree_sum,
    wmax,
    wmin,
)

# Products in the model stay below 2^62 (MODEL_PRODUCT_BITS); keep p + 2^(shift-1) inside int64.
P_LIM = 1 << 62


def _random_products(rng, size):
    # Mix magnitudes so that small words (where off-by-one errors show) are as common as large ones.
    mags = rng.integers(0, 63, size=size)
    p = rng.integers(-P_LIM, P_LIM, size=size, dtype=np.int64)
    return p >> mags.astype(np.int64)


# ---------------------------------------------------------------------------
# shift_round


@pytest.mark.parametrize("shift", [1, 2, 7, 16, 31, 40])
def test_shift_round_truncate_is_floor(shift):
    rng = np.random.default_rng(100 + shift)
    p = _random_products(rng, 4000)
    got = shift_round(p, shift, "truncate")
    assert got.dtype == np.int64
    want = [pi // (1 << shift) for pi in p.tolist()]  # Python // floors for negatives too
    assert got.tolist() == want
    # spot-check against math.floor on exact rationals
    for pi, gi in zip(p[:200].tolist(), got[:200].tolist()):
        assert gi == math.floor(Fraction(pi, 1 << shift))


@pytest.mark.parametrize("shift", [1, 2, 7, 16, 31, 40])
def test_shift_round_nearest_is_round_half_up(shift):
    rng = np.random.default_rng(200 + shift)
    p = _random_products(rng, 4000)
    # add exact ties (odd multiples of half an LSB), both signs
    k = rng.integers(-1000, 1000, size=200)
    ties = (2 * k + 1) * (1 << (shift - 1))
    p = np.concatenate([p, ties.astype(np.int64)])
    got = shift_round(p, shift, "nearest")
    want = [math.floor(Fraction(pi, 1 << shift) + Fraction(1, 2)) for pi in p.tolist()]
    assert got.tolist() == want


def test_shift_round_nearest_ties_go_up():
    # -0.5 -> 0, 0.5 -> 1, -1.5 -> -1, 1.5 -> 2 (round half up, not half away from zero or to even)
    p = np.array([-1, 1, -3, 3, -5, 5], dtype=np.int64)
    assert shift_round(p, 1, "nearest").tolist() == [0, 1, -1, 2, -2, 3]
    assert shift_round(p, 1, "truncate").tolist() == [-1, 0, -2, 1, -3, 2]


@pytest.mark.parametrize("mode", ROUNDING_MODES)
def test_shift_round_zero_shift_is_identity(mode):
    p = np.array([-7, 0, 5, -(1 << 40)], dtype=np.int64)
    assert shift_round(p, 0, mode).tolist() == p.tolist()


def test_shift_round_unknown_mode():
    with pytest.raises(ValueError, match="rounding must be one of"):
        shift_round(np.array([3], dtype=np.int64), 2, "even")


# ---------------------------------------------------------------------------
# saturate, wmin/wmax


@pytest.mark.parametrize("width", [1, 2, 3, 8, 17, 33, 48])
def test_saturate_clamps_and_flags(width):
    lo, hi = -(2 ** (width - 1)), 2 ** (width - 1) - 1
    assert (wmin(width), wmax(width)) == (lo, hi)
    rng = np.random.default_rng(300 + width)
    span = 4 * (hi - lo + 1)
    x = rng.integers(-span, span, size=500, dtype=np.int64)
    c, flag = saturate(x, width)
    assert c.tolist() == [min(max(v, lo), hi) for v in x.tolist()]
    assert flag == any(v < lo or v > hi for v in x.tolist())

    inside = np.array([lo, hi, 0 if width > 1 else lo], dtype=np.int64)
    c, flag = saturate(inside, width)
    assert not flag and c.tolist() == inside.tolist()
    for v, clamped in ((lo - 1, lo), (hi + 1, hi)):
        c, flag = saturate(np.array([v], dtype=np.int64), width)
        assert flag and c.tolist() == [clamped]


def test_saturate_flag_is_any_not_all():
    c, flag = saturate(np.array([[0, 1], [2, 100]], dtype=np.int64), 4)
    assert flag is True
    assert c.tolist() == [[0, 1], [2, 7]]


# ---------------------------------------------------------------------------
# tree_sum


def _tree_ref(terms, width):
    """DotProductTree order: pair (0,1), (2,3), ... at each level, saturate every sum, an odd last element passes."""
    lo, hi = -(2 ** (width - 1)), 2 ** (width - 1) - 1
    level = [int(t) for t in terms]
    flag = False
    while len(level) > 1:
        nxt = []
        for i in range(0, len(level) - 1, 2):
            s = level[i] + level[i + 1]
            flag |= not lo <= s <= hi
            nxt.append(min(max(s, lo), hi))
        if len(level) % 2:
            nxt.append(level[-1])
        level = nxt
    return level[0], flag


def _sequential_ref(terms, width):
    lo, hi = -(2 ** (width - 1)), 2 ** (width - 1) - 1
    acc = int(terms[0])
    for t in terms[1:]:
        acc = min(max(acc + int(t), lo), hi)
    return acc


@pytest.mark.parametrize("m", [1, 2, 3, 4, 5, 7, 8, 9, 16, 17, 40])
def test_tree_sum_without_saturation_is_plain_sum(m):
    rng = np.random.default_rng(400 + m)
    terms = rng.integers(-(1 << 20), 1 << 20, size=(6, m), dtype=np.int64)
    s, flag = tree_sum(terms, 40)
    assert not flag
    assert s.shape == (6,)
    assert s.tolist() == terms.sum(axis=-1).tolist()


def test_tree_sum_order_matters_when_saturating():
    # width 4 holds [-8, 7]. Pairwise: (7+1)->7, (-8-8)->-8, 5 passes; (7-8)=-1, 5; -1+5 = 4.
    # Left to right: 7+1->7, -1, -9->-8, -3; the exact sum is -3 as well.
    terms = np.array([7, 1, -8, -8, 5], dtype=np.int64)
    s, flag = tree_sum(terms, 4)
    assert (int(s), flag) == (4, True)
    assert _tree_ref(terms, 4) == (4, True)
    assert _sequential_ref(terms, 4) == -3 and int(terms.sum()) == -3


@pytest.mark.parametrize("m", [2, 3, 5, 6, 7, 11, 13, 16])
def test_tree_sum_matches_pairwise_reference_when_saturating(m):
    rng = np.random.default_rng(500 + m)
    width = 5
    terms = rng.integers(wmin(width), wmax(width) + 1, size=(300, m), dtype=np.int64)
    s, flag = tree_sum(terms, width)
    refs = [_tree_ref(row, width) for row in terms]
    assert s.tolist() == [r[0] for r in refs]
    assert flag == any(r[1] for r in refs)
    # the random rows do saturate; from m = 4 on the tree order differs from left to right somewhere
    assert flag
    if m >= 4:
        assert any(r[0] != _sequential_ref(row, width) for r, row in zip(refs, terms))


def test_tree_sum_flag_per_call_not_sticky():
    _, f1 = tree_sum(np.array([7, 7], dtype=np.int64), 4)
    _, f2 = tree_sum(np.array([3, 4], dtype=np.int64), 4)
    assert f1 and not f2


# ---------------------------------------------------------------------------
# bits_for


def _holds(width, bound):
    return wmin(width) <= -bound and bound <= wmax(width)


def _minimal_width(bound):
    w = 1
    while not _holds(w, bound):
        w += 1
    return w


BOUNDS = range(0, 1100)
POW2_MINUS_1 = [(1 << k) - 1 for k in range(0, 11)]


def test_bits_for_holds_the_bound():
    for bound in BOUNDS:
        w = bits_for(bound)
        assert _holds(w, bound), bound
        assert bits_for(-bound) == w
    for bound in (2**31 - 1, 2**31, 2**40 + 3):
        assert _holds(bits_for(bound), bound)


def test_bits_for_is_minimal():
    for bound in BOUNDS:
        assert bits_for(bound) == _minimal_width(bound), bound


@pytest.mark.parametrize("bound", POW2_MINUS_1)
def test_bits_for_is_minimal_at_powers_of_two_minus_one(bound):
    assert bits_for(bound) == _minimal_width(bound)


# ---------------------------------------------------------------------------
# quantize / to_real


@pytest.mark.parametrize("b", [1, 8, 16])
def test_quantize_modes(b):
    rng = np.random.default_rng(600 + b)
    x = rng.uniform(-50, 50, size=1000)
    one = 1 << b
    fl, ce, ne = (quantize(x, b, m) for m in ("floor", "ceil", "nearest"))
    for q in (fl, ce, ne):
        assert q.dtype == np.int64
    assert np.all(fl / one <= x) and np.all(x - fl / one < 1.0 / one)
    assert np.all(ce / one >= x) and np.all(ce / one - x < 1.0 / one)
    assert np.all(np.abs(ne / one - x) <= 0.5 / one)
    assert np.array_equal(to_real(ne, b), ne / one)
    # words are exact reals: quantising them again changes nothing
    for mode in ("floor", "ceil", "nearest"):
        assert np.array_equal(quantize(to_real(ne, b), b, mode), ne)
