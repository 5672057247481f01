"""The DGP core as portable C99 (`make c CORE=dgp`): `<module>_solver.{h,c}`, bit-exact against DgpFixed (iteration
(35) of 003 in the order of mpc_cores/dgp/model.py: the input clip, e and the bounds once per solve, the exact row
sums of rounded products, every saturation of a data word and its flag, the plain form's averaged primal and test
(32c), the accelerated form's gap test, gradient restart and beta_k table, the warm start from the final dual y,
the output words clamped to the quantised input box),
and `<module>_solver_float.{h,c}`, the same iteration in double on the unquantised scaled data (dgp_float).

The data words (r + p bits, about 38) times the coefficients (about 30 bits) do not fit int64_t, so a product is
rounded as model.mul_round does it: b = bh 2^k + bl with k = min(20, p), a b = (a bh) 2^k + a bl, each part in
int64_t. The shared text is mpc_cores.csrc; docs/c.md."""
from __future__ import annotations

import dataclasses
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from mpc_cores.csrc import api as capi
from mpc_cores.csrc import emit
from mpc_cores.dgp.design import ALPHA

TITLE = "dual gradient projection (iteration (35) of 003), input and state constraints"
OVF = ("data",)                 # every saturating word (e, bounds, z, s, g, the extrapolated dual) is a data word
STATE = [("data", "y", "the final dual words (y+, y-): upper rows, then lower rows")]
WARM_FROM = "the previous solve's final dual words y"
SPLIT_MAX = 20                  # model.mul_round: the low part of b has min(20, p) bits
IMAX_MAX = 65535                # the IMAX register (ctrl.imax is 16 bits): the plain form's sums grow with it
MET = "uint8_t met;            /* the stopping test held (plain: (32c) on the averages; accelerated: (32c) and gap) */"


def write_c(d, out_dir, cfg: dict | None = None) -> list[Path]:
    """The fixed-point and float solvers of design `d` into out_dir (CoreKind.c_fn); cfg: the config.json the
    fixed-point one is built from (default d.config(); it matches DgpFixed(cfg))."""
    return capi.write_c(d, out_dir, cfg, fixed_files, float_files)


def _bits(v) -> int:
    """Bits of the magnitude of the integer bound v."""
    return int(v).bit_length()


def _mul_bits(a: int, b: int, p: int) -> dict:
    """The intermediates of mpc_mulr(a, b) for |a| <= a, |b| <= b (magnitudes)."""
    k = min(SPLIT_MAX, p)
    return {"a bh": _bits(a * ((b >> k) + 1)), "a bl + rem": _bits(a * (1 << k) + (1 << p) + (1 << (p - 1)))}


def check_headroom(cfg: dict) -> None:
    """Every intermediate of the generated code below 2^HEADROOM_BITS (emit.check_headroom): the split products,
    the row sums, the dual products of the gap and restart tests, the plain form's sums over IMAX_MAX iterations."""
    p, n, mc = int(cfg["frac_bits"]), int(cfg["n"]), int(cfg["mc"])
    dmax = 1 << (int(cfg["widths"]["data"]) - 1)             # |a data word| <= dmax
    ud = max([int(u) for u in cfg["ud"]] + [0])               # y, y_new in [0, ud], |y_new - y| <= ud
    ymax = max(ud, dmax)                                      # |wy|: y_new, or the saturated extrapolation
    xmax = max(abs(int(x)) for x in cfg["xlo"] + cfg["xhi"])
    mats = {"K": (n, mc, 2 * ymax), "G": (mc, n, 2 * dmax), "Fe": (n, cfg["nw"], xmax), "Lb": (mc, cfg["nw"], xmax)}
    off = max([abs(int(b)) for b in cfg["lo0"] + cfg["hi0"]] + [dmax])     # what a row sum is added to
    items = {}
    for k, (r, c, vmax) in mats.items():
        C = np.abs(np.asarray(cfg[k], dtype=np.int64).reshape(r, c))
        cmax, rows = (int(C.max()), int(C.sum(axis=1).max())) if C.size else (0, 0)
        items.update({f"{k}: {what}": v for what, v in _mul_bits(cmax, vmax, p).items()})
        items[f"{k} row sums"] = _bits(rows * vmax // (1 << p) + c + 1 + off)
    items["wy + g"] = _bits(ymax + dmax)
    if cfg["accelerated"]:
        bmax = max(abs(int(x)) for x in cfg["beta"])
        for what, (a, b) in {"gap": (ymax, dmax), "restart": (dmax, ud), "beta (y_new - y)": (bmax, ud)}.items():
            items.update({f"{what}: {w}": v for w, v in _mul_bits(a, b, p).items()})
        items["gap and restart sums"] = _bits(2 * mc * (ymax * dmax // (1 << p) + 1))
        items["extrapolation"] = _bits(ud + bmax * ud // (1 << p) + 1)
    else:
        items["sums of z and g"] = _bits(2 * IMAX_MAX * dmax + IMAX_MAX + 1)
        items["sum of eps_g"] = _bits(IMAX_MAX * abs(int(cfg["eg"])))
    emit.check_headroom(items)


MULR = """\
/* model.mul_round: floor((a b + 2^(FRAC_BITS-1)) / 2^FRAC_BITS) exactly, b split into bh 2^SPLIT + bl
   (0 <= bl < 2^SPLIT) so that a bh and a bl fit int64_t; check_headroom bounds every part below 2^61. */
static int64_t mpc_mulr(int64_t a, int64_t b)
{
    int64_t bh = mpc_floor_shift(b, SPLIT), bl = b - bh * (INT64_C(1) << SPLIT);
    int64_t t = a * bh, hi = mpc_floor_shift(t, FRAC_BITS - SPLIT);
    int64_t rem = (t - hi * (INT64_C(1) << (FRAC_BITS - SPLIT))) * (INT64_C(1) << SPLIT);
    return hi + mpc_floor_shift(rem + a * bl + (INT64_C(1) << (FRAC_BITS - 1)), FRAC_BITS);
}

/* sum_j rnd(row_j v_j): exact (the core's accumulator is wide enough), no saturation before the word's own */
static int64_t row_sum(const COEF_T *row, const int64_t *v, int cols)
{
    int64_t s = 0;
    int j;
    for (j = 0; j < cols; j++)
        s += mpc_mulr(row[j], v[j]);
    return s;
}
"""

FLOOR_DIV = """\
/* floor(a / b) for b > 0 (C99 division truncates toward zero) */
static int64_t floor_div(int64_t a, int64_t b)
{
    int64_t q = a / b;
    return (a % b != 0 && a < 0) ? q - 1 : q;
}
"""


def _start(zero: str, shift: bool) -> str:
    if not shift:
        return f"""\
    /* warm start: the final dual words of the previous solve; cold: y = 0; the operand dual wy = y */
    warm = ctrl->warm_start && state->warm_valid;
    for (i = 0; i < M; i++) {{
        y[i] = warm ? state->y[i] : {zero};
        wy[i] = y[i];
    }}
    for (i = 0; i < N; i++)
        zo[i] = {zero};
"""
    return f"""\
    /* warm start: the final dual words of the previous solve shifted a stage (word i from word SHIFT_SRC[i], zero
       where it is negative), each clipped to its dual box; cold: y = 0; the operand dual wy = y */
    warm = ctrl->warm_start && state->warm_valid;
    for (i = 0; i < M; i++) {{
        y[i] = {zero};
        if (warm && SHIFT_SRC[i] >= 0)
            y[i] = state->y[SHIFT_SRC[i]] < UD[i] ? state->y[SHIFT_SRC[i]] : UD[i];
        wy[i] = y[i];
    }}
    for (i = 0; i < N; i++)
        zo[i] = {zero};
"""


def _iteration(real: bool, accelerated: bool, sat) -> str:
    """One iteration of (35) and its test: integer words (sat: the data word saturation), or reals."""
    if real:
        K = "dotr(K[i], v, MC) + e[i]"
        rnd = lambda a, b: f"({a}) * ({b})"  # noqa: E731
        clip = "clip"
    else:
        K = "row_sum(K[i], v, MC) + e[i]"
        rnd = lambda a, b: f"mpc_mulr({a}, {b})"  # noqa: E731
        clip = "mpc_clip"
    # the fixed-point iteration takes s = G (z - e) against the bounds relative to G e (design.bound_rows)
    G = "dotr(G[i], z, N)" if real else "row_sum(G[i], dz, N)"
    dz = "" if real else """\
        for (i = 0; i < N; i++)                         /* z - e, exact */
            dz[i] = z[i] - e[i];
"""
    head = f"""\
        for (i = 0; i < MC; i++)                        /* v = wy+ - wy- */
            v[i] = wy[i] - wy[MC + i];
        for (i = 0; i < N; i++)                         /* z = K v + e */
            z[i] = {sat(K)};
{dz}        for (i = 0; i < MC; i++) {{                      /* s = G z (words: G (z - e));  g = (s - hi, lo - s) */
            s[i] = {sat(G)};
            g[i] = {sat("s[i] - hi[i]")};
            g[MC + i] = {sat("lo[i] - s[i]")};
        }}
        for (i = 0; i < M; i++)                         /* y_new = clip(wy + g, 0, ud) */
            yn[i] = {clip}(wy[i] + g[i], 0, UD[i]);
"""
    if accelerated:
        beta = "(mpc_real_t)kb / (mpc_real_t)(kb + 3)" if real else "BETA[kb]"
        return head + f"""\
        /* test: g <= eps_g and the gap -sum rnd(wy g) <= eps_V; restart when sum rnd(g (y_new - y)) < 0 */
        stop = 1;
        gap = 0;
        rs = 0;
        for (i = 0; i < M; i++) {{
            stop &= g[i] <= EG;
            gap -= {rnd("wy[i]", "g[i]")};
            rs += {rnd("g[i]", "yn[i] - y[i]")};
        }}
        stop &= gap <= EV;
        kb = rs < 0 ? 0 : (kb + 1 < NBETA ? kb + 1 : NBETA - 1);
        for (i = 0; i < M; i++) {{                      /* wy = y_new, or clip(y_new + beta_k (y_new - y), 0, ud) */
            {"mpc_real_t" if real else "int64_t"} ext = {clip}(yn[i] + {rnd(beta, "yn[i] - y[i]")}, 0, UD[i]);
            wy[i] = rs < 0 ? yn[i] : ext;
            y[i] = yn[i];
        }}
        if (stop || it + 1 == ctrl->imax)
            for (i = 0; i < N; i++)
                zo[i] = z[i];
"""
    avg = "sz[i] / (mpc_real_t)(it + 1)" if real else "floor_div(2 * sz[i] + (int64_t)(it + 1), 2 * (int64_t)(it + 1))"
    tsum = "t = EG * (mpc_real_t)(it + 1);" if real else "t += EG;"
    return head + f"""\
        /* the averages of z and g; test (32c): sum g <= (nu + 1) eps_g */
        stop = 1;
        {tsum}
        for (i = 0; i < N; i++)
            sz[i] += z[i];
        for (i = 0; i < M; i++) {{
            sg[i] += g[i];
            stop &= sg[i] <= t;
            y[i] = wy[i] = yn[i];
        }}
        if (stop || it + 1 == ctrl->imax)
            for (i = 0; i < N; i++)                     /* the averaged primal, rounded to nearest */
                zo[i] = {avg};
"""


def _body(real: bool, accelerated: bool, sat, shift: bool) -> str:
    t = "mpc_real_t" if real else "int64_t"
    if real:
        pre = """\
    for (i = 0; i < N; i++)                             /* e = Fe w;  lo, hi = lo0, hi0 + Lw w */
        e[i] = dotr(FE[i], w_in, NW);
    for (i = 0; i < MC; i++) {
        mpc_real_t c = dotr(LW[i], w_in, NW);
        lo[i] = LO0[i] + c;
        hi[i] = HI0[i] + c;
    }
"""
    else:
        pre = f"""\
    /* the parameter words, saturated to their box (SAT); e = Fe w and the bounds (relative to G e) once per solve */
    for (i = 0; i < NW; i++) {{
        w[i] = mpc_clip(w_in[i], XLO[i], XHI[i]);
        sat |= w[i] != w_in[i];
    }}
    for (i = 0; i < N; i++)
        e[i] = {sat("row_sum(FE[i], w, NW)")};
    for (i = 0; i < MC; i++) {{
        int64_t c = row_sum(LB[i], w, NW);
        lo[i] = {sat("LO0[i] + c")};
        hi[i] = {sat("HI0[i] + c")};
    }}
"""
    decl = ("" if real else "    int64_t w[NW], dz[N];\n") + (f"    {t} e[N], lo[MC], hi[MC], y[M], wy[M], yn[M], "
                                                           f"v[MC], "
                                                    f"z[N], s[MC], g[M], zo[N];\n    unsigned iters = 0;\n"
                                                    "    int met = 0, stop;\n")
    if accelerated:
        decl += f"    {t} gap, rs;\n    int kb = 0;\n"
        init = ""
    else:
        decl += f"    {t} sz[N], sg[M], t = 0;\n"
        init = "    for (i = 0; i < N; i++)\n        sz[i] = 0;\n    for (i = 0; i < M; i++)\n        sg[i] = 0;\n"
    return (decl + pre + _start("0", shift) + init
            + "    for (it = 0; it < ctrl->imax; it++) {\n" + _iteration(real, accelerated, sat) + """\
        iters = it + 1;
        if (stop) {
            met = 1;
            break;
        }
    }
""")


def _epilogue(api: capi.Api) -> str:
    """The state kept (the final y), the output words, the status (iterations run and the test's outcome)."""
    st = [t for t, _, _ in api.state][0]
    if api.float_:
        sets = ["nonfinite = (uint8_t)nonfinite"]
        fin = "    for (i = 0; i < N; i++)\n        nonfinite |= !isfinite(zo[i]);\n"
    else:
        sets = ["sat = sat", "overflow = f_data", f"overflow_signals = (uint8_t)(f_data ? {api.P}_OVF_DATA : 0)"]
        fin = ""
    sets_c = "".join(f"        status->{s};\n" for s in sets)
    # the fixed-point output words are clamped to the quantised input box (the iteration's z stays unclamped)
    clamp, zo = ("", "zo[i]") if api.float_ else ("                         /* clamped to the input box */",
                                                   "mpc_clip(zo[i], OUT_LO[i], OUT_HI[i])")
    return f"""\
    for (i = 0; i < M; i++)
        state->y[i] = ({st})y[i];
{fin}    state->warm_valid = 1;
    nout = ctrl->out_all ? N : NU;
    for (i = 0; i < nout; i++){clamp}
        out[i] = ({api.value_t}){zo};
    if (status) {{
        status->iterations = (uint16_t)iters;
        status->warm = (uint8_t)warm;
        status->met = (uint8_t)met;
{sets_c}    }}
    return (unsigned)nout;
}}
"""


def _files(api: capi.Api, cfg: dict, title: str, what: str, data: str, body: str, vectors=None) -> dict[str, str]:
    """capi.solver_files with the DGP epilogue."""
    head = capi.source_head(api, title + ("" if api.float_ else ", bit-exact against its golden model."),
                            ("math.h",) if api.float_ else ())
    c = (head + data + "\n" + capi.solve_prologue(api) + body + _epilogue(api)
         + (capi.selftest(api, vectors) if vectors else ""))
    return {f"{api.file}.h": capi.header(api, cfg, title, what), f"{api.file}.c": c}


def _dgp_api(api: capi.Api, mc: int) -> capi.Api:
    return dataclasses.replace(api, state_len="M", warm_from=WARM_FROM, status=api.status + [MET],
                               defines=[("M", str(2 * mc), "dual words y: upper rows, then lower rows")]
                               + list(api.defines))


class _OneSolve:
    """DgpFixed with one solve's answer unpacked (z, sat, overflow), as capi.selftest_vectors reads it."""

    def __init__(self, model):
        self.model = model

    def solve(self, w, imax=None, warm=None):
        r = self.model.solve(w, imax=imax, warm=warm)
        return SimpleNamespace(z=r.z[0], sat=bool(r.sat[0]), overflow=bool(r.overflow[0]),
                               iterations=int(r.iterations[0]))


def _sizes(P: str, mc: int) -> str:
    return f"#define M {P}_M\n#define MC {mc}                  /* constraint rows: y+ and y- have MC words each */\n"


def fixed_files(nm: emit.Names, cfg: dict) -> dict[str, str]:
    from mpc_cores.dgp.model import DgpFixed

    check_headroom(cfg)
    n, nw, mc, p = int(cfg["n"]), int(cfg["nw"]), int(cfg["mc"]), int(cfg["frac_bits"])
    acc = bool(cfg["accelerated"])
    api = _dgp_api(capi.fixed_api(nm, cfg, STATE, OVF), mc)
    mats = {k: np.array(cfg[k], dtype=np.int64).reshape(r, c)
            for k, r, c in (("K", n, mc), ("G", mc, n), ("Fe", n, nw), ("Lb", mc, nw))}
    coefs = np.concatenate([m.ravel() for m in mats.values()])

    def sat(x: str) -> str:
        return f"mpc_sat({x}, W_DATA_LO, W_DATA_HI, &f_data)"

    beta = (f"#define NBETA {len(cfg['beta'])}\n{emit.array('BETA', cfg['beta'])}" if acc else "")
    data = f"""\
{_sizes(api.P, mc)}#define FRAC_BITS {p}
#define SPLIT {min(SPLIT_MAX, p)}
#define COEF_T {emit.int_type(coefs)}
#define EG {emit.int_lit(cfg["eg"])}
#define EV {emit.int_lit(cfg["eV"])}
{emit.width_macros(cfg["widths"], OVF)}
/* K = -Q^-1 G', G, Fe = -Q^-1 Phi, Lb = Lw - G Fe words; the bounds' constant parts, the dual box alpha d, the box of
   accepted parameter words w = (x, r), the input box of the output words{"; the table beta_k = k / (k + 3)" if acc else ""} */
{emit.array("K", mats["K"], ctype="COEF_T")}{emit.array("G", mats["G"], ctype="COEF_T")}\
{emit.array("FE", mats["Fe"], ctype="COEF_T")}{emit.array("LB", mats["Lb"], ctype="COEF_T")}\
{emit.array("LO0", cfg["lo0"])}{emit.array("HI0", cfg["hi0"])}{emit.array("UD", cfg["ud"])}\
{emit.array("XLO", cfg["xlo"])}{emit.array("XHI", cfg["xhi"])}\
{emit.array("OUT_LO", cfg["out_lo"])}{emit.array("OUT_HI", cfg["out_hi"])}{beta}{_shift_table(cfg)}
{emit.helpers(cfg["rounding"], "floor", "clip", "sat")}
{MULR}{"" if acc else chr(10) + FLOOR_DIV}"""
    vectors = capi.selftest_vectors(_OneSolve(DgpFixed(cfg)), cfg["xlo"], cfg["xhi"], int(cfg["widths"]["stream"]),
                                    cfg)
    form = "accelerated (gradient restart, gap test)" if acc else "plain (averaged primal, test (32c))"
    return _files(api, cfg, f"the DGP core {nm.module} in C99 integer arithmetic", f"{TITLE}, {form}; the same "
                  "words as the core and its golden model (mpc_cores.dgp.model.DgpFixed), flags included.", data,
                  _body(False, acc, sat, bool(cfg.get("shift_src"))), vectors)


def _shift_table(cfg: dict) -> str:
    """The shifted warm start's sources (design.shift_sources), when the design has warm_shift."""
    src = cfg.get("shift_src") or []
    return ("/* the shifted warm start: dual word i starts from word SHIFT_SRC[i] of the previous solve's final "
            "dual (-1: zero) */\n" + emit.array("SHIFT_SRC", src)) if src else ""


def float_data(d) -> dict:
    """dgp_float's data: the scaled problem (K, G, Fe, Lw, lo0, hi0), the dual box alpha d, eps_g sigma, eps_V."""
    q = d.qp
    return {"K": q.K, "G": q.G, "Fe": q.Fe, "Lw": q.Lw, "lo0": q.lo0, "hi0": q.hi0, "ud": ALPHA * np.asarray(d.d),
            "eg": d.eps_g * q.sigma, "eV": d.eps_V}


DOTR = """\
static mpc_real_t dotr(const mpc_real_t *row, const mpc_real_t *v, int cols)
{
    mpc_real_t s = 0;
    int j;
    for (j = 0; j < cols; j++)
        s += row[j] * v[j];
    return s;
}

static mpc_real_t clip(mpc_real_t x, mpc_real_t lo, mpc_real_t hi)
{
    return x < lo ? lo : (x > hi ? hi : x);
}
"""


def float_files(nm: emit.Names, d, cfg: dict) -> dict[str, str]:
    api, fd = _dgp_api(capi.float_api(nm, [(n, c) for _, n, c in STATE]), d.mc), float_data(d)
    real = lambda name: emit.array(name.upper(), fd[name], real=True)  # noqa: E731
    data = f"""\
{_sizes(api.P, d.mc)}#define EG (({api.value_t}){emit.real_lit(fd["eg"])})
#define EV (({api.value_t}){emit.real_lit(fd["eV"])})
#define NBETA 256
/* the scaled problem: K = -Q^-1 G', G, Fe = -Q^-1 Phi, Lw, lo0, hi0; the dual box alpha d */
{real("K")}{real("G")}{real("Fe")}{real("Lw")}{real("lo0")}{real("hi0")}{real("ud")}{_shift_table(cfg)}
{DOTR}"""
    form = "accelerated" if d.accelerated else "plain"
    return _files(api, cfg, f"the DGP solver of the core {nm.module} in floating point (double, or float with "
                  f"-D{api.P}_SINGLE)", f"{TITLE}, {form}; the iteration on the unquantised data (not bit-exact: "
                  "the fixed-point solver is).", data, _body(True, d.accelerated, lambda x: x, bool(cfg.get("shift_src"))))
