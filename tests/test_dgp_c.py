"""`make c CORE=dgp`: the generated C99 solvers of the DGP core (mpc_cores/dgp/c.py) against its golden model
DgpFixed, word for word and flag for flag (and the warm-start state, the final dual words y), for the accelerated
and the plain form of examples/masses_state.yaml, compiled by gcc -std=c99 -O2 -Wall -Wextra -Werror -pedantic; the
float variant against dgp_float. Python and gcc only."""
from __future__ import annotations

import ctypes
import subprocess
from collections import Counter

import numpy as np
import pytest

from conftest import REPO
from mpc_cores.csrc import emit, harness
from mpc_cores.dgp.c import write_c
from mpc_cores.dgp.design import ALPHA, design_dgp, shift_sources
from mpc_cores.dgp.model import DgpFixed, dgp_float
from mpc_cores.errors import DesignError
from mpc_cores.problem import load_spec

pytestmark = pytest.mark.skipif(harness.gcc() is None, reason="gcc not found: the C solvers are compiled by gcc")

# the accelerated form, the plain form and the accelerated form with the shifted warm start (design.shift_sources)
FORMS = {"accelerated": dict(accelerated=True), "plain": dict(accelerated=False),
         "shifted": dict(accelerated=True, warm_shift=True)}
# Imax of the random solves: the accelerated form needs 10 to 25 iterations from cold, the plain one 250 to 1000+
# (a warm start near the last solution meets its test in a few)
IMAX_HI = {"accelerated": 20, "plain": 40, "shifted": 20}

SHIM = """\
#include "{file}.h"

size_t shim_state_size(void)
{{
    return sizeof({p}_state_t);
}}

void shim_state_y(const void *state, {io} *y)
{{
    int i;
    for (i = 0; i < {P}_M; i++)
        y[i] = (({p}_state_t *)state)->y[i];
}}

/* one solve (imax < 0: ctrl NULL); flags: warm, iterations, met, then sat, overflow, overflow_signals (fixed) or
   nonfinite (float) */
int shim_solve(void *state, int imax, int warm, int out_all, const {io} *w, {io} *out, int *flags)
{{
    {p}_ctrl_t c;
    {p}_status_t st;
    {v} wv[{P}_NW], ov[{P}_N];
    int i, k;
    c.imax = (uint16_t)imax;
    c.warm_start = (uint8_t)warm;
    c.out_all = (uint8_t)out_all;
    for (i = 0; i < {P}_NW; i++)
        wv[i] = ({v})w[i];
    k = (int){p}_solve(({p}_state_t *)state, imax < 0 ? NULL : &c, wv, ov, &st);
    for (i = 0; i < k; i++)
        out[i] = ov[i];
    flags[0] = st.warm;
    flags[1] = st.iterations;
    flags[2] = st.met;
    {flags}
    return k;
}}
"""


class Lib:
    """A generated DGP solver with the shim above in a shared library: solves, and the state's dual words."""

    def __init__(self, src, nm: emit.Names, cfg: dict, float_: bool):
        file = nm.stem + ("_float" if float_ else "")
        p, P = nm.p + ("_f" if float_ else ""), nm.P + ("_F" if float_ else "")
        io, v = ("double", f"{p}_real_t") if float_ else ("int64_t", f"{p}_word_t")
        flags = "flags[3] = st.nonfinite;" if float_ else ("flags[3] = st.sat;\n    flags[4] = st.overflow;\n"
                                                          "    flags[5] = st.overflow_signals;")
        shim = src / f"{file}_shim.c"
        shim.write_text(SHIM.format(file=file, p=p, P=P, io=io, v=v, flags=flags))
        so = harness.compile_c([src / f"{file}.c", shim], src / f"lib{file}.so", "-fPIC", "-shared", f"-I{src}")
        self.lib = ctypes.CDLL(str(so))
        self.n, self.nw, self.m = int(cfg["n"]), int(cfg["nw"]), 2 * int(cfg["mc"])
        self.float_ = float_
        self.dtype = np.float64 if float_ else np.int64
        self.ct = ctypes.c_double if float_ else ctypes.c_int64
        self.lib.shim_state_size.restype = ctypes.c_size_t
        self.lib.shim_solve.restype = ctypes.c_int

    def new_state(self):
        return ctypes.create_string_buffer(self.lib.shim_state_size())

    def solve(self, state, w, imax, warm=True, out_all=False):
        """(output words or reals, flags, the state's y after the solve); imax None: ctrl NULL."""
        w = np.ascontiguousarray(w, dtype=self.dtype)
        out, y = np.zeros(self.n, dtype=self.dtype), np.zeros(self.m, dtype=self.dtype)
        fl = (ctypes.c_int * 6)()
        ptr = lambda a: a.ctypes.data_as(ctypes.POINTER(self.ct))  # noqa: E731
        k = self.lib.shim_solve(state, -1 if imax is None else int(imax), int(warm), int(out_all), ptr(w), ptr(out),
                                fl)
        self.lib.shim_state_y(state, ptr(y))
        return out[:k], tuple(fl[: 4 if self.float_ else 6]), y


def build(d, out, cfg=None) -> tuple[Lib, Lib]:
    """Generate, compile every file strictly (float also in single precision), run the embedded self test, load
    the fixed-point and float solvers with the shim."""
    files = write_c(d, out, cfg)
    nm = emit.names(d.module_name)
    assert sorted(f.name for f in files) == sorted(f"{nm.stem}{s}" for s in (".h", ".c", "_float.h", "_float.c"))
    harness.compile_c([out / f"{nm.stem}_float.c"], out / "single.o", "-c", f"-D{nm.P}_F_SINGLE")
    exe = harness.compile_c([out / f"{nm.stem}.c"], out / "selftest", "-DMPC_C_SELFTEST")
    p = subprocess.run([str(exe)], capture_output=True, text=True)
    assert p.returncode == 0 and "6 of 6 solves equal" in p.stdout, p.stdout
    cfg = cfg or d.config()
    return Lib(out, nm, cfg, False), Lib(out, nm, cfg, True)


@pytest.fixture(scope="module")
def designs():
    spec = load_spec(REPO / "examples" / "masses_state.yaml")
    return {form: design_dgp(spec, **opts) for form, opts in FORMS.items()}


@pytest.fixture(scope="module")
def built(designs, tmp_path_factory):
    return {form: build(d, tmp_path_factory.mktemp(form)) for form, d in designs.items()}


def replay(cfg: dict, lib: Lib, episodes: int, imax_hi: int, seed: int) -> Counter:
    """Episodes of 4 consecutive solves of a parameter drifting from a random point of the box (as in a closed loop:
    the warm start is close), side by side with the golden model: Imax in [1, imax_hi] or the reset values (ctrl
    NULL), mostly warm, OUT_ALL or not, 5 % of the words outside the box (within the stream word), a reset now and
    then. Asserts (the output words clamped to the input box included) every word, flag, iteration count and the state's dual words; returns what was seen."""
    model = DgpFixed(cfg)
    rng = np.random.default_rng(seed)
    lo, hi = model.xlo, model.xhi
    lim = (1 << (int(cfg["widths"]["stream"]) - 1)) - 1
    nu, imax0 = int(cfg["nu"]), int(cfg["iterations"])
    state, held = lib.new_state(), False
    seen = Counter()
    for ep in range(episodes):
        if rng.random() < 0.2:
            state, held = lib.new_state(), False
            model.reset()
        w0 = rng.integers(lo, hi + 1) * rng.uniform(0.3, 1.0)
        for k in range(4):
            w = np.round(w0 * (1 - 0.05 * k)).astype(np.int64)
            far = rng.random(len(w)) < 0.05
            w = np.where(far, np.where(rng.random(len(w)) < 0.5, rng.integers(np.minimum(hi + 1, lim), lim + 1),
                                       rng.integers(-lim - 1, np.maximum(lo, -lim))), w)
            if rng.random() < 0.1:
                imax, warm, out_all = None, bool(cfg["warm_start"]), bool(cfg["output_all"])
            else:
                imax = imax_hi if rng.random() < 0.5 else int(rng.integers(1, imax_hi + 1))
                warm, out_all = bool(rng.random() < 0.85), bool(rng.random() < 0.3)
            got, flags, y = lib.solve(state, w, imax, warm, out_all)
            r = model.solve(w, imax=imax0 if imax is None else imax, warm=warm)
            exp = r.z[0] if out_all else r.z[0, :nu]
            tag = f"episode {ep} solve {k} (imax={imax}, warm={warm}, out_all={out_all}, w={w.tolist()})"
            assert got.tolist() == exp.tolist(), f"{tag}: C {got.tolist()} != model {exp.tolist()}"
            want = (int(warm and held), int(r.iterations[0]), int(r.met[0]), int(r.sat[0]), int(r.overflow[0]),
                    int(r.overflow[0]))
            assert flags == want, f"{tag}: flags (warm, iterations, met, sat, overflow, signals) {flags} != {want}"
            assert y.tolist() == r.y[0].tolist(), f"{tag}: the state's dual words differ"
            held = True
            seen.update({"solves": 1, "met": bool(r.met[0]), "not met": not r.met[0], "sat": bool(r.sat[0]),
                         "overflow": bool(r.overflow[0]), "warm, y != 0": bool(flags[0] and np.any(y)),
                         "warm met": bool(flags[0] and r.met[0] and np.any(y)), "reset values": imax is None,
                         "out_all": out_all, "clamped": bool(np.any(exp != r.zraw[0, : len(exp)]))})
    return seen


@pytest.mark.parametrize("form", list(FORMS))
def test_bit_exact(form, designs, built):
    """Every word, the output count, the warm, iteration, test, SAT and OVERFLOW flags and the final dual words as
    the golden model's, over warm-started sequences with Imax below and above the iterations needed."""
    seen = replay(designs[form].config(), built[form][0], 10, IMAX_HI[form], seed=len(form))
    for k in ("met", "not met", "sat", "warm met", "reset values", "out_all", "clamped"):
        assert seen[k], (k, seen)


@pytest.mark.parametrize("form", list(FORMS))
def test_bit_exact_saturating(form, designs, tmp_path):
    """The data words cut to one integer bit (values in [-1, 1)), so that the bounds, z, s and g
    saturate (about half of the solves): still every word and flag as the golden model's."""
    d = designs[form]
    cfg = d.config()
    cfg["widths"] = dict(cfg["widths"], data=cfg["frac_bits"] + 1)      # words in [-1, 1)
    seen = replay(cfg, build(d, tmp_path, cfg)[0], 4, 12, seed=3)
    assert seen["overflow"] >= seen["solves"] // 4, seen


def test_headroom_refused(designs, tmp_path):
    """Words too wide for int64_t intermediates are refused with the reason, before any file is written."""
    d = designs["accelerated"]
    cfg = d.config()
    cfg["widths"] = dict(cfg["widths"], data=60)
    with pytest.raises(DesignError, match=r"below 2\^61: .*K: a bh needs \d+ bits"):
        write_c(d, tmp_path, cfg)
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("form", list(FORMS))
def test_float_variant(form, designs, built):
    """The float variant (double) against dgp_float on the unquantised data with the same dual box and warm start,
    over a drifting warm-started sequence: the same iteration counts and test outcomes, the outputs and dual words
    within 1e-9 relative to max(1, |.|) (only the order of the sums differs)."""
    d = designs[form]
    lib = built[form][1]
    rng = np.random.default_rng(5)
    imax = IMAX_HI[form]
    state, y_prev, worst, met = lib.new_state(), None, 0.0, 0
    w0 = rng.uniform(d.xlo, d.xhi) / (1 << d.b) * 0.8
    for k in range(8):
        w = w0 * (1 - 0.04 * k)
        z, flags, y = lib.solve(state, w, imax, True, True)
        y0 = y_prev
        if d.warm_shift and y_prev is not None:              # the shifted warm start, in the float units
            src = shift_sources(d.qp, d.problem)
            y0 = np.where(src >= 0, np.minimum(y_prev[np.maximum(src, 0)], ALPHA * d.d), 0.0)
        zr, it, ok, yr = dgp_float(d.qp, w, imax, d.accelerated, d.eps_g, d.eps_V, ud=ALPHA * d.d, y0=y0)
        assert flags == (int(k > 0), it, int(ok), 0), (k, flags, it, ok)
        worst = max(worst, float(np.abs(z - zr).max() / max(1.0, np.abs(zr).max())),
                    float(np.abs(y - yr).max() / max(1.0, np.abs(yr).max())))
        y_prev, met = yr, met + ok
    assert worst < 1e-9, worst
    assert met, "no solve of the sequence met its test"


def test_detects_a_changed_word(designs, tmp_path):
    """The comparison fails when one coefficient of the C (Fe's first) differs from the golden model's by one LSB."""
    d = designs["accelerated"]
    cfg = d.config()
    bad = dict(cfg, Fe=[[a + (i == j == 0) for j, a in enumerate(row)] for i, row in enumerate(cfg["Fe"])])
    write_c(d, tmp_path, bad)
    with pytest.raises(AssertionError, match="!= model"):
        replay(cfg, Lib(tmp_path, emit.names(d.module_name), bad, False), 3, IMAX_HI["accelerated"], seed=1)
