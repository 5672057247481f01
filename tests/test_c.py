"""`make c`: the generated C99 solvers (mpc_cores.csrc, mpc_cores/<kind>/c.py) against the golden models, word for
word and flag for flag, compiled by gcc -std=c99 -O2 -Wall -Wextra -Werror -pedantic; the float variant against the
float64 references; the command line; the bench's C rows. Python and gcc only: no sbt, no Verilator. The golden
models against the RTL are the RTL suites' business (tests/test_fgm_rtl.py, tests/test_admm_rtl.py)."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from conftest import ADMM_CASES, CASES, REPO
from mpc_cores import registry
from mpc_cores.csrc import emit, harness
from mpc_cores.kind import load

pytestmark = pytest.mark.skipif(harness.gcc() is None, reason="gcc not found: the C solvers are compiled by gcc")

# FGM and ADMM designs: the RTL suites' cases (both roundings, b from 10 to 18, nw > n, soft pairs or none), and
# the options only the spec sets (OUT_ALL and WARM_START reset values, Imax)
MASSES = lambda: CASES["masses_p1_b16"][0]()  # noqa: E731
DESIGNS = {
    **{f"fgm_{k}": ("fgm", p, ov) for k, (p, ov, _) in CASES.items()},
    "fgm_masses_outall_cold_i20": ("fgm", MASSES, dict(frac_bits=14, output_all=True, warm_start=False,
                                                       iterations=20)),
    **{f"admm_{k}": ("admm", p, ov) for k, (p, ov, _) in ADMM_CASES.items()},
    "admm_rand_outall_cold": ("admm", ADMM_CASES["rand_rate_n19_p5"][0], dict(frac_bits=15, output_all=True,
                                                                              warm_start=False, iterations=12)),
}
SOLVES = {"fgm": 80, "admm": 40}


@pytest.fixture(scope="module")
def designs():
    """did -> design, made once per module (the design functions take the spec-only options as overrides)."""
    cache = {}

    def get(did):
        if did not in cache:
            kind, prob, ov = DESIGNS[did]
            cache[did] = load(registry.get(kind).design_fn)(prob(), **ov)
        return cache[did]
    return get


def _generate(kind: str, d, out, cfg=None):
    """The kind's C writer through the registry (make c), from cfg instead of d.config() when given."""
    return load(registry.get(kind).c_fn)(d, out, **({"cfg": cfg} if cfg else {}))


def _box(kind, model):
    return (model.xlo, model.xhi) if kind == "fgm" else (model.wlo, model.whi)


def replay(kind: str, cfg: dict, lib, solves: int, seed: int) -> dict:
    """Random solves through the C solver and the golden model side by side: Imax in [1, 2 Imax0] or the reset
    values (ctrl NULL), warm or cold, OUT_ALL or not, 10 % of the words outside the box (within the stream word),
    a reset now and then. Returns counts; asserts every word and flag."""
    model = registry.get(kind).golden_model(cfg)
    rng = np.random.default_rng(seed)
    lo, hi = (np.asarray(a, dtype=np.int64) for a in _box(kind, model))
    lim = (1 << (int(cfg["widths"]["stream"]) - 1)) - 1
    imax0 = int(cfg["iterations"])
    state, held = lib.new_state(), False
    seen = {"sat": 0, "overflow": 0, "warm": 0, "out_all": 0, "reset_values": 0}
    for s in range(solves):
        if rng.random() < 0.05:
            state, held = lib.new_state(), False
            model.reset()
        w = rng.integers(lo, hi + 1)
        far = rng.random(len(w)) < 0.1
        w = np.where(far, np.where(rng.random(len(w)) < 0.5, rng.integers(np.minimum(hi + 1, lim), lim + 1),
                                   rng.integers(-lim - 1, np.maximum(lo, -lim))), w)
        if rng.random() < 0.1:
            imax, warm, out_all = None, bool(cfg["warm_start"]), bool(cfg["output_all"])
            seen["reset_values"] += 1
        else:
            imax, warm, out_all = int(rng.integers(1, 2 * imax0 + 1)), rng.random() < 0.8, rng.random() < 0.3
        tol = None              # the exit test's EXIT_TOL: its reset value, or now and then another
        if cfg.get("early_exit") and rng.random() < 0.5:
            tol = int(rng.choice([0, 1, 2] + [1 << max(0, int(cfg["frac_bits"]) - s) for s in (5, 3, 2)]))
            seen["exit_tol"] = seen.get("exit_tol", 0) + 1
        got, flags, _ = lib.solve(state, w, imax, warm, out_all, exit_tol=tol)
        r = model.solve(w, imax=imax0 if imax is None else imax, warm=warm,
                        **({} if tol is None else {"exit_tol": tol}))
        exp = r.z if out_all else r.z[: int(cfg["nu"])]
        tag = f"solve {s} (imax={imax}, warm={warm}, out_all={out_all}, w={w.tolist()})"
        assert got.tolist() == exp.tolist(), f"{tag}: C {got.tolist()} != model {exp.tolist()}"
        assert flags[:3] == (int(warm and held), int(r.sat), int(r.overflow)), f"{tag}: flags {flags}"
        if kind == "admm":
            assert flags[3] == sum(1 << i for i, k in enumerate(OVF["admm"]) if r.flags[k]), f"{tag}: {flags}"
        else:
            assert (flags[3] != 0) == r.overflow, f"{tag}: {flags}"
        assert lib.iterations == getattr(r, "iterations", imax0 if imax is None else imax), \
            f"{tag}: {lib.iterations} iterations"
        if cfg.get("early_exit"):
            assert lib.met == r.met, f"{tag}: MET {lib.met}"
            seen["met"] = seen.get("met", 0) + r.met
        held = True
        for k, v in (("sat", r.sat), ("overflow", r.overflow), ("warm", warm and flags[0]), ("out_all", out_all)):
            seen[k] += bool(v)
    return seen


OVF = {"fgm": ("sum", "t", "y"), "admm": ("v", "y", "q", "z", "d", "nu", "sum")}


def build(kind, d, out, cfg=None):
    """Generate, compile every file strictly (float also in single precision), run the embedded self test, load
    the fixed-point solver with the shim."""
    files = _generate(kind, d, out, cfg)
    nm = emit.names(d.module_name)
    assert sorted(f.name for f in files) == sorted(f"{nm.stem}{s}" for s in (".h", ".c", "_float.h", "_float.c"))
    for f in files:
        if f.suffix == ".c":
            harness.compile_c([f], out / f"{f.stem}.o", "-c")
    harness.compile_c([out / f"{nm.stem}_float.c"], out / "single.o", "-c", f"-D{nm.P}_F_SINGLE")
    exe = harness.compile_c([out / f"{nm.stem}.c"], out / "selftest", "-DMPC_C_SELFTEST")
    p = subprocess.run([str(exe)], capture_output=True, text=True)
    assert p.returncode == 0 and "6 of 6 solves equal" in p.stdout, p.stdout
    return harness.load(out, nm, cfg or d.config())


@pytest.mark.parametrize("did", list(DESIGNS))
def test_bit_exact(did, designs, tmp_path):
    """Every word, the output count and the warm, SAT and OVERFLOW flags (ADMM: which signal) as the golden
    model's, over random solves with saturated inputs, warm-start sequences, resets and the reset values."""
    kind = DESIGNS[did][0]
    d = designs(did)
    seen = replay(kind, d.config(), build(kind, d, tmp_path), SOLVES[kind], seed=len(did))
    assert seen["sat"] and seen["warm"] and seen["out_all"] and seen["reset_values"], seen
    if d.config().get("early_exit"):
        assert seen["exit_tol"] and seen["met"], seen


# bits cut from the design's word widths, so that the datapath saturates: FGM everywhere; ADMM the iterate words
# (v, y, q, z, d, nu), then the products and the adder trees' partial sums
NARROW = {"fgm": ("fgm_masses_p3_b12_nearest", {"sum": 4, "t": 4, "y": 3}),
          "admm_iterates": ("admm_rand_soft_n19_p3_l00_trunc", {"v": 6, "y": 3, "q": 3, "z": 3, "d": 3, "nu": 5}),
          "admm_sums": ("admm_rand_soft_n19_p3_l00_trunc", {"sum": 5})}


@pytest.mark.parametrize("case", list(NARROW))
def test_bit_exact_saturating(case, designs, tmp_path):
    """Widths cut below the design's, so that OVERFLOW rises (where the adder tree's partial sums saturate, its
    order matters): still every word and flag as the golden model's."""
    did, cut = NARROW[case]
    kind, d = DESIGNS[did][0], designs(did)
    cfg = d.config()
    cfg["widths"] = {k: v - cut.get(k, 0) for k, v in cfg["widths"].items()}
    seen = replay(kind, cfg, build(kind, d, tmp_path, cfg), SOLVES[kind], seed=7)
    assert seen["overflow"] >= SOLVES[kind] // 4, seen


def test_detects_a_changed_word(designs, tmp_path):
    """The comparison fails when one coefficient of the C differs from the golden model's by one LSB."""
    d = designs("fgm_rand_n4_p4_b10")
    cfg = d.config()
    bad = dict(cfg, A=[[a + (i == j == 0) for j, a in enumerate(row)] for i, row in enumerate(cfg["A"])])
    _generate("fgm", d, tmp_path, bad)
    lib = harness.load(tmp_path, emit.names(d.module_name), bad)
    with pytest.raises(AssertionError, match="!= model"):
        replay("fgm", cfg, lib, 40, seed=1)


def test_headroom_refused(designs, tmp_path):
    """Words too wide for int64_t intermediates are refused with the reason, before any file is written."""
    from mpc_cores.errors import DesignError

    d = designs("fgm_rand_n4_p4_b10")
    cfg = d.config()
    cfg["widths"] = dict(cfg["widths"], sum=62)
    with pytest.raises(DesignError, match=r"below 2\^61: sum of \|products\| needs 63 bits"):
        _generate("fgm", d, tmp_path, cfg)
    assert not list(tmp_path.iterdir())


def _float_reference(kind, d):
    if kind == "fgm":
        from mpc_bench.baselines import NumpyFgm

        return NumpyFgm(d.qp, d.nu, d.c, d.lam_max, d.iterations).solve, (d.xlo, d.xhi)
    from mpc_cores.admm.model import AdmmFloat

    f = AdmmFloat(d)
    return (lambda w: f.solve(w)[0]), (d.wlo, d.whi)


@pytest.mark.parametrize("did", ["fgm_masses_p1_b16", "admm_rand_soft_n19_p3_l00_trunc", "admm_rand_rate_n19_p5",
                                 "admm_masses_norate_p1_b16"])
def test_float_variant(did, designs, tmp_path):
    """The float variant (double) against the float64 reference of the same algorithm and warm start (numpy FGM of
    the bench, AdmmFloat) over a warm-started sequence in the parameter box: within 1e-9 (docs/c.md: only the order
    of the sums differs)."""
    kind = DESIGNS[did][0]
    d = designs(did)
    _generate(kind, d, tmp_path)
    lib = harness.load(tmp_path, emit.names(d.module_name), d.config(), float_=True)
    ref, (lo, hi) = _float_reference(kind, d)
    rng = np.random.default_rng(3)
    state, worst = lib.new_state(), 0.0
    for k in range(25):
        w = rng.uniform(lo, hi) / (1 << d.b)
        z, flags, _ = lib.solve(state, w, d.iterations, True, True)
        zr = ref(w)
        assert flags == (int(k > 0), 0)
        worst = max(worst, float(np.abs(z - zr).max() / max(1.0, np.abs(zr).max())))
    assert worst < 1e-9, worst


USER = """#include <stdio.h>
#include "{stem}.h"
int main(void)
{{
    static {p}_state_t state;
    {p}_word_t w[{P}_NW] = {{0}}, u0[{P}_NU];
    unsigned k, i;
    for (k = 0; k < 2; k++) {{
        unsigned n = {p}_solve(&state, NULL, w, u0, NULL);
        for (i = 0; i < n; i++)
            printf("%ld ", (long)u0[i]);
    }}
    return 0;
}}
"""


def test_user_program(designs, tmp_path):
    """A program of a user: the header alone, the reset values (ctrl NULL), an output buffer of NU words, no status;
    built with the solver under the strict flags, its words are the golden model's."""
    d = designs("fgm_masses_p1_b16")
    _generate("fgm", d, tmp_path)
    nm = emit.names(d.module_name)
    (tmp_path / "user.c").write_text(USER.format(stem=nm.stem, p=nm.p, P=nm.P))
    exe = harness.compile_c([tmp_path / "user.c", tmp_path / f"{nm.stem}.c"], tmp_path / "user")
    model = registry.get("fgm").golden_model(d.config())
    w = np.zeros(d.nw, dtype=np.int64)
    want = [int(v) for _ in range(2) for v in model.solve(w).z[: d.nu]]
    assert subprocess.run([str(exe)], capture_output=True, text=True).stdout.split() == [str(v) for v in want]


def test_cli(tmp_path):
    """`mpc-cores c` writes the four files of a design with the overrides given, without sbt."""
    p = subprocess.run([sys.executable, "-m", "mpc_cores", "c", "--core", "fgm", "--frac-bits", "12", "--iterations",
                        "9", "--out", str(tmp_path)], capture_output=True, text=True, cwd=REPO, timeout=120)
    assert p.returncode == 0, p.stderr
    h = next(tmp_path.glob("FgmCore_masses_*_b12_solver.h")).read_text()
    assert "_IMAX 9 " in h and len(list(tmp_path.glob("*_solver*"))) == 4


@pytest.mark.parametrize("core", ["minres", "ipm"])
def test_cli_refuses_kinds_without_c(core):
    from test_refusals import refusal

    from mpc_cores import registry

    with_c = [k.name for k in registry.kinds().values() if k.c_fn]
    assert {"fgm", "admm", "dgp"} <= set(with_c) and core not in with_c
    assert refusal("c", "--core", core) == f"error: CORE={core}: C solvers are generated for the cores {', '.join(with_c)}"


def test_bench_rows(designs, tmp_path):
    """mpc_bench.c_timing: the two rows over a short loop of masses, in the format of the other solvers."""
    from mpc_bench import baselines, c_timing
    from mpc_cores.problem import condense

    d = designs("fgm_masses_p1_b16")
    W = baselines.closed_loop_qps(d.problem, condense(d.problem), d, 6, 3)
    ref = baselines.NumpyFgm(d.qp, d.nu, d.c, d.lam_max, d.iterations)
    makers, missing = c_timing.c_makers("fgm", d, tmp_path)
    case = baselines.SwCase("fgm", W, np.array([ref.solve(w)[: d.nu] for w in W]), d.nu, makers, {})
    rows = baselines.time_software(case, 2, lambda line: None)["solvers"]
    assert [r.name for r in rows] == [c_timing.FIXED_NAME, c_timing.FLOAT_NAME]
    assert all(r.times_us.shape == (2, 6) and r.own_us is not None and r.own_median_us > 0 for r in rows)
    assert rows[1].u_err < 1e-9 and rows[0].u_err < 1e-2     # float: numpy's iteration; fixed: b = 16 words
    assert baselines.timer_table({"solvers": rows})[2].startswith(f"| {c_timing.FIXED_NAME} |")
