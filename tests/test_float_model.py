"""The bit-exact floating-point model (mpc_cores/float/model.py) against numpy, and its rounding on known cases.

binary32 against numpy float32 and binary16 against numpy float16 on the same vectors the RTL gets (edge cases,
ties, 10^5 random pairs per operator): bits equal, NaN results compared by NaN-ness (numpy keeps payloads,
the model returns the canonical quiet NaN).
"""
from __future__ import annotations

import pytest

from mpc_cores.float import model
from verif.float import suite
from verif.float import vectors as V
from mpc_cores.float.model import Format

F32, F16 = suite.BINARY32, suite.BINARY16


@pytest.mark.parametrize("f", [F32, F16], ids=lambda f: f.tag)
@pytest.mark.parametrize("op", suite.OPS)
def test_model_matches_numpy(op, f):
    seed = suite.seed_of(f, op)
    a, b, o, n_random = suite.operands(f, op, suite.N_RANDOM, seed)
    out, _ = suite.model_results(f, op, suite.N_RANDOM, seed)
    assert n_random >= 100_000 and len(a) > n_random
    bad = V.mismatches_vs_numpy(f, op, a, b, o, out)
    ref = V.numpy_results(f, op, a, b, o)
    assert bad.size == 0, f"{bad.size} mismatches, first: " + ", ".join(
        f"a={int(a[i]):#x} b={int(b[i]):#x} op={int(o[i])}: model {int(out[i]):#x} numpy {int(ref[i]):#x}"
        for i in bad[:5])
    # NaN results carry the canonical quiet NaN
    nan = [int(x) for x in out if f.is_nan(int(x))]
    assert op == "cmp" or all(x == f.qnan for x in nan)


@pytest.mark.parametrize("f", [F32, suite.REDUCED], ids=lambda f: f.tag)
def test_random_vectors_reach_ties_subnormals_overflow(f):
    """The random mixes make the rare cases common: exact ties (both ways), subnormal results, overflow,
    exact results, NaN operands."""
    for op in ("add", "mul", "div"):
        suite.model_results(f, op, suite.N_RANDOM, suite.seed_of(f, op))
        cov = suite.COVERAGE[(f, op, suite.N_RANDOM, suite.seed_of(f, op))]
        assert cov["tie"] >= 40 and cov["tie_up"] >= 20, (op, cov)
        assert cov["subnormal"] >= 500 and cov["overflow"] >= 100 and cov["exact"] >= 5000, (op, cov)


def test_round_pack_known_cases():
    f = F32
    one = 0x3F800000
    assert model.round_pack(f, 0, 1, 0) == (one, 0)
    # 1 + 2^-24: a tie, to even (1.0); 1 + 3 * 2^-24: a tie, to even (1 + 2^-22)
    assert model.round_pack(f, 0, (1 << 24) + 1, -24) == (one, model.INEXACT)
    assert model.round_pack(f, 0, (1 << 24) + 3, -24) == (one + 2, model.INEXACT)
    # the sticky bit breaks the tie upwards
    assert model.round_pack(f, 0, (1 << 24) + 1, -24, sticky=True) == (one + 1, model.INEXACT)
    # smallest subnormal, half of it (tie to 0, underflow), three halves (tie to 2)
    assert model.round_pack(f, 0, 1, -149) == (1, 0)
    assert model.round_pack(f, 1, 1, -150) == (0x80000000, model.INEXACT | model.UNDERFLOW)
    assert model.round_pack(f, 0, 3, -150) == (2, model.INEXACT | model.UNDERFLOW)
    # largest subnormal rounding up into the smallest normal
    assert model.round_pack(f, 0, (1 << 24) - 1, -150) == (0x00800000, model.INEXACT | model.UNDERFLOW)
    # max normal + half an ulp: a tie with an odd significand -> overflow to infinity
    assert model.round_pack(f, 0, (1 << 25) - 1, 103) == (0x7F800000, model.OVERFLOW | model.INEXACT)


def test_special_cases():
    f = F32
    inf, ninf, qnan, snan = 0x7F800000, 0xFF800000, 0x7FC00000, 0x7F800001
    assert model.add(f, inf, ninf) == (qnan, model.INVALID)
    assert model.add(f, 0x80000000, 0x80000000) == (0x80000000, 0)
    assert model.add(f, 0x80000000, 0) == (0, 0)
    assert model.add(f, 0x3F800000, 0x3F800000, sub=True) == (0, 0)
    assert model.mul(f, 0, inf) == (qnan, model.INVALID)
    assert model.mul(f, snan, 0x3F800000) == (qnan, model.INVALID)
    assert model.div(f, 0x3F800000, 0x80000000) == (ninf, model.DIVZERO)
    assert model.div(f, 0, 0) == (qnan, model.INVALID)
    assert model.sqrt(f, 0x80000000) == (0x80000000, 0)
    assert model.sqrt(f, 0xBF800000) == (qnan, model.INVALID)
    assert model.compare(f, 0, 0x80000000) == (0b110, 0)               # +0 == -0
    assert model.compare(f, qnan, 0) == (0b1000, 0)                     # quiet ==: no invalid
    assert model.compare(f, qnan, 0, signaling=True) == (0b1000, model.INVALID)
    assert model.compare(f, snan, 0) == (0b1000, model.INVALID)


@pytest.mark.parametrize("e,m,rule", [(1, 23, "expW must be in [2, 16]: got expW=1"),
                                      (8, 0, "manW must be in [1, 62]: got manW=0"),
                                      (16, 50, "1 + expW + manW must be <= 64")])
def test_format_refusals(e, m, rule):
    with pytest.raises(ValueError, match=rule.replace("[", r"\[").replace("]", r"\]").replace("+", r"\+")):
        Format(e, m)
