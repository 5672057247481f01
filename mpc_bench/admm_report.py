"""Formulas, records and report lines of the ADMM section of the benchmark (mpc_bench.admm): eq. (24) and
Tables I and III(b) of 002 for the ADMM architecture, one record per core (admm.csv), the summary table and the
"## ADMM core" part of report.md."""
from __future__ import annotations

import math

from mpc_bench.baselines import NumpyAdmm, core_ratios, fastest_cell, solver_section
from mpc_bench.parsers import ecp5_fit
from mpc_bench.qp import (
    F_S6_MHZ, F_V6_MHZ, Core, _core_latency, _fmax_section, _load_text, _memories, _resource_cells,
    _software_solvers,
)
from mpc_bench.report import _f, _table, _tool_columns, _x, fmax_table, latency_us, ratio

# IMAX reset value of the simulated ADMM cores: cycle_contract runs Imax = 1, 3 and this value.
ADMM_SIM_IMAX = 5

# Table III(b) of 002 (ADMM, masses with input-rate and soft state constraints, n_A = 216, Imax = 40).
PAPER_TABLE3_ADMM = {1: (216, 23.40, 40.70), 2: (432, 12.60, 21.91), 3: (648, 9.00, 15.65),
                     4: (864, 7.20, 12.52), 5: (1080, 6.20, 10.78), 6: (1296, 5.40, 9.39), 7: (1512, 4.90, 8.52)}

SW_KEYS = (("OSQP default", "osqp_default"), ("OSQP tuned", "osqp_tuned"), (NumpyAdmm.name, "numpy_admm"))


# ----------------------------------------------------------------------------------------- arithmetic

def eq24(n: int, P: int, lat_add: int, lat_mul: int) -> int:
    """L_A of eq. (24) of 002."""
    depth = math.ceil(math.log2(n)) if n > 1 else 0
    return -(-n // P) + lat_add * depth + lat_mul + 6 * lat_add + 2


def table3b_cycles(n: int, P: int, lat_add: int, lat_mul: int, imax: int) -> int:
    """The cycle count behind Table III(b) of 002: Imax (eq. (24) + 1) reproduces all seven rows at 400 and
    230 MHz (Imax eq. (24) does not), where Table III(a) is Imax eq. (23) exactly."""
    return imax * (eq24(n, P, lat_add, lat_mul) + 1)


def paper_multipliers_admm(n: int, P: int) -> int:
    """Table I of 002: P n_A multipliers for the ADMM architecture."""
    return P * n


def paper_memory_blocks_admm(n: int, P: int) -> tuple[int, int]:
    """Table I of 002: P (n_A + 8) memory blocks of ceil(n_A / P) words for the ADMM architecture."""
    return P * (n + 8), -(-n // P)


def admm_useful_macs(n: int) -> int:
    """Multiply-accumulates one ADMM iteration needs: n_A^2 for M11 v (the rho_j products are shifts)."""
    return n * n


def admm_mac_utilisation(n: int, multipliers: int, cycles_per_iteration: int) -> float:
    return admm_useful_macs(n) / (multipliers * cycles_per_iteration)


def solve_overhead(cycles_per_solve: int, iterations: int, cycles_per_iteration: int) -> int:
    """Cycles of a solve outside its iterations, from one measured solve at `iterations`."""
    return cycles_per_solve - iterations * cycles_per_iteration


def cycles_at(overhead: int, imax: int, cycles_per_iteration: int) -> int:
    """Cycles per solve at Imax iterations (the cycle contract: overhead + Imax L)."""
    return overhead + imax * cycles_per_iteration


# ----------------------------------------------------------------------------------------- records and tables

def admm_fmax_estimate(cores: list[Core]) -> tuple[float | None, str]:
    """The lowest Fmax of the small ADMM cores on the LFE5U-85F, and which core it is."""
    got = [(c.pnr["fmax_mhz"], c.tag) for c in cores if c.role == "fmax" and c.pnr]
    return min(got) if got else (None, "")


def _est_lat_text(recs: list[dict]) -> str:
    lat = next((r["est_lat"] for r in recs if r.get("est_lat")), None)
    return f"l_A = {lat[0]}, l_M = {lat[1]}" if lat else "no estimate"


def admm_rows(cores: list[Core], sw: dict | None, est_fmax: float | None) -> list[dict]:
    """One flat record per ADMM core (masses_rate_soft sweep and the small problem placed and routed)."""
    med = {r.name: r.ref_median_us for r in sw["solvers"]} if sw else {}
    # the estimate's core runs at its own latencies: the sweep's cycles move by the change of eq. (24)
    est_lat = next(((e.core["lat_add"], e.core["lat_mul"]) for e in cores if e.role == "fmax" and e.pnr), None)
    out = []
    for c in cores:
        cj, m = c.core, c.measured
        n, P, la, lm = cj["n"], c.P, cj["lat_add"], cj["lat_mul"]
        cpi = m["cycles_per_iteration"] if m else None
        overhead = solve_overhead(m["cycles_per_solve"], m["iterations"], cpi) if m else None
        cps = cycles_at(overhead, c.imax, cpi) if m else None
        cps_cj = cycles_at(cj["solve_overhead_cycles"], c.imax, cj["cycles_per_iteration"])
        cyc = cps if cps is not None else cps_cj
        t3 = PAPER_TABLE3_ADMM.get(P) if (n, c.imax, la, lm) == (216, 40, 1, 1) else None
        sweep = c.role == "sweep"
        lat = _core_latency(c, cyc)
        cyc_est = cyc + (c.imax + 1) * (eq24(n, P, *est_lat) - eq24(n, P, la, lm)) if sweep and est_lat else None
        lat_est = latency_us(cyc_est, est_fmax) if cyc_est else None
        lat_v6 = latency_us(cyc, F_V6_MHZ)
        r = {
            "problem": c.problem, "role": c.role, "P": P, "b": c.b, "n": n, "nw": cj["nw"], "ns": cj["ns"],
            "N": cj["N"], "imax": c.imax, "imax_simulated": m["iterations"] if m else None,
            "lat_add": la, "lat_mul": lm,
            "cycles_per_iteration_measured": cpi, "cycles_per_iteration_corejson": cj["cycles_per_iteration"],
            "cycles_eq24": cj["cycles_eq24"],
            "solve_overhead_measured": overhead, "solve_overhead_corejson": cj["solve_overhead_cycles"],
            "cycles_per_solve_simulated": m["cycles_per_solve"] if m else None,
            "cycles_per_solve_measured": cps, "cycles_per_solve_corejson": cps_cj,
            "cycles_per_solve_table3b": table3b_cycles(n, P, la, lm, c.imax),
            "multipliers": cj["multipliers"], "multipliers_table1": paper_multipliers_admm(n, P),
            "multipliers_table3": t3[0] if t3 else None,
        }
        _tool_columns(c, r)
        r.update({
            "latency_us_ecp5": lat,
            "fmax_est_mhz": est_fmax if sweep else None, "est_lat": est_lat if sweep else None,
            "cycles_per_solve_est": cyc_est, "latency_us_ecp5_est": lat_est,
            "latency_us_v6_ours": lat_v6, "latency_us_v6_paper": t3[1] if t3 else None,
            "latency_us_s6_ours": latency_us(cyc, F_S6_MHZ), "latency_us_s6_paper": t3[2] if t3 else None,
            "mac_utilisation": admm_mac_utilisation(n, cj["multipliers"], cpi if cpi else cj["cycles_per_iteration"]),
        })
        for name, key in SW_KEYS:
            us = med.get(name) if sweep else None
            r[f"{key}_us"] = us
            r[f"{key}_over_core"] = ratio(us, lat_est)
            r[f"{key}_over_core_v6"] = ratio(us, lat_v6)
        r.update(core_ratios(lat_est, sw if sweep else None))
        out.append(r)
    return out


def _fit_cell(r: dict) -> str:
    if r.get("ecp5_MULT18X18D") is None:
        return "-"
    over = ecp5_fit({k: r.get(f"ecp5_{k}", 0) for k in ("MULT18X18D", "DP16KD")})
    return "no: " + "; ".join(o.split(" needed")[0] for o in over) if over else "yes"


def admm_summary_table(recs: list[dict]) -> list[str]:
    est = next((r["fmax_est_mhz"] for r in recs if r.get("fmax_est_mhz")), None)
    hdr = ["P", "b", "L_A meas (eq. 24)", f"cycles/solve (Imax = {recs[0]['imax']})", "mult. ours (Table I)",
           "MULT18X18D / DSP48E1", "LUT4 / LUT", "FF ECP5 / xc7", "fits LFE5U-85F", "V6 us ours (paper)",
           "S6 us ours (paper)", f"us at {_f(est, '{:.0f}')} MHz (est.)", "OSQP def. / core", "OSQP tuned / core",
           "numpy / core", "fastest solver / core est. (median, p99)", "MAC use"]
    body = []
    for r in recs:
        body.append([
            str(r["P"]), str(r["b"]),
            f"{_f(r['cycles_per_iteration_measured'], '{}')} ({r['cycles_eq24']})",
            _f(r["cycles_per_solve_measured"], "{}"),
            *_resource_cells(r),
            _fit_cell(r),
            f"{_f(r['latency_us_v6_ours'])} ({_f(r['latency_us_v6_paper'])})",
            f"{_f(r['latency_us_s6_ours'])} ({_f(r['latency_us_s6_paper'])})",
            _f(r["latency_us_ecp5_est"]),
            f"{_x(r['osqp_default_over_core'])} / {_x(r['osqp_default_over_core_v6'])}",
            f"{_x(r['osqp_tuned_over_core'])} / {_x(r['osqp_tuned_over_core_v6'])}",
            f"{_x(r['numpy_admm_over_core'])} / {_x(r['numpy_admm_over_core_v6'])}",
            fastest_cell(r), _f(100 * r["mac_utilisation"], "{:.0f} %"),
        ])
    return _table(hdr, body)


def fmax_summary_table(recs: list[dict]) -> list[str]:
    """ADMM cores placed and routed for Fmax, with their pipeline latencies and cycles."""
    return fmax_table([("ADMM", 24, r) for r in recs])


def admm_section(cores: list[Core], recs: list[dict], sw: dict | None) -> list[str]:
    big = [(c, r) for c, r in zip(cores, recs) if c.role == "sweep"]
    small = [(c, r) for c, r in zip(cores, recs) if c.role == "fmax"]
    br = [r for _, r in big]
    r0 = (br or recs)[0]
    imax, sim = r0["imax"], r0["imax_simulated"] or ADMM_SIM_IMAX
    L = [f"## ADMM core: {r0['problem']}", ""]
    if br:
        L += ["### Cycles (Verilator)", "",
              f"The simulated cores are the Imax = {imax} designs (word widths sized for {imax} iterations) "
              f"generated with IMAX reset value {sim}: cycle_contract measures solves at Imax = 1, 3 and {sim}, "
              f"checks them against the core's cycle contract, and L_A is their difference per iteration. Cycles "
              f"per solve at Imax = {imax} are computed, not simulated: the overhead measured at Imax = {sim} "
              f"(cycles per solve - {sim} L_A) + {imax} L_A.", ""]
        body = [[str(r["P"]), str(r["b"]), _f(r["cycles_per_iteration_measured"], "{}"),
                 str(r["cycles_per_iteration_corejson"]), str(r["cycles_eq24"]),
                 _f(r["cycles_per_solve_simulated"], "{}"), _f(r["solve_overhead_measured"], "{}"),
                 _f(r["cycles_per_solve_measured"], "{}"), str(r["cycles_per_solve_corejson"]),
                 str(r["cycles_per_solve_table3b"])] for r in br]
        L += _table(["P", "b", "L_A measured", "L_A core.json", "eq. (24)", f"cycles/solve at Imax = {sim} (sim.)",
                     "overhead", f"cycles/solve at Imax = {imax}", "core.json", f"{imax} (eq. (24) + 1) (Table III(b))"],
                    body)
        L += ["", "L_A is one cycle under eq. (24) of 002: the soft projection takes 2 l_A cycles and the state's "
              "d and nu updates run beside the slack's (README, ADMM core). Cycles per solve run from the handshake "
              "of the last input word to the first output word; the overhead is the first pass (G~ (w, 1), one "
              "iteration's time) and the I/O handshake. Table III(b) of 002 is reproduced exactly, at all seven P and both "
              "clocks, by Imax (eq. (24) + 1) cycles, not by Imax eq. (24); that count is the last column.", "",
              "### Resources (Yosys)", ""]
        body = [[str(r["P"]), str(r["b"]), str(r["multipliers"]), str(r["multipliers_table1"]),
                 _f(r.get("ecp5_MULT18X18D"), "{}"), _f(r.get("ecp5_LUT4"), "{}"), _f(r.get("ecp5_CCU2C"), "{}"),
                 _f(r.get("ecp5_FF"), "{}"), _f(r.get("ecp5_DP16KD"), "{}"), _f(r.get("ecp5_LUTRAM"), "{}"),
                 _f(r.get("xc7_DSP48E1"), "{}"), _f(r.get("xc7_LUT"), "{}"), _f(r.get("xc7_FF"), "{}"),
                 _f(r.get("xc7_RAMB"), "{:g}"), _f(r.get("xc7_LUTRAM"), "{}"),
                 "{} x {}".format(*paper_memory_blocks_admm(r["n"], r["P"]))] for r in br]
        L += _table(["P", "b", "mult. ours", "Table I", "MULT18X18D", "LUT4", "CCU2C", "FF", "DP16KD",
                     "DPR16X4", "DSP48E1", "LUT", "FF", "RAMB36", "LUTRAM/SRL", "Table I memories x words"], body)
        widths = {c.b: c.core.get("signals", {}) for c, _ in big}
        wtxt = "; ".join(f"b = {b}: coefficients {s['coef']['width']} bits x operands "
                         f"{max(s['v']['width'], s['w']['width'])} bits" for b, s in sorted(widths.items())
                         if "coef" in s and "v" in s and "w" in s)
        L += ["", f"mult. ours: P max(n_A, nw + 1) products (Table I of 002: P n_A). Each product is wider than one "
              f"hard multiplier ({wtxt}), so Yosys builds it from several MULT18X18D (18 x 18) or DSP48E1 "
              "(25 x 18) blocks. Table I of 002 keeps every column of the matrices in its own memory of "
              "ceil(n_A/P) words; this core keeps per row unit one RAM of 2 ceil(n_A/P) rows of M11 and G~ "
              "coefficients, one of bound pairs and one of G~ (w, 1) words. The synthesised cores are the "
              f"simulated ones (IMAX reset value {sim}; the Imax = {imax} core differs in that constant only). "
              + ("They are synthesised hierarchically (`synth_ecp5 -noflatten`, `synth_xilinx` without -flatten; "
                 "counts include submodules): the P row units share one dot-product module, which Yosys maps "
                 "once, where the flat synthesis of the P = 4 core ran out of the 4 GB a WebAssembly Yosys can "
                 "address; without optimisation across module boundaries the counts can differ a little from a flat "
                 "synthesis. "
                 if any(c.hierarchical for c, _ in big) else ""), "",
              "Memories as Yosys inferred them (memory_libmap):", ""]
        L += _memories([c for c, _ in big])
    L += ["", "### Fit check and Fmax (nextpnr-ecp5, LFE5U-85F, CABGA381, speed 8)", ""]
    if br:
        L += [f"{r0['problem']} (n_A = {r0['n']}): " + "; ".join(
            f"P = {r['P']}, b = {r['b']}: " + (r["pnr_note"] or "fits") for r in br) + ". The LFE5U-85F is the "
            "largest ECP5, so no ECP5 holds this core and there is no Fmax for it.", ""]
    if small:
        s0 = small[0][1]
        c0 = small[0][0]
        q = c0.design.qp
        L += [f"The Fmax below is for a small ADMM problem instead, `{s0['problem']}` (built in mpc_bench/admm.py: a "
              f"random stable plant with nx = {q.problem.nx}, nu = {q.nu}, N = {q.N}, one tracked output, "
              f"input-rate limits and {q.ns} soft state; n_A = {s0['n']}, nw = {s0['nw']}, b = {s0['b']}, "
              f"Imax = {s0['imax']}), placed and routed at P = " + ", ".join(str(c.P) for c, _ in small)
              + ". Its row units have the masses core's structure (dot product, adder tree, soft projection) with "
              "a shallower tree; the masses core's would be longer routes on a larger device.", ""]
        L += _fmax_section([c for c, _ in small], [r for _, r in small], "admm_core.lpf")
        L += ["", "Small problem, cycles and latency at its own Fmax:", ""]
        L += fmax_summary_table([r for _, r in small])
    if br:
        est = next((r["fmax_est_mhz"] for r in br if r.get("fmax_est_mhz")), None)
        L += ["", "### Latency against Table III(b) of 002", "",
              f"us est.: our cycles at {_f(est, '{:.1f}')} MHz, the lowest Fmax of the small ADMM cores on the "
              "LFE5U-85F, with the cycles of the masses core at the small cores' latencies ("
              + _est_lat_text(br) + "): an estimate of what an ECP5-class fabric would give, not a measurement (no ECP5 holds "
              "the masses core).", ""]
        body = [[str(r["P"]), str(r["b"]), _f(r["cycles_per_solve_measured"], "{}"), _f(r["cycles_per_solve_est"], "{}"),
                 _f(r["latency_us_ecp5_est"], "{:.2f}"),
                 _f(r["latency_us_v6_ours"], "{:.2f}"), _f(r["latency_us_v6_paper"]),
                 _f(r["latency_us_s6_ours"], "{:.2f}"), _f(r["latency_us_s6_paper"])] for r in br]
        L += _table(["P", "b", f"cycles/solve (Imax = {imax})", "cycles/solve est.", "us est.", "us at 400 MHz",
                     "Table III(b) V6",
                     "us at 230 MHz", "Table III(b) S6"], body)
    if sw and br:
        lo, hi = sw["u_box"]
        act = sw.get("active", {})
        L += ["", "### Software on this CPU", "",
              f"One closed loop of {r0['problem']} ({sw['steps']} steps, references anywhere in 80 % of their box "
              f"changing every {sw['hold']} steps, x0 = 0, u_prev = 0, driven by the float ADMM with "
              "u = clip(u_prev + du0, umin, umax)), replayed "
              f"{sw['repeats']} time(s) into each solver (OSQP and numpy ADMM warm-started from their own previous "
              "solution). "
              f"Limits binding on the plant: soft position limits exceeded at {100 * act.get('soft', 0):.0f} % of "
              f"the steps, an input at its box at {100 * act.get('box', 0):.0f} %, an input change at the rate "
              f"limit at {100 * act.get('rate', 0):.0f} %. OSQP solves the soft-constrained sparse QP (8) of 002 "
              f"(n_A = {r0['n']} variables; F z = b(w), the boxes and three rows per soft pair, as "
              "mpc_cores/admm/problem.py gives it to OSQP), updating q = h(w) and b(w) per step. numpy ADMM is "
              "Algorithm 2 on the unquantised M11, G~ with the core's rho_j, Imax and warm start (the iteration of "
              "mpc_cores.admm.model.AdmmFloat, without its per-call set-up: max |z - z_AdmmFloat| = "
              f"{sw['numpy_vs_admmfloat']:.1e} over the first 20 solves). Median, p90, max and the replays as for "
              "the FGM" + _load_text(sw) + f". Error: max and median over the loop of |du0 - du0*|, du0* from OSQP at eps 1e-9 "
              f"(median / max {sw['ref_iters'][0]:.0f} / {sw['ref_iters'][1]} iterations; du0 in [{lo:g}, {hi:g}]).",
              ""]
        L += _software_solvers(sw)
        L += ["", "Core (bit-exact golden model, same QPs): " + ", ".join(
            f"b = {b}: error max {e[0]:.2e} (step {e[2]}, {e[2] % sw['hold']} after a reference change), "
            f"median {e[1]:.2e}" for b, e in sorted(sw["core_err"].items()))
              + f". numpy ADMM runs the same iteration in exact arithmetic: where its largest error matches the "
              f"core's, that error is the algorithm's after {sw['imax']} warm-started iterations, not the fixed "
              "point's (compare the medians).", ""]
        body = [[str(r["P"]), str(r["b"]), _f(r["latency_us_ecp5_est"]), _f(r["latency_us_v6_ours"]),
                 _x(r["osqp_default_over_core"]), _x(r["osqp_tuned_over_core"]), _x(r["numpy_admm_over_core"]),
                 _x(r["osqp_default_over_core_v6"]), _x(r["osqp_tuned_over_core_v6"]),
                 _x(r["numpy_admm_over_core_v6"])] for r in br]
        L += _table(["P", "b", "core us est. (ECP5)", "core us at 400 MHz", "OSQP default / core est.",
                     "OSQP tuned / core est.", "numpy ADMM / core est.", "OSQP default / core at 400 MHz",
                     "OSQP tuned / core at 400 MHz", "numpy ADMM / core at 400 MHz"], body)
        L += solver_section(
            br, sw, "est. ECP5",
            f"The QP of every step (problem B): the soft-constrained sparse QP (8) of 002 as OSQP gets it above "
            f"(n_A = {r0['n']} variables). PIQP (sparse backend) gets the equality rows as A z = b(w), the rows "
            "that bound one variable (the boxes, delta >= 0) as variable bounds and the two slanted rows per "
            "soft pair as two-sided rows; Clarabel the equality rows as a zero cone and every finite bound as one "
            "nonnegative-cone row. Both are interior-point methods and start cold; OSQP starts from its previous "
            "solution.",
            "Core us: the masses core's cycles at the small cores' latencies over their ECP5 Fmax (the estimate "
            "above); core solves/s: 1 / that latency (one QP in flight; the next input frame is buffered during "
            "the solve, the output beats after it are not counted).")
    if br:
        L += ["", "### MAC utilisation", ""]
        body = [[str(r["P"]), str(r["b"]), str(admm_useful_macs(r["n"])), str(r["multipliers"]),
                 _f(r["cycles_per_iteration_measured"], "{}"),
                 str(r["multipliers"] * (r["cycles_per_iteration_measured"] or r["cycles_per_iteration_corejson"])),
                 f"{100 * r['mac_utilisation']:.1f} %"] for r in br]
        L += _table(["P", "b", "useful MACs/iteration", "multipliers", "L_A", "multiplier-cycles", "utilisation"],
                    body)
        L += ["", "Useful: n_A^2 for M11 v (rho_j z, nu / rho_j and rho_j d are shifts). The idle share is the "
              "pipeline of each iteration (L_A - ceil(n_A/P) cycles: the tree, the projection and the updates), "
              "the multipliers of the last row block when P does not divide n_A, and the G~ (w, 1) pass of "
              "each solve.", ""]
    return L

