"""RTL of the floating-point operators (src/main/scala/float) against the bit-exact model, in Verilator.

One sbt run elaborates every unit of the session (and the refused configurations of the refusal test); one
Verilator model holds them all; a C++ harness streams one operand pair per cycle (5 % idle cycles with junk
operands) through each unit. Every result and flag must equal the model's, on exactly cycle t + latency.
"""
from __future__ import annotations

import shutil
from collections import Counter
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from mpc_cores.flow import REPO, GeneratorError, run_generator
from mpc_cores.float.latency import format_latencies
from verif.float import corners, rtl, suite

BUILD = REPO / "build" / "tests" / "float"

DEFAULT_UNITS = [(op, f, "default") for f in suite.FORMATS for op in suite.OPS]
# the multiplier for target ecp5 (its product on a MULT18X18D with its registers): the fewest cycles, the fast
# preset's and fully pipelined
DSP_UNITS = [("mul", suite.E8M17, lat) for lat in (4, format_latencies(suite.E8M17, "fast", "ecp5")["lat_mul"],
                                                   "steps")]
UNITS = DEFAULT_UNITS + suite.LATENCY_VARIANTS + suite.PIPELINED
TARGETS = ["generic"] * len(UNITS) + ["ecp5"] * len(DSP_UNITS)  # of UNITS + DSP_UNITS

# refused by the generator: (op, expW, manW, latency, target) -> the rule in the message
REFUSALS = {
    ("add", 1, 23, "3", "generic"): "exponent width expW must be in [2, 16]: got expW=1",
    ("mul", 8, 0, "3", "generic"): "mantissa width manW must be in [1, 62]: got manW=0",
    ("div", 16, 50, "3", "generic"): "1 + expW + manW must be <= 64 (one 64-bit word): got expW=16, manW=50",
    ("sqrt", 8, 23, "-1", "generic"): "latency must be >= 0: got latency=-1",
    ("fma", 8, 23, "3", "generic"): "operator must be one of add, mul, div, sqrt, cmp: got 'fma'",
    ("cmp", 8, 23, "two", "generic"): "latency must be an integer: got 'two'",
    ("mul", 8, 17, "3", "ecp5"): "the ecp5 multiplier in e8m17 needs latency >= 4",
    ("add", 8, 17, "3", "virtex"): "target must be one of generic, ecp5, xilinx7: got 'virtex'",
}


def _uid(op, f, lat, target="generic") -> str:
    return f"{op}_{f.tag}_l{lat}" + ("" if target == "generic" else f"_{target}")


def _vectors(op, f, lat):
    n = suite.N_RANDOM if lat == "default" else suite.N_LATENCY
    offset = {"default": 0, "steps": 1000}[lat] if isinstance(lat, str) else 7 + lat
    seed = suite.seed_of(f, op) + offset
    return n, seed


@pytest.fixture(scope="module")
def float_session():
    jobs = [(op, f.expW, f.manW, lat, t, BUILD / _uid(op, f, lat, t))
            for (op, f, lat), t in zip(UNITS + DSP_UNITS, TARGETS)]
    bad = [(op, e, m, lat, t, BUILD / "refused" / f"{op}_{e}_{m}_{lat}_{t}") for op, e, m, lat, t in REFUSALS]
    for j in jobs + bad:
        shutil.rmtree(j[-1], ignore_errors=True)
    try:
        run_generator("float.FloatMain", rtl.generator_args(jobs + bad))
        refusal_msg = ""
    except GeneratorError as e:
        refusal_msg = str(e)
    missing = [str(j[-1]) for j in jobs if not (j[-1] / "float.json").exists()]
    if missing:
        raise GeneratorError(f"no output in {missing[:3]}...:\n{refusal_msg}")
    units = [rtl.load_unit(j[-1]) for j in jobs]
    with ThreadPoolExecutor(1) as pool:
        exe = pool.submit(rtl.build, units, BUILD / "sim")
        streams, expected = [], []
        rng = np.random.default_rng(5)
        for (op, f, lat) in UNITS + DSP_UNITS:  # the model's results while Verilator compiles
            n, seed = _vectors(op, f, lat)
            a, b, o, _ = suite.operands(f, op, n, seed)
            expected.append(suite.model_results(f, op, n, seed))
            # 5 % idle cycles, with junk operands that must not reach any output
            total = len(a) + len(a) // 19
            valid = np.ones(total, dtype=bool)
            valid[rng.choice(total, total - len(a), replace=False)] = False
            ja, jb, jo = (rng.integers(0, 1 << f.width, total).astype(np.uint64),
                          rng.integers(0, 1 << f.width, total).astype(np.uint64),
                          rng.integers(0, 2, total).astype(np.uint64))
            pos = np.flatnonzero(valid)
            ja[pos], jb[pos], jo[pos] = a, b, o
            streams.append((valid, jo, ja, jb))
        exe = exe.result()
    extra = max(u.latency for u in units) + 2
    results = rtl.run(exe, BUILD / "run", streams, extra)
    return {"units": units, "streams": streams, "expected": expected, "results": results,
            "refusals": refusal_msg}


def _check(float_session, key, target="generic"):
    k = UNITS.index(key) if target == "generic" else len(UNITS) + DSP_UNITS.index(key)
    u = float_session["units"][k]
    valid, o, a, b = float_session["streams"][k]
    out, flags = float_session["expected"][k]
    got = float_session["results"][k]
    op, f, lat = key
    assert u.op == op and (u.fmt.expW, u.fmt.manW) == (f.expW, f.manW) and u.info["target"] == target
    if lat == "steps":
        assert u.latency == u.info["steps"]
    elif lat != "default":
        assert u.latency == lat
    pos = np.flatnonzero(valid)
    assert len(out) > 0 and len(got) == len(pos), f"{len(got)} results for {len(pos)} valid inputs"
    # latency: the result of the input on cycle t appears on cycle t + latency, and out_valid only then
    assert np.array_equal(got[:, 0], pos.astype(np.uint64) + np.uint64(u.latency)), "latency/valid mismatch"
    bad = np.flatnonzero((got[:, 1] != out) | (got[:, 2] != flags))
    assert bad.size == 0, f"{bad.size} of {len(out)} differ; first: " + "; ".join(
        f"a={int(a[pos[i]]):#x} b={int(b[pos[i]]):#x} op={int(o[pos[i]])}: rtl {int(got[i, 1]):#x} "
        f"flags {int(got[i, 2]):#07b}, model {int(out[i]):#x} flags {int(flags[i]):#07b}" for i in bad[:4])
    return len(out), u


@pytest.mark.parametrize("key", DEFAULT_UNITS, ids=[_uid(*k) for k in DEFAULT_UNITS])
def test_rtl_matches_model(float_session, key):
    op, f, _ = key
    n, u = _check(float_session, key)
    if f.width <= 8:  # every operand pair, both op bits
        assert n == 2 * (1 << f.width) ** (1 if op == "sqrt" else 2)
    else:
        assert n >= suite.N_RANDOM + 100  # random pairs and the edge cases
    assert u.latency == u.info["default_latency"]


@pytest.mark.parametrize("key", suite.LATENCY_VARIANTS, ids=[_uid(*k) for k in suite.LATENCY_VARIANTS])
def test_latency_parameter(float_session, key):
    n, u = _check(float_session, key)
    assert n >= suite.N_LATENCY
    assert u.info["latency"] == key[2] and u.module.endswith(f"_l{key[2]}")


@pytest.mark.parametrize("key", suite.PIPELINED, ids=[_uid(*k) for k in suite.PIPELINED])
def test_fully_pipelined(float_session, key):
    """Latency `steps`: one register after every step (the operators' highest clock rate, docs/float.md)."""
    n, u = _check(float_session, key)
    assert n >= suite.N_LATENCY
    assert u.latency == u.info["steps"] > u.info["default_latency"] and u.module.endswith(f"_l{u.latency}")
    # the cores' fast latency preset builds divide and square root fully pipelined, and compact at the default
    op, f, _ = key
    if op in ("div", "sqrt"):
        assert format_latencies(f, "fast")[f"lat_{op}"] == u.info["steps"]
    assert format_latencies(f, "compact")[f"lat_{op}"] == u.info["default_latency"]


@pytest.mark.parametrize("key", DSP_UNITS, ids=[_uid(*k, "ecp5") for k in DSP_UNITS])
def test_mul_on_ecp5_dsp(float_session, key):
    """Target ecp5: the significand product on the MULT18X18D (its model here: input, pipeline and output
    registers) gives the generic multiplier's words, with one cycle more than the generic multiplier with the same
    placement of the other registers (`steps`: a register after every step as well)."""
    n, u = _check(float_session, key, "ecp5")
    assert n >= suite.N_LATENCY and u.module.endswith(f"_l{u.latency}_ecp5")
    sv = u.sv.read_text()
    assert "mpc_ecp5_mult18x18u" in sv and "SIGNEDA(1'b0)" in sv
    if key[2] == "steps":
        generic = float_session["units"][UNITS.index(("mul", key[1], "steps"))]
        assert u.latency == u.info["steps"] == generic.latency + 1


@pytest.mark.parametrize("f", [suite.E8M17, suite.BINARY32], ids=lambda f: f.tag)
def test_mul_corners_reach_every_case(f):
    """The multiplier's directed pairs (verif/float/corners.py), among the vectors of every mul unit above, reach
    each piece of its rounding path; the labels come from the exact product, not from the RTL. Every distance
    of the right shift (0: normal result, 1 .. manW + 3 into the subnormal range) with two normal operands and
    with a subnormal one; at each distance where they exist, exact ties rounded down and up and ties broken
    only by product bits far below the guard bit; two subnormals; rounding up into the smallest normal; the
    largest finite result and overflow (by a tie too when 2^(manW+2) - 1 factors into two significands)."""
    m = f.manW
    a, b, _, _ = suite.operands(f, "mul", suite.N_RANDOM, suite.seed_of(f, "mul"))
    pairs = corners.mul_pairs(f)
    assert set(pairs) <= set(zip(a.tolist(), b.tolist()))
    seen = Counter()
    for x, y in pairs:
        lab = corners.mul_labels(f, x, y)
        d = next(int(s[len("shift="):]) for s in lab if s.startswith("shift="))
        seen.update(lab)
        for cls in lab & {"sub*normal", "normal*normal"}:
            seen.update((cls, k, d) for k in lab | {"any"})
        if {"overflow", "tie"} <= lab:
            seen["overflow_tie"] += 1
    missing = []
    for cls in ("sub*normal", "normal*normal"):
        for d in range(m + 4):
            wanted = ["any"] + (["tie", "far_sticky"] if d <= m + 1 else []) + (["tie_up"] if d <= m else [])
            missing += [(cls, k, d) for k in wanted if not seen[(cls, k, d)]]
        if not seen[(cls, "to_min_normal", 1)]:
            missing.append((cls, "to_min_normal"))
    missing += [k for k in ("sub*sub", "overflow", "to_max") if not seen[k]]
    if corners.factor_pairs((1 << (m + 2)) - 1, m + 1) and not seen["overflow_tie"]:
        missing.append("overflow_tie")
    assert not missing, missing


def test_generator_refusals(float_session):
    msg = float_session["refusals"]
    for (op, e, m, lat, t), rule in REFUSALS.items():
        assert f"REFUSED {op} {e} {m} {lat} {t}: " in msg and rule in msg, (rule, msg)
    assert not (BUILD / "refused").exists() or not any((BUILD / "refused").iterdir())
