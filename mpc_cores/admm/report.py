"""core.json and the design report of an ADMM core."""
from __future__ import annotations

from mpc_cores.admm.design import AdmmDesign, product_counts
from mpc_cores.admm.scaling import FREE_DROP, GATE
from mpc_cores.fixed import run_time_fields
from mpc_cores.interleave import PASS_QUEUE, PASS_START, core_fields, report_lines
from mpc_cores.target import dp16kd, dsp_count, report_line

_WHAT = {"coef": "matrix words M11, G~", "w": "parameter word (of w) after saturation, and the word 1",
         "v": "operand v = rho z - nu", "y": "y = M11 v + G~ (w, 1)", "q": "q = y + nu / rho", "z": "iterate z",
         "d": "y - z", "nu": "multiplier nu", "sum": "products and adder-tree partial sums",
         "msum": "sum of |products| of a row of M11 v", "gsum": "sum of |products| of a row of G~ (w, 1)"}


def core_json(d: AdmmDesign, hw: dict) -> dict:
    """Metadata of a generated ADMM core: the Python design and the generator's hw.json, checked against 002."""
    mom = hw.get("momentum_cycles", 0)     # accelerated: the momentum lanes after the write stage
    if hw["cycles_per_iteration"] - mom > hw["cycles_eq24"]:
        raise RuntimeError(f"L_A = {hw['cycles_per_iteration']} - {mom} exceeds eq. (24) of 002: {hw['cycles_eq24']}")
    if bool(hw.get("accelerated", False)) != d.accelerated:
        raise RuntimeError(f"generator and front end disagree on accelerated: {hw.get('accelerated')}")
    if hw["multipliers"] != d.multipliers + (d.P * (d.m - d.n) if d.chunks == 1 else 0):
        raise RuntimeError(f"generator and front end disagree on multipliers: {hw['multipliers']}")
    b = d.b
    one = 1 << b
    signals = {k: {"width": w, "int_bits": w - 1 - b, "frac_bits": b, "bound": d.bounds[k] / one,
                   "how": "simulated x safety" if k in d.estimated else "analytic", "what": _WHAT[k]}
               for k, w in d.widths.items() if k != "stream" and k in d.bounds}
    sw = d.widths["stream"]
    L = hw["cycles_per_iteration"]
    q = d.qp
    return {
        "core": d.method,            # the kind: admm, or a splitting method on its datapath (ama, vucondat)
        "method": d.method,
        "accelerated": d.accelerated,
        "momentum_cycles": mom,
        "name": d.name,
        "module": hw["module"],
        "sv": f"{hw['module']}.sv",
        "n": d.n, "nu": d.nu, "nw": d.nw, "nx": q.nx, "ns": q.ns, "N": d.N,
        "rate": d.rate,              # rate-augmented: w = (x, u_prev, r), du_0 out; else w = (x, r), u_0 out
        "form": form(d),
        "P": d.P, "K": hw["K"],
        "frac_bits": b,
        **run_time_fields(d, sw),
        "rho_log2": d.rho_log2,
        "cost_log2": d.cost_log2,   # the cost scaled by 2^-cost_log2 in the data (mpc_cores.admm.scaling)
        "shifts": hw["shifts"],
        "cycles_per_iteration": L,
        "cycles_eq24": hw["cycles_eq24"],
        "cycles_per_solve": hw["cycles_per_solve"],
        "solve_overhead_cycles": hw["solve_overhead_cycles"],
        "cycles_per_solve_formula": f"{hw['solve_overhead_cycles']} + IMAX * {hw['period_cycles']}" + (
            f" (+ 0 to {hw['period_cycles'] - 1} waiting for the problem's turn)" if d.problems > 1 else ""),
        **interleave_fields(d, hw),
        "tree_inputs": hw["tree_inputs"], "tree_depth": hw["tree_depth"],
        "multipliers": hw["multipliers"],
        "multipliers_table1": d.P * d.n,
        "signals": signals,
        "assumption2": d.assumption2,
        "row_units": hw["row_units"],
        "axil_addr_width": hw["axil_addr_width"],
        "col_bits": hw["col_bits"],
        "registers": hw["registers"],
        "regions": hw["regions"],
    }


def interleave_fields(d: AdmmDesign, hw: dict) -> dict:
    """core.json's interleaving entries (mpc_cores.interleave.core_fields), from the generator's row placement."""
    if hw["problems"] != d.problems:
        raise RuntimeError(f"generator and front end disagree on problems: {hw['problems']} vs {d.problems}")
    L = hw["cycles_per_iteration"]
    fields = core_fields(hw["K"], L, d.problems, d.iterations, d.n if d.output_all else d.nu, d.nw,
                         PASS_START + 1 + PASS_QUEUE + (d.iterations + 1) * L)
    if fields["period_cycles"] != hw["period_cycles"] or fields["latency_cycles"]["min"] != hw["cycles_per_solve"]:
        raise RuntimeError("generator and front end disagree on the period or the latency: "
                           f"{hw['period_cycles']}, {hw['cycles_per_solve']} vs {fields}")
    return fields


def form(d: AdmmDesign) -> str:
    """the QP's form in a phrase: what the core takes and what its first nu words are"""
    return "w = (x, u_prev, r), du_0 out" if d.rate else "w = (x, r), u_0 out"


def _precondition_line(d: AdmmDesign) -> list[str]:
    """the power-of-two preconditioner folded into the shifts, if the design has one"""
    if d.scaling is None:
        return []
    dv, n = d.scaling.d, len(d.scaling.d)
    counts = ", ".join(f"2^{int(k)} on {int((dv == k).sum())}" for k in sorted(set(dv.tolist())))
    return [f"  Preconditioned (power-of-two Ruiz): D = {counts} of {n} components, cost x 2^{d.scaling.c}; "
            f"folded into the steps rho_j / (c D_j^2) (the shifts below)"]


def _method_lines(d: AdmmDesign) -> list[str]:
    """the method (004) and its step sizes; Assumption 2 of 002 for ADMM"""
    return _precondition_line(d) + _method_core_lines(d)


def _method_core_lines(d: AdmmDesign) -> list[str]:
    ks = sorted(set(int(k) for k in d.shift))
    if d.method == "ama":
        fast = ([f"  Accelerated (fast AMA): Nesterov momentum on nu, restart when <nu - nu^, nu - nu_prev>_(1/rho) < 0 "
                 f"(O'Donoghue-Candes gradient scheme); {len(d.config()['momentum'])} momentum words, "
                 f"{1 + d.lat_mul} cycles more per iteration"] if d.accelerated else [])
        return [f"  Method: AMA (v = -nu, M11 of the unaugmented KKT matrix); rho_j = 2^k_j, k_j in {ks}, below 2 mu = "
                f"{2 * d.mu:.4g} (mu = lambda_min of H_A on Ker F{', scaled QP' if d.scaling is not None else ''})"] + fast
    if d.method == "vucondat":
        return [f"  Method: Vu-Condat (Chambolle-Pock, L = I): tau = 1/rho, sigma = rho/2; rho = 2^{d.rho_log2}, "
                f"sigma_j = 2^k_j with k_j in {ks} (the datapath's shifts), v = sigma (y + z) - nu"]
    a2 = d.assumption2
    scaled = ("soft pairs, du scaled" if d.rate else "soft pairs scaled") + (
        ", preconditioned" if d.scaling is not None else "")
    cost = ([f"  Cost scaled by 2^-{d.cost_log2} in the data (median |nu*|_inf of the accepted box over {GATE:g} rho), "
             f"free components' rho 2^-{FREE_DROP} times the rest's (mpc_cores.admm.scaling)"] if d.cost_log2 else [])
    return cost + [f"  rho = 2^{d.rho_log2}, shifts k_j in {ks} ({scaled})",
            f"  Assumption 2 (002) on the quantised M11: eig on Ker F in [{a2['kernel_min']:.4g}, {a2['kernel_max']:.6f}] "
            f"(inside (0, 1)), spectral radius {a2['spectral_radius']:.6f} (< 1)"]


def design_report(d: AdmmDesign, core: dict | None = None) -> str:
    b = d.b
    one = 1 << b
    q = d.qp
    nx = "nx~" if d.rate else "nx"
    lines = [
        f"ADMM core for '{d.name}': n_A = {d.n} = N (nu + {nx} + |S|) + {nx} + |S| = {d.N} ({d.nu} + {q.nx} + {q.ns}) "
        f"+ {q.nx} + {q.ns}, nw = {d.nw}",
        f"  Form: {form(d)} " + ("(input_rate: the state augmented with u_prev, decision inputs du_k; "
                                 "u_0 = clip(u_prev + du_0, umin, umax))" if d.rate else
                                 "(no input_rate: decision inputs u_k; u_0 = clip(u_0, umin, umax))"),
        f"  P = {d.P}, l_A = {d.lat_add}, l_M = {d.lat_mul}, {d.rounding} products, b = {b} fraction bits",
        *([f"  Lanes: {d.lanes} multipliers take a row of {d.m} columns in {d.chunks} chunks (one a cycle), their "
           f"tree sums added exactly and the total saturated"] if d.chunks > 1 else []),
        report_line(d.target, d.lat_mul, d.products(), product_counts(d)),
        *_method_lines(d),
        "  Word widths (static words analytic; iterates: largest seen in the bit-exact model x safety, IV-C2 of 002):",
    ]
    for k, w in d.widths.items():
        if k == "stream" or k not in d.bounds:
            continue
        lines.append(f"    {k:<5} {w:>3} bits = Q{w - 1 - b}.{b}  |{k}| <= {d.bounds[k] / one:.6g}")
    lines.append(f"    stream words {d.widths['stream']} bits")
    if core is not None:
        lines.append(f"  Cycles: L_A = {core['cycles_per_iteration']} per iteration (eq. (24): {core['cycles_eq24']}); "
                     f"{core['cycles_per_solve']} per solve at Imax = {d.iterations} (= {core['cycles_per_solve_formula']})")
        lines += report_lines(core["K"], core["cycles_per_iteration"], d.problems, d.iterations,
                              d.n if d.output_all else d.nu, d.nw, PASS_START + 1 + PASS_QUEUE + (d.iterations + 1) * core["cycles_per_iteration"])[1:]
    else:
        lines.append(f"  Cycles: eq. (24) of 002 gives L_A <= {d.cycles_per_iteration} per iteration")
    if d.chunks > 1:
        lines.append(f"  Multipliers: {d.multipliers} (ceil(max(n_A, nw + 1) / chunks) lanes; Table I: P n_A = {d.n})")
    else:
        lines.append(f"  Multipliers: {d.P * max(d.n, d.nw + 1)} (P * max(n_A, nw + 1); Table I: P n_A = {d.P * d.n})")
    return "\n".join(lines)


def facts(d: AdmmDesign) -> dict:
    """What the design check and the gallery print of a design (mpc_cores.check); the cycles per solve from the
    per-iteration bound of eq. (24) (the generated core's count is at most this)."""
    prods = d.products()
    counts = product_counts(d)
    return {"iterations": d.iterations, "iterations_text": f"Imax = {d.iterations}",
            "cycles": PASS_START + 1 + PASS_QUEUE + (d.iterations + 1) * d.cycles_per_iteration,
            "multipliers": d.multipliers, "dsp_ecp5": dsp_count("ecp5", prods, counts), "bram_ecp5": dp16kd(memories(d)),
            "words": f"b = {d.b}, widest product {max(prods, key=lambda p: p[0] * p[1])}"
                     + (f", {d.lanes} lanes x {d.chunks} chunks" if d.chunks > 1 else "")}


def memories(d: AdmmDesign) -> list[tuple]:
    """(words, lanes, bits per lane, built from primitives) of the core's memories per row unit (AdmmCore): the
    matrix (M11 and G~ blocks of 2^ceil(log2 slots) words of `lanes` coefficients), the bounds and G~ (w, 1)"""
    K = -(-d.n // d.P)
    block = 1 << max(1, (K * d.chunks - 1).bit_length())
    w = d.widths
    return d.P * [(2 * block, d.lanes, w["coef"], True), (K, 2, w["z"], True), (K * d.problems, 1, w["sum"], False)]
