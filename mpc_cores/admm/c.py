"""The ADMM core as portable C99 (`make c CORE=admm`): `<module>_solver.{h,c}`, bit-exact against AdmmFixed (the
order of operations in mpc_cores/admm/model.py: the input clip, G~ (w, 1) once, the shifts by k_j, the adder trees,
the integer projection with its rounded halving, every saturation and its flag, the warm start of (z, nu)), and
`<module>_solver_float.{h,c}`, Algorithm 2 of 002 in double on the unquantised data with the same rho_j and warm
start (AdmmFloat(d)). The shared text is mpc_cores.csrc.emit; docs/c.md."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from mpc_cores.admm.model import ACC_STATES, ETA_SHIFT, shift_stages
from mpc_cores.admm.problem import BOX
from mpc_cores.csrc import api as capi
from mpc_cores.csrc import emit
from mpc_cores.errors import DesignError

TITLE = "ADMM (Algorithm 2 of 002) with input-rate and soft state constraints"
OVF = ("v", "y", "q", "z", "d", "nu", "sum")     # AdmmSolveResult.flags, in the order of the overflow_signals bits
STATE = [("z", "z", "the last solution"), ("nu", "nu", "its multipliers")]


def state_of(cfg: dict) -> list[tuple[str, str, str]]:
    """The arrays kept between solves: z and nu, and for vucondat the last primal iterate y (which holds z after a
    cold start: the wider of the two words)."""
    if cfg.get("method", "admm") != "vucondat":
        return STATE
    w = cfg["widths"]
    return STATE + [("z" if w["z"] > w["y"] else "y", "y", "the last primal iterate (Vu-Condat)")]


# the method's operand v (mpc_cores.admm.model): admm rho z - nu, ama -nu, vucondat sigma (y + z) - nu
V_FIXED = {"admm": "mpc_shift_by(z[i], K[i]) - nu[i]", "ama": "-nu[i]",
           "vucondat": "mpc_shift_by(y[i] + z[i], K[i]) - nu[i]"}
V_FLOAT = {"admm": "RHO[i] * z[i] - nu[i]", "ama": "-nu[i]", "vucondat": "RHO[i] * (y[i] + z[i]) - nu[i]"}


def write_c(d, out_dir, cfg: dict | None = None) -> list[Path]:
    """The fixed-point and float solvers of design `d` into out_dir (CoreKind.c_fn); cfg: the config.json the
    fixed-point one is built from (default d.config(); it matches AdmmFixed(cfg))."""
    return capi.write_c(d, out_dir, cfg, fixed_files, float_files)


def warm_source(cfg: dict) -> np.ndarray:
    """Index of z (and nu) each component of the warm start comes from: the model's own shift_stages."""
    return shift_stages(np.arange(int(cfg["n"])), int(cfg["N"]), int(cfg["nu"]))


def check_headroom(cfg: dict) -> None:
    """Every intermediate of the generated code below 2^HEADROOM_BITS (emit.check_headroom)."""
    w, b = cfg["widths"], int(cfg["frac_bits"])
    wb = lambda k: emit.width_bits(w, k)  # noqa: E731
    k = np.asarray(cfg["shift"], dtype=np.int64)
    up, down = max(0, int(k.max())), max(0, -int(k.min()))
    soft = [abs(int(x)) for x in cfg["soft_c"] + cfg["soft_r"]] + [1]
    emit.check_headroom({
        "products": wb("coef") + max(wb("v"), wb("w"), b + 1) + 1,
        "sum of |products|": wb("sum") + math.ceil(math.log2(int(cfg["n"]))),
        "rho z - nu": max(wb("z") + up, wb("nu")) + 1,
        "sigma (y + z) - nu": max(max(wb("y"), wb("z")) + 1 + up, wb("nu")) + 1,
        "y + nu / rho": max(wb("y"), wb("nu") + down) + 1,
        "projection": max(wb("q"), max(soft).bit_length()) + 4,
        "nu + rho (y - z)": max(wb("nu"), wb("d") + up, wb("y") + 1, wb("z") + 1) + 1,
        **(_acc_headroom(cfg, wb, b, up, down) if cfg.get("accelerated") else {}),
    })


def _acc_headroom(cfg: dict, wb, b: int, up: int, down: int) -> dict:
    """accelerated: the momentum products, the restart test's products and sum"""
    cur = {"y": max(wb("y"), wb("z")), "z": wb("z"), "nu": wb("nu")}
    ks = ACC_STATES[cfg.get("method", "admm")]
    logn = math.ceil(math.log2(3 * int(cfg["n"]) + 1))
    out = {f"mom ({k} - prev)": b + 2 + cur[k] + 2 for k in ks}
    if ks == ("nu",):
        out.update({"d (nu - prev)": wb("d") + wb("nu") + 2, "gradient test sum": wb("d") + wb("nu") + 2 - b + logn})
    else:
        sq = max(2 * (cur[k] + 1) for k in ks)
        out.update({"(x - x^)^2": sq + 1, "residual test sum": sq - b + max(up, down) + logn + 1})
    return out


def _proj(real: bool) -> str:
    """The projection onto K: boxes clipped, free components passed, soft pairs (x, d) onto |x - c| <= r + d,
    d >= 0; in integers as mpc_cores.admm.model.proj_soft (the halving rounded), in reals as project_soft."""
    t, clip = ("mpc_real_t", "clip") if real else ("int64_t", "mpc_clip")
    half = "(e + d) / 2" if real else "mpc_rnd(e + d, 1)"
    over = "m <= 0" if real else "e + d <= 0"
    return f"""\
static void proj(const {t} *q, {t} *z)
{{
    int i;
    for (i = 0; i < N; i++)
        z[i] = KIND[i] == KIND_BOX ? {clip}(q[i], LO[i], HI[i]) : q[i];
    for (i = 0; i < NS; i++) {{
        {t} x = q[SX[i]], d = q[SD[i]], c = SC[i], r = SR[i];
        {t} t = x - c, e = (t < 0 ? -t : t) - r, m = {half};
        if (d >= 0 && d >= e)
            continue;                                   /* inside: z = q */
        if (e <= 0) {{                                   /* below the flat edge */
            z[SD[i]] = 0;
        }} else if ({over}) {{                        /* beyond the corner */
            z[SX[i]] = t < 0 ? c - r : c + r;
            z[SD[i]] = 0;
        }} else {{                                        /* onto the slanted edge */
            z[SX[i]] = t < 0 ? c - (r + m) : c + (r + m);
            z[SD[i]] = m;
        }}
    }}
}}
"""


# The solve's start: warm, (z, nu) of the last solve shifted by one stage; cold, z = proj(0), nu = 0.
START = """\
    /* warm start: (z, nu) of the last solve shifted by one stage; cold: z = proj(0), nu = 0 */
    warm = ctrl->warm_start && state->warm_valid;
    for (i = 0; i < N; i++) {
        z[i] = warm ? state->z[WARM_SRC[i]] : 0;
        nu[i] = warm ? state->nu[WARM_SRC[i]] : 0;
    }
    if (!warm) {
        for (i = 0; i < N; i++)
            q[i] = 0;
        proj(q, z);
    }
"""
# Vu-Condat: the last primal iterate y, shifted like z (cold: y = z)
START_Y = """\
    for (i = 0; i < N; i++)
        y[i] = warm ? state->y[WARM_SRC[i]] : z[i];
"""


def start(cfg: dict) -> str:
    return START + (START_Y if cfg.get("method", "admm") == "vucondat" else "")


def _data(cfg_or: dict, real: bool) -> str:
    """The projection's data (kinds, boxes, soft pairs) and the warm start's source indices."""
    lo, hi, sc, sr = (cfg_or[k] for k in ("lo", "hi", "soft_c", "soft_r"))
    arr = (lambda nm, v: emit.array(nm, v, real=True)) if real else emit.array
    return (f"#define NS {len(cfg_or['soft_x'])}               /* soft pairs (x, delta), all stages */\n"
            f"#define KIND_BOX {BOX}\n" + emit.array("KIND", cfg_or["kind"], ctype="uint8_t")
            + arr("LO", lo) + arr("HI", hi) + emit.array("SX", cfg_or["soft_x"], ctype="int")
            + emit.array("SD", cfg_or["soft_d"], ctype="int") + arr("SC", sc) + arr("SR", sr)
            + emit.array("WARM_SRC", warm_source(cfg_or), ctype="int"))


# Accelerated (cfg["accelerated"], mpc_cores.admm.model.AdmmFixed): the states hold x^, prev_x the last iteration's
# x, hat_x the x an iteration read (the residual test), dd the iteration's d (AMA's gradient test), idx the momentum
# index, thr the residual test's threshold (-1: none yet)
def _keys(cfg: dict) -> tuple[str, ...]:
    return ACC_STATES[cfg.get("method", "admm")]


def acc_decl(cfg: dict) -> str:
    ks = _keys(cfg)
    arrays = [f"prev_{k}[N], cand_{k}[N]" for k in ks] + (["dd[N]"] if ks == ("nu",) else
                                                          [f"hat_{k}[N]" for k in ks])
    thr = "" if ks == ("nu",) else ", thr = -1"
    return f"\n    int64_t {', '.join(arrays)}{thr};\n    int idx = 0;"


def acc_start(cfg: dict) -> str:
    return "    for (i = 0; i < N; i++) {\n" + "".join(f"        prev_{k}[i] = {k}[i];\n" for k in _keys(cfg)) + "    }\n"


def acc_hat(cfg: dict) -> str:
    if _keys(cfg) == ("nu",):
        return ""
    return ("        for (i = 0; i < N; i++) {                       /* x^, what this iteration reads */\n"
            + "".join(f"            hat_{k}[i] = {k}[i];\n" for k in _keys(cfg)) + "        }\n")


ACC_KEEP_D = "\n            dd[i] = d;"


def _momentum(cfg: dict) -> str:
    if not cfg.get("accelerated"):
        return ""
    return (f"#define NMOM {len(cfg['momentum'])}\n#define ETA_SHIFT {ETA_SHIFT}\n"
            "/* accelerated: the momentum words (a_i - 1) / a_(i+1) */\n" + emit.array("MOM", cfg["momentum"]))


def acc_step(cfg: dict, sat) -> str:
    """After the nu update: the restart test (AMA: gradient; ADMM, Vu-Condat: the combined residual against the
    threshold), the candidates x + mom (x - prev), and after every iteration but the last the next x^ (the
    candidate, or x on a restart) and the momentum index."""
    ks = _keys(cfg)
    cands = "".join(f"""
                cand_{k}[i] = {sat(k, f"{k}[i] + mpc_rnd(MOM[idx] * ({k}[i] - prev_{k}[i]), FRAC_BITS)")};""" for k in ks)
    if ks == ("nu",):
        terms = "\n                test += mpc_floor_shift(dd[i] * (nu[i] - prev_nu[i]), FRAC_BITS);"
        ok = "test >= 0"
        thr = ""
    else:
        terms = "".join(f"""
                dx = mpc_floor_shift(({k}[i] - hat_{k}[i]) * ({k}[i] - hat_{k}[i]), FRAC_BITS);
                test += {"-K[i]" if k == "nu" else "K[i]"} >= 0 ? dx * (INT64_C(1) << ({"-K[i]" if k == "nu" else "K[i]"})) : mpc_floor_shift(dx, {"K[i]" if k == "nu" else "-K[i]"});""" for k in ks)
        ok = "thr < 0 || test < thr"
        thr = "\n            thr = ok ? test - mpc_floor_shift(test, ETA_SHIFT) : thr + mpc_floor_shift(thr, ETA_SHIFT);"
    moves = "".join(f"""
                    prev_{k}[i] = {k}[i];
                    if (ok)
                        {k}[i] = cand_{k}[i];""" for k in ks)
    return f"""
        {{                                              /* accelerated: restart test and momentum */
            int64_t test = 0{", dx" if ks != ("nu",) else ""};
            int ok;
            for (i = 0; i < N; i++) {{{terms}{cands}
            }}
            ok = {ok};{thr}
            if (it + 1 < ctrl->imax) {{
                for (i = 0; i < N; i++) {{{moves}
                }}
                idx = ok ? (idx + 1 < NMOM ? idx + 1 : idx) : 0;
            }}
        }}"""


def fixed_files(nm: emit.Names, cfg: dict) -> dict[str, str]:
    from mpc_cores.admm.model import AdmmFixed

    check_headroom(cfg)
    api = capi.fixed_api(nm, cfg, state_of(cfg), OVF)
    api.split = "s = M11 v"
    method = cfg.get("method", "admm")
    n, nw = int(cfg["n"]), int(cfg["nw"])
    if nw + 1 > n:
        raise DesignError(f"the C solver (like the golden model) pads G~'s nw + 1 = {nw + 1} columns to n_A = {n}")
    M = np.array(cfg["M11"], dtype=np.int64).reshape(n, n)
    G = np.array(cfg["G"], dtype=np.int64).reshape(n, nw + 1)
    model = AdmmFixed(cfg)

    chunks = int(cfg.get("chunks", 1))
    lanes = -(-max(n, nw + 1) // chunks)
    tree_defs = ("#define TREE_MAX N               /* operands of the adder tree: n_A */" if chunks == 1 else
                 f"#define LANES {lanes}               /* multipliers of the row unit: a row in CHUNKS chunks */\n"
                 f"#define CHUNKS {chunks}\n#define TREE_MAX LANES")

    def dot(row: str, v: str, cols: str) -> str:
        if chunks == 1:
            return f"mpc_dot({row}, {v}, {cols}, TREE_MAX, W_SUM_LO, W_SUM_HI, &f_sum)"
        return f"dot_chunks({row}, {v}, {cols}, &f_sum)"

    def sat(k: str, x: str) -> str:
        return f"mpc_sat({x}, W_{k.upper()}_LO, W_{k.upper()}_HI, &f_{k})"

    data = f"""\
#define FRAC_BITS {cfg["frac_bits"]}
{tree_defs}
#define COEF_T {emit.int_type(np.concatenate([M.ravel(), G.ravel()]))}
{emit.width_macros(cfg["widths"], OVF)}
/* M11 and G~ words (G~'s last column multiplies the word 2^b), rho_j = 2^K[j], the box of parameter words */
{emit.array("M11", M, ctype="COEF_T")}{emit.array("G", G, ctype="COEF_T")}\
{emit.array("K", cfg["shift"], ctype="int8_t")}{emit.array("WLO", cfg["wlo"])}{emit.array("WHI", cfg["whi"])}\
{_data(cfg, False)}{_momentum(cfg)}
{emit.helpers(cfg["rounding"], "clip", "dot", "shift_by")}
{CHUNKED_DOT if chunks > 1 else ""}{_proj(False)}"""
    acc = bool(cfg.get("accelerated"))
    w_form = "(x, u_prev, r)" if cfg.get("rate", True) else "(x, r)"   # the QP's form (mpc_cores.admm.problem)
    body = f"""\
    int64_t w[NW + 1], gw[N], z[N], nu[N], v[N], s[N], y[N], q[N];{acc_decl(cfg) if acc else ""}
    /* w = {w_form} saturated to its box (SAT), then the constant word 2^b; G~ (w, 1) once per solve */
    for (i = 0; i < NW; i++) {{
        w[i] = mpc_clip(w_in[i], WLO[i], WHI[i]);
        sat |= w[i] != w_in[i];
    }}
    w[NW] = INT64_C(1) << FRAC_BITS;
    for (i = 0; i < N; i++)
        gw[i] = {dot("G[i]", "w", "NW + 1")};
{start(cfg)}{acc_start(cfg) if acc else ""}\
    for (it = 0; it < ctrl->imax; it++) {{
{acc_hat(cfg) if acc else ""}\
        for (i = 0; i < N; i++)                         /* v, the method's operand ({method}) */
            v[i] = {sat("v", V_FIXED[method])};
        if (linstep) {{                                  /* s = M11 v: the caller's (the split) */
            int r = linstep(user, v, s);
            if (r < 0)
                return 0;
            if (r > 0)
                f_sum = 1;
        }} else {{
            for (i = 0; i < N; i++)
                s[i] = {dot("M11[i]", "v", "N")};
        }}
        for (i = 0; i < N; i++) {{                       /* y = M11 v + G~ (w, 1);  q = y + nu / rho */
            y[i] = {sat("y", "s[i] + gw[i]")};
            q[i] = {sat("q", "y[i] + mpc_shift_by(nu[i], -K[i])")};
        }}
        proj(q, z);
        for (i = 0; i < N; i++) {{                       /* nu += rho (y - z) */
            int64_t d;
            z[i] = {sat("z", "z[i]")};
            d = {sat("d", "y[i] - z[i]")};
            nu[i] = {sat("nu", "nu[i] + mpc_shift_by(d, K[i])")};{ACC_KEEP_D if acc and _keys(cfg) == ("nu",) else ""}
        }}{acc_step(cfg, sat) if acc else ""}
    }}
"""
    vectors = capi.selftest_vectors(model, model.wlo, model.whi, int(cfg["widths"]["stream"]), cfg)
    return capi.solver_files(api, cfg, f"the ADMM core {nm.module} in C99 integer arithmetic", f"{TITLE}; the same "
                             "words as the core and its golden model (mpc_cores.admm.model.AdmmFixed), flags "
                             "included.", data, body, vectors)


def float_data(d) -> dict:
    """Algorithm 2's data in float64 (AdmmFloat(d, quantised=False)): M11, G~, rho_j, the projection's sets."""
    q = d.qp
    box = q.kind == BOX
    return {"M11": d.M11f, "G": d.Gf, "rho": d.rho_vec, "kind": q.kind, "soft_x": q.soft_x, "soft_d": q.soft_d,
            "lo": np.where(box, q.lo, 0.0), "hi": np.where(box, q.hi, 0.0), "soft_c": q.soft_c, "soft_r": q.soft_r,
            "n": d.n, "N": d.N, "nu": d.nu}


def float_files(nm: emit.Names, d, cfg: dict) -> dict[str, str]:
    api, fd = capi.float_api(nm, [(n, c) for _, n, c in state_of(cfg)]), float_data(d)
    method = cfg.get("method", "admm")
    data = f"""\
/* M11 and G~ (its last column multiplies 1), rho_j and 1 / rho_j (powers of two) */
{emit.array("M11", fd["M11"], real=True)}{emit.array("G", fd["G"], real=True)}\
{emit.array("RHO", fd["rho"], real=True)}{emit.array("IRHO", 1.0 / fd["rho"], real=True)}\
{_data(fd, True)}
static mpc_real_t clip(mpc_real_t x, mpc_real_t lo, mpc_real_t hi)
{{
    return x < lo ? lo : (x > hi ? hi : x);
}}

{_proj(True)}"""
    body = f"""\
    mpc_real_t gw[N], z[N], nu[N], v[N], y[N], q[N];
    int j;
    for (i = 0; i < N; i++) {{
        mpc_real_t s = 0;
        for (j = 0; j < NW; j++)
            s += G[i][j] * w_in[j];
        gw[i] = s + G[i][NW];
    }}
{start(cfg)}\
    for (it = 0; it < ctrl->imax; it++) {{
        for (i = 0; i < N; i++)
            v[i] = {V_FLOAT[method]};
        for (i = 0; i < N; i++) {{
            mpc_real_t s = 0;
            for (j = 0; j < N; j++)
                s += M11[i][j] * v[j];
            y[i] = s + gw[i];
            q[i] = y[i] + nu[i] * IRHO[i];
        }}
        proj(q, z);
        for (i = 0; i < N; i++)
            nu[i] += RHO[i] * (y[i] - z[i]);
    }}
"""
    return capi.solver_files(api, cfg, f"the ADMM solver of the core {nm.module} in floating point (double, or float "
                             f"with -D{api.P}_SINGLE)", f"{TITLE}; Algorithm 2 on the unquantised data (not "
                             "bit-exact: the fixed-point solver is).", data, body)


CHUNKED_DOT = """\
/* A row in CHUNKS chunks of LANES columns (AdmmCore with chunks > 1): each chunk's tree, then the exact sum of the
   chunks, saturated once */
static int64_t dot_chunks(const COEF_T *row, const int64_t *v, int cols, uint8_t *flag)
{
    int64_t s = 0;
    int c;
    for (c = 0; c < CHUNKS && c * LANES < cols; c++) {
        int k = cols - c * LANES;
        s += mpc_dot(row + c * LANES, v + c * LANES, k < LANES ? k : LANES, LANES, W_SUM_LO, W_SUM_HI, flag);
    }
    return mpc_sat(s, W_SUM_LO, W_SUM_HI, flag);
}
"""
