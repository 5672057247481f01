"""The FGM core as portable C99 (`make c CORE=fgm`): `<module>_solver.{h,c}`, bit-exact against FgmFixed (the same
words, rounding, adder-tree order, saturation and warm start), and `<module>_solver_float.{h,c}`, Algorithm 1 of 002
in double on the unquantised normalised data, warm-started like the core (mpc_bench.baselines.NumpyFgm's
iteration). The shared text is mpc_cores.csrc; docs/c.md."""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from mpc_cores.csrc import api as capi
from mpc_cores.csrc import emit

TITLE = "fast gradient method (Algorithm 1 of 002), input-constrained MPC"
OVF = ("sum", "t", "y")         # the datapath words that saturate, in the order of the overflow_signals bits
STATE = [("z", "z", "the last solution")]


def write_c(d, out_dir, cfg: dict | None = None) -> list[Path]:
    """The fixed-point and float solvers of design `d` into out_dir (CoreKind.c_fn); cfg: the config.json the
    fixed-point one is built from (default d.config(); it matches FgmFixed(cfg))."""
    return capi.write_c(d, out_dir, cfg, fixed_files, float_files)


def check_headroom(cfg: dict) -> None:
    """Every intermediate of the generated code below 2^HEADROOM_BITS (emit.check_headroom)."""
    w = cfg["widths"]
    wb = lambda k: emit.width_bits(w, k)  # noqa: E731
    m = max(int(cfg["n"]), int(cfg["nw"]))
    emit.check_headroom({
        "products": wb("coef") + max(wb("x"), wb("y")) + 1,
        "sum of |products|": wb("sum") + (math.ceil(math.log2(m)) if m > 1 else 0),
        "t": wb("sum") + 1,
        "(1 + beta) z": wb("beta") + wb("z") + 1,
    })


def _start(clip: str, lo: str, hi: str) -> str:
    """The solve's start: warm, the previous solution shifted by one stage with the last stage repeated; cold, the
    box's point nearest 0."""
    return f"""\
    warm = ctrl->warm_start && state->warm_valid;
    for (i = 0; i < N; i++) {{
        z[i] = warm ? state->z[i < N - NU ? i + NU : i] : {clip}(0, {lo}[i], {hi}[i]);
        y[i] = z[i];
    }}
"""


# The exit test (FgmCore): the largest |z+ - z| of an iteration; the solve ends after an iteration where it and the
# previous iteration's are below EXIT_TOL (the first iteration's previous step is 0)
MET = "uint8_t met;            /* ITERATIONS.MET: the exit test ended the solve (else IMAX) */"
exit_decl = """
    int64_t step, big;
    int ok, prev_ok = 1, met = 0;"""
exit_ok = """
        ok = 1;"""
exit_step = """
            step = zn[i] - z[i];
            big = step < 0 ? -step : step;
            if (big >= (int64_t)ctrl->exit_tol)
                ok = 0;"""
exit_test = """
        met = ok && prev_ok;
        prev_ok = ok;
        if (met) {
            it++;
            break;
        }"""
exit_end = """
    if (status)
        status->met = (uint8_t)met;"""


def fixed_files(nm: emit.Names, cfg: dict) -> dict[str, str]:
    from mpc_cores.fgm.model import FgmFixed

    check_headroom(cfg)
    api = capi.fixed_api(nm, cfg, STATE, OVF)
    early = bool(cfg.get("early_exit"))
    if early:                   # the exit test: EXIT_TOL as a setting, ITERATIONS.COUNT and MET in the status
        api = dataclasses.replace(api, ctrl_extra=(("uint32_t", "exit_tol", "EXIT_TOL: the exit test's tolerance, a "
                                                    "word of z (0: none)", "EXIT_TOL"),),
                                  defines=list(api.defines) + [("EXIT_TOL", str(int(cfg["exit_tol"])),
                                                                "reset value of EXIT_TOL")],
                                  status=api.status + [MET], iters="it")
    n, nw = int(cfg["n"]), int(cfg["nw"])
    A = np.array(cfg["A"], dtype=np.int64).reshape(n, n)
    F = np.array(cfg["F"], dtype=np.int64).reshape(n, nw)
    model = FgmFixed(cfg)
    data = f"""\
#define FRAC_BITS {cfg["frac_bits"]}
#define TREE_MAX {max(n, nw)}          /* operands of the adder tree: max(n, nw) */
#define COEF_T {emit.int_type(np.concatenate([A.ravel(), F.ravel()]))}
#define BETA INT64_C({int(cfg["beta"])})
#define ONE_PLUS_BETA INT64_C({int(cfg["one_plus_beta"])})
{emit.width_macros(cfg["widths"], OVF)}
/* (I - H_n) and Phi_n words, the box of z, the box of accepted parameter words w = (x, r) */
{emit.array("A", A, ctype="COEF_T")}{emit.array("F", F, ctype="COEF_T")}{emit.array("LO", cfg["lo"])}\
{emit.array("HI", cfg["hi"])}{emit.array("XLO", cfg["xlo"])}{emit.array("XHI", cfg["xhi"])}
{emit.helpers(cfg["rounding"], "clip", "dot")}"""
    body = f"""\
    int64_t w[NW], h[N], z[N], y[N], zn[N];{exit_decl if early else ""}
    /* the parameter words, saturated to their box (SAT); h = Phi_n w once per solve */
    for (i = 0; i < NW; i++) {{
        w[i] = mpc_clip(w_in[i], XLO[i], XHI[i]);
        sat |= w[i] != w_in[i];
    }}
    for (i = 0; i < N; i++)
        h[i] = mpc_dot(F[i], w, NW, TREE_MAX, W_SUM_LO, W_SUM_HI, &f_sum);
{_start("mpc_clip", "LO", "HI")}\
    for (it = 0; it < ctrl->imax; it++) {{
        /* z+ = clip(sat((I - H_n) y - h), lo, hi) */
        for (i = 0; i < N; i++)
            zn[i] = mpc_clip(mpc_sat(mpc_dot(A[i], y, N, TREE_MAX, W_SUM_LO, W_SUM_HI, &f_sum) - h[i],
                                     W_T_LO, W_T_HI, &f_t), LO[i], HI[i]);
        /* y = sat(rnd((1 + beta) z+) - rnd(beta z)) */{exit_ok if early else ""}
        for (i = 0; i < N; i++) {{{exit_step if early else ""}
            y[i] = mpc_sat(mpc_rnd(ONE_PLUS_BETA * zn[i], FRAC_BITS) - mpc_rnd(BETA * z[i], FRAC_BITS), W_Y_LO,
                           W_Y_HI, &f_y);
            z[i] = zn[i];
        }}{exit_test if early else ""}
    }}{exit_end if early else ""}
"""
    tols = [int(cfg.get("exit_tol", 0)), 1 << max(0, int(cfg["frac_bits"]) - 5), 0]
    vectors = capi.selftest_vectors(model, model.xlo, model.xhi, int(cfg["widths"]["stream"]), cfg,
                                    extra=(lambda k: {"exit_tol": tols[k % 3]}) if early else None)
    return capi.solver_files(api, cfg, f"the FGM core {nm.module} in C99 integer arithmetic", f"{TITLE}; the same "
                             "words as the core and its golden model (mpc_cores.fgm.model.FgmFixed), flags included.",
                             data, body, vectors)


def float_data(d) -> dict:
    """Algorithm 1's data in float64: G = I - H_n, Phi_n (H_n = H_F / (c lambda_max)), beta from mu of H_n, the input
    box (mpc_bench.baselines.NumpyFgm)."""
    s = d.c * d.lam_max
    Hn = d.qp.H / s
    mu = float(np.linalg.eigvalsh(Hn)[0])
    return {"G": np.eye(d.n) - Hn, "Phi": d.qp.Phi / s, "beta": (1 - math.sqrt(mu)) / (1 + math.sqrt(mu)),
            "lb": np.asarray(d.qp.lb, dtype=float), "ub": np.asarray(d.qp.ub, dtype=float)}


def float_files(nm: emit.Names, d, cfg: dict) -> dict[str, str]:
    api, fd = capi.float_api(nm, [(n, c) for _, n, c in STATE]), float_data(d)
    data = f"""\
#define BETA (({api.value_t}){emit.real_lit(fd["beta"])})
/* G = I - H_n, Phi_n, the input box */
{emit.array("G", fd["G"], real=True)}{emit.array("PHI", fd["Phi"], real=True)}{emit.array("LB", fd["lb"], real=True)}\
{emit.array("UB", fd["ub"], real=True)}
static mpc_real_t clip(mpc_real_t x, mpc_real_t lo, mpc_real_t hi)
{{
    return x < lo ? lo : (x > hi ? hi : x);
}}
"""
    body = f"""\
    mpc_real_t h[N], z[N], y[N], zn[N];
    int j;
    for (i = 0; i < N; i++) {{
        mpc_real_t s = 0;
        for (j = 0; j < NW; j++)
            s += PHI[i][j] * w_in[j];
        h[i] = s;
    }}
{_start("clip", "LB", "UB")}\
    for (it = 0; it < ctrl->imax; it++) {{
        for (i = 0; i < N; i++) {{
            mpc_real_t s = 0;
            for (j = 0; j < N; j++)
                s += G[i][j] * y[j];
            zn[i] = clip(s - h[i], LB[i], UB[i]);
        }}
        for (i = 0; i < N; i++) {{
            y[i] = (1 + BETA) * zn[i] - BETA * z[i];
            z[i] = zn[i];
        }}
    }}
"""
    return capi.solver_files(api, cfg, f"the FGM solver of the core {nm.module} in floating point (double, or float "
                             f"with -D{api.P}_SINGLE)", f"{TITLE}; Algorithm 1 on the unquantised data (not "
                             "bit-exact: the fixed-point solver is).", data, body)
