"""core.json and the design report of an FGM core."""
from __future__ import annotations

import numpy as np

from mpc_cores.fgm.design import FgmDesign, roundoff_bound
from mpc_cores.fixed import run_time_fields
from mpc_cores.interleave import core_fields, report_lines
from mpc_cores.target import dp16kd, dsp_count, report_line, single_dsp_advice


def _fmt(intb: int, b: int, width: int) -> dict:
    return {"int_bits": intb, "frac_bits": b, "width": width}


def core_json(d: FgmDesign, hw: dict) -> dict:
    """Metadata of a generated core: the Python design and the generator's hw.json, checked against each other."""
    for key, mine in (("cycles_per_iteration", d.cycles_per_iteration), ("multipliers", d.multipliers),
                      ("cycles_per_solve", d.cycles_per_solve()), ("period_cycles", d.period_cycles),
                      ("problems", d.problems)):
        if hw[key] != mine:
            raise RuntimeError(f"generator and front end disagree on {key}: {hw[key]} vs {mine}")
    b = d.b
    one = 1 << b
    signals = {}
    descr = {"coef": "matrix words (I - H_n), Phi_n", "x": "state/reference word after saturation",
             "z": "iterate z (and u)", "y": "iterate y", "sum": "products and adder-tree partial sums",
             "t": "t = (I - H_n) y - Phi_n x", "beta": "beta and 1 + beta"}
    for k, w in d.widths.items():
        if k == "stream":
            continue
        signals[k] = {"width": w, "int_bits": w - 1 - b, "frac_bits": b, "bound": d.bounds[k] / one,
                      "what": descr[k]}
    from mpc_cores.fgm.certify import certify

    sw = d.widths["stream"]
    eta = roundoff_bound(d, d.iterations)
    cert = certify(d, d.tol)
    return {
        "core": "fgm",
        "name": d.name,
        "module": hw["module"],
        "sv": f"{hw['module']}.sv",
        "n": d.n, "nu": d.nu, "nw": d.nw, "nx": d.problem.nx, "ny": d.problem.ny, "N": d.problem.N,
        "P": d.P,
        "frac_bits": b,
        "int_bits": max(signals[k]["int_bits"] for k in ("y", "sum", "t")),
        "x_format": _fmt(sw - 1 - b, b, sw),
        "u_format": _fmt(sw - 1 - b, b, sw),
        **run_time_fields(d, sw),
        "cycles_per_iteration": hw["cycles_per_iteration"],
        "cycles_eq23": hw["cycles_eq23"],
        "cycles_per_solve": hw["cycles_per_solve"],
        "solve_overhead_cycles": hw["solve_overhead_cycles"],
        "cycles_per_solve_formula": f"{hw['solve_overhead_cycles']} + {'I' if d.early_exit else 'IMAX'} * "
                                    f"{hw['period_cycles']}" + (
            f" (+ 0 to {hw['period_cycles'] - 1} waiting for the problem's turn)" if d.problems > 1 else "") + (
            ", I = ITERATIONS.COUNT: the iterations run, IMAX at most" if d.early_exit else ""),
        "early_exit": d.early_exit,
        **({"exit_tol": d.exit_tol, "exit_tol_value": d.exit_tol / one, "exit_extra_cycles": d.exit_extra,
            "exit_suboptimality_bound": d.exit_bound()} if d.early_exit else {}),
        **interleave_fields(d),
        "tree_inputs": hw["tree_inputs"], "tree_depth": hw["tree_depth"],
        "multipliers": hw["multipliers"],
        "signals": signals,
        "prop1": d.prop1,
        "normalisation": {"c": d.c, "lambda_max_HF": d.lam_max, "mu": d.mu,
                          "kappa": float(1 / d.mu), "beta": d.beta / one},
        "roundoff_bound_eq20": float(eta[-1]),
        "certificate": {k: (None if isinstance(v, float) and v != v else v) for k, v in cert.as_dict().items()},
        "box": {"u_lo": (d.lo / one).tolist(), "u_hi": (d.hi / one).tolist(),
                "w_lo": (d.xlo / one).tolist(), "w_hi": (d.xhi / one).tolist()},
        "axil_addr_width": hw["axil_addr_width"],
        "p_bits": hw["p_bits"], "col_bits": hw["col_bits"],
        "registers": hw["registers"],
        "regions": hw["regions"],
    }


def _dsp_advice(d: FgmDesign) -> str | None:
    """the largest b at which every product is one DSP of the target, when the design's b is larger"""
    from mpc_cores.fgm.design import design_fgm

    def products(b):
        return design_fgm(d.problem, frac_bits=b, P=d.P, target=d.target, lat_mul=d.lat_mul, lat_add=d.lat_add,
                          rounding=d.rounding, iterations=d.iterations).products()
    return single_dsp_advice(d.target, d.b, products, [d.P * d.m, 2 * d.P])


def interleave_fields(d) -> dict:
    """core.json's interleaving entries (mpc_cores.interleave.core_fields); with the exit test the least latency is
    one iteration's"""
    f = core_fields(d.K, d.cycles_per_iteration, d.problems, d.iterations, d.n if d.output_all else d.nu, d.nw,
                    d.solve_overhead + d.iterations * d.cycles_per_iteration)
    if d.early_exit:
        f["latency_cycles"] = dict(f["latency_cycles"], min=d.solve_overhead + d.cycles_per_iteration)
    return f


def design_report(d: FgmDesign, core: dict | None = None) -> str:
    b = d.b
    one = 1 << b
    eta = roundoff_bound(d, d.iterations)
    lines = [
        f"FGM core for '{d.name}': n = N*nu = {d.n} ({d.problem.N} x {d.nu}), nw = {d.nw} (x: {d.problem.nx}, r: {d.problem.ny})",
        f"  P = {d.P}, l_A = {d.lat_add}, l_M = {d.lat_mul}, {d.rounding} products, b = {b} fraction bits",
        report_line(d.target, d.lat_mul, d.products(), [d.P * d.m, 2 * d.P]),
        *([a] if (a := _dsp_advice(d)) else []),
        f"  Assumption 1 (002): c = {d.c:.6g}, lambda_max(H^_F) = {d.lam_max:.6g}, eig(H^_n) in [{d.mu:.4g}, "
        f"{np.linalg.eigvalsh(d.Hn_hat)[-1]:.6f}], beta^ = {d.beta / one:.6f} (>= bound, < 1)",
        _conditioning_line(d),
        "  Word widths (Prop. 1 of 002 on the quantised words; no overflow for any w in the box):",
    ]
    for k, w in d.widths.items():
        if k == "stream":
            continue
        lines.append(f"    {k:<5} {w:>3} bits = Q{w - 1 - b}.{b}  |{k}| <= {d.bounds[k] / one:.6g}")
    lines.append(f"    stream words {d.widths['stream']} bits")
    lines += [
        f"  Cycles: L_F = {d.cycles_per_iteration} per iteration (eq. (23): {d.cycles_eq23}); per solve "
        f"{d.solve_overhead} + Imax * {d.cycles_per_iteration} without interleaving",
        *report_lines(d.K, d.cycles_per_iteration, d.problems, d.iterations, d.n if d.output_all else d.nu, d.nw,
                      d.solve_overhead + d.iterations * d.cycles_per_iteration),
        f"  Round-off bound eq. (20) after {d.iterations} iterations: ||z_fixed - z_exact||_2 <= {eta[-1]:.3g}",
        *_exit_lines(d),
        f"  Multipliers: {d.multipliers} (P * max(n, nw) + 2P)",
    ]
    return "\n".join(lines)


def _exit_lines(d: FgmDesign) -> list[str]:
    """The exit test: what it stops on, its cycles and the suboptimality it implies"""
    if not d.early_exit:
        return []
    one = 1 << d.b
    bound = d.exit_bound()
    return [f"  Exit test: a solve ends after the first iteration whose step max |z+ - z| and the previous "
            f"iteration's are below EXIT_TOL = {d.exit_tol} LSB ({d.exit_tol / one:.4g}), else at IMAX; "
            f"{d.exit_extra} cycles of L_F are its decision's; cycles per solve {d.solve_overhead} + I * "
            f"{d.cycles_per_iteration}, I in ITERATIONS.COUNT",
            f"    it implies ||G(y)||_inf < (1 + beta) EXIT_TOL for the gradient map, so V(z) - V* <= {bound:.3g} "
            f"for the exact iteration on the quantised data (n (1 + beta)^2 EXIT_TOL^2 c lambda_max (1/mu - 1) / 2), "
            f"before the round-off of eq. (20)"]


def _conditioning_line(d: FgmDesign) -> str:
    """kappa of the condensed Hessian, and what the diagonal (Jacobi) scaling that keeps the input box a box would
    make of it: the iterations of eq. (7) grow with sqrt(kappa), and the quantisation floor with kappa"""
    H = d.qp.H
    e = np.linalg.eigvalsh(H)
    s = 1.0 / np.sqrt(np.diag(H))
    ej = np.linalg.eigvalsh(s[:, None] * H * s[None, :])
    k, kj = e[-1] / e[0], ej[-1] / ej[0]
    verdict = ("it would lower kappa: the inputs' units are unbalanced, rescale them in the spec"
               if kj < k / 2 else "no help here, the conditioning is the dynamics'")
    return (f"  Conditioning: kappa(H_F) = {k:.3g}; a diagonal scaling of the inputs (Jacobi, the input box stays a "
            f"box) gives {kj:.3g}: {verdict}")


def facts(d: FgmDesign) -> dict:
    """What the design check and the gallery print of a design (mpc_cores.check)."""
    counts = [d.P * d.m, 2 * d.P]
    return {"iterations": d.iterations, "iterations_text": f"Imax = {d.iterations}", "cycles": d.cycles_per_solve(),
            "multipliers": d.multipliers, "dsp_ecp5": dsp_count("ecp5", d.products(), counts),
            "bram_ecp5": dp16kd(d.P * [(2 * (1 << max(1, (d.K - 1).bit_length())), d.m, d.widths["coef"], True),
                                       (d.K, 2, d.widths["z"], True)]),
            "words": f"b = {d.b}, widest product {max(d.products(), key=lambda p: p[0] * p[1])}",
            **({"cycles_of": lambda i: d.solve_overhead + i * d.cycles_per_iteration,
                "exit_tol": f"{d.exit_tol} LSB"} if d.early_exit else {})}
