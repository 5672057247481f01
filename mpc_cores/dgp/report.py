"""core.json and the design report of a DGP core."""
from __future__ import annotations

from mpc_cores.dgp.design import ALPHA, DgpDesign, product_counts
from mpc_cores.fixed import run_time_fields
from mpc_cores.target import dp16kd, dsp_count, report_line


def _counts(d: DgpDesign) -> list[int]:
    return product_counts(d)


def core_json(d: DgpDesign, hw: dict) -> dict:
    """Metadata of a generated DGP core: the Python design and the generator's hw.json, checked against each other."""
    for key, mine in (("cycles_per_iteration", d.cycles_per_iteration), ("solve_overhead_cycles", d.solve_overhead),
                      ("multipliers", d.multipliers), ("div_cycles", d.div_cycles),
                      ("issue_cycles", d.issue_cycles), ("zero_start_saving_cycles", d.zero_start_saving)):
        if hw[key] != mine:
            raise RuntimeError(f"generator and front end disagree on {key}: {hw[key]} vs {mine}")
    b = d.b
    sw = d.widths["stream"]
    a = d.analysis
    return {
        "core": "dgp", "name": d.name, "module": hw["module"], "sv": f"{hw['module']}.sv",
        "n": d.n, "nu": d.nu, "nw": d.nw, "nx": d.problem.nx, "ny": d.problem.ny, "N": d.problem.N,
        "mc": d.mc, "m": d.m, "P": d.P, "lanes": d.lanes, "accelerated": d.accelerated, "warm_shift": d.warm_shift,
        "frac_bits": b, "int_bits": d.widths["data"] - b, "bits_eq36": d.bits36, "bits_eq37": d.bits37,
        "eps_certified": d.b >= d.bits36,
        "data_format": {"int_bits": d.widths["data"] - b, "frac_bits": b, "width": d.widths["data"]},
        **run_time_fields(d, sw),
        "eps_g": d.eps_g, "eps_V": d.eps_V, "alpha": ALPHA, "dual_margin": d.margin,
        "analysis": a, "widths": d.widths,
        "cycles_per_iteration": hw["cycles_per_iteration"],
        "solve_overhead_cycles": hw["solve_overhead_cycles"],
        "zero_start_saving_cycles": hw["zero_start_saving_cycles"],
        "cycles_to_output_formula": f"{hw['solve_overhead_cycles']} + I * {hw['cycles_per_iteration']} "
                                    f"- Z * {hw['zero_start_saving_cycles']} (I: the iterations run, 1..IMAX, in the "
                                    f"status word and ITERATIONS.COUNT; Z: 1 when the starting dual was all zero, "
                                    f"every cold start, in ITERATIONS.ZERO_START)",
        "cycles_at_imax": d.cycles_to_output(d.iterations),
        "div_cycles_per_word": hw["div_cycles"],
        "issue_cycles": hw["issue_cycles"], "gap_cycles": hw["gap_cycles"], "chunks": hw["chunks"],
        "multipliers": hw["multipliers"],
        "output_words": "u0 (nu words) or z (n words, CTRL.OUT_ALL), then a status word: iterations in bits 15:0, "
                        "test met 16, input saturated 17, datapath overflow 18",
        "axil_addr_width": hw["axil_addr_width"],
        "registers": hw["registers"], "regions": hw["regions"],
    }


def design_report(d: DgpDesign, core: dict | None = None) -> str:
    a = d.analysis
    W = d.widths["data"]
    form = ("accelerated (Nesterov, gradient restart; stops when g <= eps_g and the duality gap <= eps_V; outputs "
            "the last z)" if d.accelerated else "plain (stops at (32c) of 003; outputs the averaged primal (20))")
    i, g = d.issue_cycles, d.gap_cycles
    lines = [
        f"DGP core for '{d.name}': n = N*nu = {d.n} ({d.problem.N} x {d.nu}), {d.mc} two-sided constraint rows "
        f"(m = {d.m} one-sided, dual words), nw = {d.nw}",
        f"  Form: {form}",
        "  Warm start: " + ("from the previous final dual shifted a stage (each row from the same row a stage "
                            "later, the last stage's from zero), clipped to the dual box" if d.warm_shift
                            else "from the previous final dual") + (" (the default)" if d.warm_start else
                                                                    " (CTRL.WARM; cold by default)"),
        *([f"  State: the dual and the bounds in block RAM (ram_state): per row unit 3 memories of {d.rounds['G']} rows x 2 "
            f"data words, pass K's operand from the differences wy+ - wy-; {dp16kd(d.memories())} DP16KD in all with "
            f"the matrix memories (estimate)"] if d.ram_state else []),
        f"  Scaling: sigma = {a['sigma']:.6g} makes L = lambda_max(A Q^-1 A') = 1 (section VI-A of 003)",
        f"  Dual box (14)-(15): d_i = max({d.margin:g} x largest sampled y*_i, 1), alpha = {ALPHA:g}; ||d||_2 = D = "
        f"{a['D']:.4g}, ||d||_inf = {a['d_max']:.4g}",
        f"  Fraction bits p = {d.b}: (36) of 003 gives p >= {d.bits36} for eps = min(eps_g sigma, eps_V) = "
        f"{a['eps']:.3g} (eps_g = {d.eps_g:g}, eps_V = {d.eps_V:g}, L_V = {a['L_V']:.4g})"
        + ("" if d.b >= d.bits36 else f"; NOT CERTIFIED: p = {d.b} < {d.bits36}, the (eps_g, eps_V) guarantee of 003 "
           f"does not hold (the design check measures the loop)"),
        f"  Integer bits r = {W - d.b}: (37) of 003 gives r >= {d.bits37} (y^ = {a['y_hat']:.4g}"
        f", z^ = {a['z_hat']:.4g}, "
        f"g^ = {a['g_hat']:.4g})",
        f"  Words: data {W} bits = Q{W - d.b - 1}.{d.b} (sign included in r), coefficients {d.widths['coef']}, "
        f"row accumulator {d.widths['acc']}, sums of the test {d.widths['sum']}, stream {d.widths['stream']} bits",
        f"  Row units: P = {d.P} of {d.lanes} lanes, rows per unit K {d.rounds['K']}, G {d.rounds['G']}; chunks per "
        f"row F {d.chunks['F']}, K {d.chunks['K']}, G {d.chunks['G']}, issued where a round's rows have a nonzero "
        f"(F {i['F']}, K {i['K']}, G {i['G']} of {', '.join(map(str, d.dense_issue_cycles.values()))}); l_A = {d.lat_add}, l_M = {d.lat_mul}"
        + (f" (the element stage's products {d.element_lat_mul}: their DSP outputs land in fabric registers)"
           if d.accelerated and d.element_lat_mul != d.lat_mul else ""),
        report_line(d.target, d.lat_mul, d.products(), _counts(d)),
        f"  Cycles per iteration: {d.cycles_per_iteration} = pass K {i['K']} + {g['K']} + pass G {i['G']} + {g['G']}"
        f" + 1",
        f"  Latency: {d.solve_overhead} + I x {d.cycles_per_iteration} cycles from the last input word to the first "
        f"output word, I the iterations run (at IMAX = {d.iterations}: {d.cycles_to_output(d.iterations)}); "
        f"{d.zero_start_saving} fewer when the starting dual is all zero (every cold start: its first iteration's "
        f"passes K and G are skipped, the element stage taking the first pass's bound rows)",
    ]
    if not d.accelerated:
        lines.append(f"  Output: each word of the averaged primal takes {d.div_cycles} cycles (serial division)")
    if core is not None:
        lines.append(f"  Module {core['module']}, {core['multipliers']} multipliers")
    return "\n".join(lines)


def facts(d: DgpDesign) -> dict:
    """What the design check and the gallery print of a design (mpc_cores.check): cycles to the first output word
    at IMAX (the stopping test may end a solve earlier)."""
    return {"iterations": d.iterations, "iterations_text": f"Imax = {d.iterations}",
            "cycles": d.cycles_to_output(d.iterations), "multipliers": d.multipliers,
            "dsp_ecp5": dsp_count("ecp5", d.products(), _counts(d)),
            "bram_ecp5": dp16kd(d.memories()),
            "words": f"b = {d.b}, data {d.widths['data']} bits"}
