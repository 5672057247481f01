"""Formulas, records and report lines of the interior-point section of the benchmark (mpc_bench.ipm): Table I of 001
(floating-point units), eq. (18) (latency of 2P problems), one record per core (ipm.csv), the console summary and
the "## Interior-point core" part of report.md."""
from __future__ import annotations

import numpy as np

from mpc_bench.minres_report import F_001_MHZ, FLOAT_KINDS, mem_list
from mpc_bench.report import _f, _table, _tool_columns, latency_us, pnr_cells, ratio
from mpc_bench.tools import XC7_SCOPE, seeds_phrase

# Table I of 001 (floating-point units of the whole circuit): Stage 1 3i (i parallel instances of Stage 1, 1 for
# most problems), dot-product block of the linear solver 4M - 3, other linear-solver units 27: 4M + 24 + 3i.
STAGE1_001_PER_INSTANCE, OTHER_001 = 3, 27


def table1_001(M: int, i: int = 1) -> dict[str, int]:
    """Floating-point units of 001's circuit (Table I) for a KKT matrix of half-bandwidth M and i Stage 1 blocks."""
    return {"stage1": STAGE1_001_PER_INSTANCE * i, "dot": 4 * M - 3, "other": OTHER_001,
            "total": 4 * M + 24 + STAGE1_001_PER_INSTANCE * i}


def eq18_cycles(P: int, N: int, i_nw: int, i_mr: int) -> int:
    """Cycles of eq. (18) of 001: 2 I_NW (P N + P) I_MR, the latency of 2P problems."""
    return 2 * i_nw * (P * N + P) * i_mr


def measured_latency(rec: dict | None) -> dict:
    """The `latency` record of the testbench (rounds "0" cold, "1" warm; per channel the cycles from its id word to
    its status word): the largest latency of each round and the warm round's per channel, in channel order."""
    if not rec:
        return {}
    rounds = rec["rounds"]
    warm = rounds["1"]["latency"]
    return {"cold": max(rounds["0"]["latency"].values()), "warm": max(warm.values()),
            "per_channel": [warm[k] for k in sorted(warm, key=int)]}


def fp_units(u: dict | None) -> int | None:
    return sum(u[k] for k in FLOAT_KINDS) if u else None


# ----------------------------------------------------------------------------------------- records

def ipm_rows(cores: list, sw: dict | None) -> list[dict]:
    """One flat record per core: the CSV rows and the source of every table of the section. The latency of a core
    without its own Fmax is quoted at the lowest Fmax of the placed cores (marked est.) and at 001's 150 MHz."""
    placed = [c.pnr["fmax_mhz"] for c in cores if c.pnr]
    est = min(placed) if placed else None
    out = []
    for c in cores:
        cj, st1 = c.core, c.core["stage1_cycles"]
        P, N, M = cj["P"], cj["N"], cj["M"]
        meas = measured_latency(c.measured)
        t1 = table1_001(M)
        u = c.units or {}
        lat, lat1 = cj["latency_cycles"], cj["cycles_per_solve"]
        r = {
            "problem": c.problem, "role": c.role, "P": P, "problems_in_flight": cj["problems_in_flight"],
            "n": cj["n"], "m": cj["m"], "T": cj["T"], "N": N, "M": M, "P_eq15": cj["P_eq15"],
            "i_nw": cj["i_nw"], "i_mr": cj["iterations"], "format": cj["format"],
            **{f"stage1_{k}": v for k, v in st1.items()},
            "stage1_per_problem": st1["linearise"] + st1["receive"] + st1["update"],
            "minres_per_problem": (cj["iterations"] + 1) * cj["slot_cycles"], "slot_cycles": cj["slot_cycles"],
            "stage1_hidden": cj["stage1_hidden"], "stage1_note": cj["stage1_note"],
            "latency_cycles": lat, "latency_cycles_cold": cj["latency_cycles_cold"],
            "latency_per_channel": " ".join(map(str, cj["latency_per_channel"])),
            "cycles_per_newton_iteration": cj.get("cycles_per_newton_iteration"),
            "eq18_per_newton_iteration": 2 * (P * N + P) * cj["iterations"],
            "cycles_per_solve": lat1, "eq18_cycles": eq18_cycles(P, N, cj["i_nw"], cj["iterations"]),
            "latency_over_eq18": lat / eq18_cycles(P, N, cj["i_nw"], cj["iterations"]),
            "measured_latency": meas.get("warm"), "measured_latency_cold": meas.get("cold"),
            "measured_per_channel": " ".join(map(str, meas["per_channel"])) if meas else None,
            "measured_equals_corejson": (meas["warm"] == lat and meas["cold"] == cj["latency_cycles_cold"]
                                         and meas["per_channel"] == cj["latency_per_channel"]) if meas else None,
            "storage_minres": cj["storage_words"]["minres"], "storage_stage1": cj["storage_words"]["stage1_slots"]
            + cj["storage_words"]["stage1_const"],
            "multipliers_minres_corejson": cj["multipliers_minres"],
            "fcompare": c.compares,
            "fp_units_001_stage1": t1["stage1"], "fp_units_001_linear": t1["dot"] + t1["other"],
            "fp_units_001": t1["total"],
        }
        for part in ("stage1", "minres", "total"):
            for k in FLOAT_KINDS:
                r[f"{part}_{k.lower()}"] = (u.get(part) or {}).get(k)
            r[f"fp_units_{part}"] = fp_units(u.get(part))
        _tool_columns(c, r)
        f = r["fmax_mhz"]
        r["fmax_est_mhz"] = est if f is None else None
        for key, fq in (("", f), ("_est", r["fmax_est_mhz"]), ("_150", F_001_MHZ)):
            r[f"latency_us{key}"] = latency_us(lat, fq)
            r[f"per_problem_us{key}"] = latency_us(lat, fq) / (2 * P) if fq else None
            r[f"solve_alone_us{key}"] = latency_us(lat1, fq)
        r["eq18_us_150"] = latency_us(r["eq18_cycles"], F_001_MHZ)
        _sw_columns(r, sw)
        out.append(r)
    return out


def _core_us(r: dict) -> tuple[float | None, float | None, float | None, str]:
    """(latency of 2P, per problem at full throughput, one problem alone) in us at the core's Fmax, else at the
    estimate, else at 150 MHz; and which clock."""
    for key, what in (("", "Fmax"), ("_est", "est."), ("_150", "150 MHz")):
        if r.get(f"latency_us{key}") is not None:
            return r[f"latency_us{key}"], r[f"per_problem_us{key}"], r[f"solve_alone_us{key}"], what
    return None, None, None, ""


def _sw_columns(r: dict, sw: dict | None) -> None:
    lat, per, alone, _ = _core_us(r)
    for s in (sw or {}).get("solvers", []):
        key = s.name.lower().replace(" ", "_")
        r[f"sw_{key}_us"] = s.ref_median_us
        r[f"sw_{key}_basis"] = s.basis
        r[f"sw_{key}_over_latency"] = ratio(s.ref_median_us, lat)
        r[f"sw_{key}_over_per_problem"] = ratio(s.ref_median_us, per)
        r[f"sw_{key}_over_alone"] = ratio(s.ref_median_us, alone)


# ----------------------------------------------------------------------------------------- report

def _n(v) -> str:
    return _f(v, "{}")


def summary_table(recs: list[dict]) -> list[str]:
    """Console and README table: one row per core."""
    hdr = ["problem", "P (in flight)", "I_NW / I_MR", "latency 2P cycles (eq. 18)", "measured", "Stage 1 hidden",
           "FP units (001)", "MULT18X18D", "LUT4", "FF", "Fmax MHz", "us: 2P / per problem / alone"]
    body = []
    for r in recs:
        lat, per, alone, what = _core_us(r)
        body.append([r["problem"], f"{r['P']} ({r['problems_in_flight']})", f"{r['i_nw']} / {r['i_mr']}",
                     f"{r['latency_cycles']} ({r['eq18_cycles']}, x{r['latency_over_eq18']:.2f})",
                     _n(r["measured_latency"]) + ("" if r["measured_equals_corejson"] in (None, True) else " (differs)"),
                     "yes" if r["stage1_hidden"] else "no", f"{_n(r['fp_units_total'])} ({r['fp_units_001']})",
                     _n(r.get("ecp5_MULT18X18D")), _n(r.get("ecp5_LUT4")), _n(r.get("ecp5_FF")),
                     _f(r["fmax_mhz"], "{:.1f}"),
                     f"{_f(lat, '{:.0f}')} / {_f(per, '{:.1f}')} / {_f(alone, '{:.0f}')}" + (f" ({what})" if lat else "")])
    return _table(hdr, body)


def _cycles_part(recs: list[dict]) -> list[str]:
    L = ["### Cycles", "",
         "core.json's cycle model (mpc_cores.ipm.timing.simulate): 2P problems sent back to back on an idle core, "
         "warm-started, the largest latency (id word to status word); eq. (18) of 001 is 2 I_NW (P N + P) I_MR. "
         "Measured: the cocotb test `latency` of the kind's testbench in Verilator (2P problems cold, then warm; "
         "per answer the cycles from the id word's handshake to the status word's).", ""]
    body = [[r["problem"], f"{r['P']} ({r['P_eq15']})", str(r["problems_in_flight"]), f"{r['i_nw']} / {r['i_mr']}",
             str(r["N"]), str(r["latency_cycles"]), str(r["eq18_cycles"]), f"{r['latency_over_eq18']:.3f}",
             _n(r["measured_latency"]), _f(r["measured_equals_corejson"], "{}", "not run"),
             f"{_n(r['cycles_per_newton_iteration'])} ({r['eq18_per_newton_iteration']})",
             str(r["cycles_per_solve"]), str(r["latency_cycles_cold"]), _n(r["measured_latency_cold"])]
            for r in recs]
    L += _table(["problem", "P (eq. 15)", "in flight", "I_NW / I_MR", "N", "latency 2P (core.json)", "eq. (18)",
                 "ratio", "measured", "measured = core.json", "per Newton iteration (2 (P N + P) I_MR)",
                 "one problem alone", "cold 2P", "measured cold"], body)
    L += ["", "Stage 1 program cycles per problem (mpc_cores.ipm.isa, core.json `stage1_cycles`) and whether Stage 1 "
          "hides behind MINRES (a Newton iteration of the 2P problems takes two MINRES batches back to back, "
          "2 (I_MR + 1) P S cycles; mpc_cores.ipm.timing.stage1_hidden):", ""]
    body = [[r["problem"], str(r["P"]), *(str(r[f"stage1_{k}"]) for k in
                                           ("sample", "cold", "warm", "linearise", "receive", "update", "output")),
             str(r["stage1_per_problem"]), f"{r['minres_per_problem']} (S = {r['slot_cycles']})",
             "yes" if r["stage1_hidden"] else "no"] for r in recs]
    L += _table(["problem", "P", "sample", "cold", "warm", "linearise", "receive", "update", "output",
                 "Stage 1 per problem", "MINRES per problem", "hidden"], body)
    L += ["", "Where the core takes more than eq. (18): 001 counts I_NW linear solves of (P N + P) I_MR cycles for "
          "both halves of the 2P problems. MINRES runs consecutive batches back to back, so once Stage 1 hides, a "
          "Newton iteration takes 2 (I_MR + 1) P S: the core adds the init pass of each batch (r_0 = b - d A z_0, "
          "the warm start) and the Stage 1 programs that cannot overlap (sample and cold/warm start before the "
          "first batch, update and output after the last). With P below eq. (15) the slots stretch (S > N), and "
          "such a core is far from eq. (18) by construction.", ""]
    return L


def _fit(c) -> str:
    """Whether the synthesised core fits the LFE5U-85F (hard blocks, LUT4, FF: mpc_bench.minres.logic_fit)."""
    from mpc_bench.minres import logic_fit

    if not c.ecp5:
        return "-"
    over = logic_fit(c.ecp5)
    return "fits" if not over else "no: " + "; ".join(over)


def _units_part(cores: list, recs: list[dict]) -> list[str]:
    L = ["### Floating-point units (Table I of 001) and resources (Yosys)", ""]
    body = [[r["problem"], str(r["P"]), str(r["M"]),
             *(f"{_n(r[f'{p}_fmul'])} / {_n(r[f'{p}_fadd'])} / {_n(r[f'{p}_fdiv'])} / {_n(r[f'{p}_fsqrt'])}"
               for p in ("stage1", "minres")),
             _n(r["fp_units_stage1"]), str(r["fp_units_001_stage1"]), _n(r["fp_units_minres"]),
             str(r["fp_units_001_linear"]), _n(r["fp_units_total"]), str(r["fp_units_001"]), _n(r["fcompare"])]
            for r in recs]
    L += _table(["problem", "P", "M", "Stage 1 FMul / FAdd / FDiv / FSqrt", "MINRES FMul / FAdd / FDiv / FSqrt",
                 "Stage 1", "001", "linear solver", "001 (4M + 24)", "total", "001 (4M + 27)", "FCompare"], body)
    L += ["", "Counted: instances of the float library's FMul, FAdd, FDiv and FSqrt in the generated SystemVerilog "
          "through the hierarchy (mpc_bench.minres_report.float_units), under the Stage 1 engine and the MINRES core "
          "of the top level; FCompare: comparator instances (not in Table I: 001 tests the sign bit only). Table I "
          "of 001: Stage 1 3i (i = 1 Stage 1 instance), dot-product block 4M - 3, 27 other linear-solver units: "
          "4M + 24 + 3i.", ""]
    syn = [(c, r) for c, r in zip(cores, recs) if r.get("ecp5_LUT4") is not None or r.get("xc7_LUT") is not None]
    if syn:
        body = [[c.tag, _n(r.get("ecp5_MULT18X18D")), _n(r.get("ecp5_LUT4")), _n(r.get("ecp5_CCU2C")),
                 _n(r.get("ecp5_FF")), _n(r.get("ecp5_DP16KD")), _n(r.get("ecp5_LUTRAM")),
                 _fit(c), f"{pnr_cells(c, '')[0]} MHz" if c.pnr else (c.pnr_note or "-"),
                 _n(r.get("xc7_DSP48E1")), _n(r.get("xc7_LUT")),
                 _n(r.get("xc7_FF")), _f(r.get("xc7_RAMB"), "{:g}")] for c, r in syn]
        L += _table(["core", "MULT18X18D", "LUT4", "CCU2C", "FF", "DP16KD", "DPR16X4", "LFE5U-85F", "nextpnr",
                     "DSP48E1", "LUT", "FF", "RAMB36"], body)
        L += ["", "ECP5: `synth_ecp5`, fit against the LFE5U-85F (hard blocks: mpc_bench.parsers.ecp5_fit; LUT4 and "
              "FF: mpc_bench.minres.logic_fit); " + XC7_SCOPE + "Memories as Yosys inferred them:", ""]
        L += [f"- {c.tag}: ECP5 {mem_list(c.ecp5_mem) or '-'}; xc7 {mem_list(c.xc7_mem) or '-'}" for c, _ in syn
              if c.ecp5_mem or c.xc7_mem] or ["- (none reported)"]
    else:
        L += ["No core was synthesised in this run.", ""]
    L += [""]
    placed = [(c, r) for c, r in zip(cores, recs) if c.pnr or (c.place and c.pnr_note)]
    L += ["### Fmax (nextpnr-ecp5, LFE5U-85F, CABGA381, speed 8)", "",
          f"constraints/ipm_core.lpf (the clock only, 001's 150 MHz), {seeds_phrase([c for c, _ in placed])}, "
          "`--lpf-allow-unconstrained`: "
          "register to register.", ""]
    if placed:
        L += _table(["core", "Fmax MHz", "TRELLIS_COMB", "critical path (register to register)", "logic cells",
                     "ns"], [[c.tag, *pnr_cells(c, _n(r.get("ecp5_TRELLIS_COMB_pnr")))] for c, r in placed])
        for c, _ in placed:
            cp = (c.pnr or {}).get("critical_path")
            if cp:
                L += ["", f"{c.tag}: RTL signals on the critical path: " + ", ".join(cp["signals"]) + "."]
    else:
        L += ["No core was placed and routed in this run."]
    return L + [""]


def _software_part(m: dict, sw: dict) -> list[str]:
    L = ["### Software on this CPU (same QPs)", "",
         f"The closed loop of {m['problem']} (mpc_cores.ipm.study.loop: {sw['steps']} steps from x = 0, references "
         f"changing every {sw['hold']} steps) under the core's bit-exact model (mpc_cores.ipm.core_model, warm "
         "start); each step's QP (x, r) replayed into every solver on the condensed form of the same MPC problem "
         "(same minimiser u as the sparse QP the core solves), set up once, the linear term updated per step; "
         f"{sw['repeats']} replay(s) each, half before and half after the hardware jobs{_load(sw)}. Median: the "
         "smallest of the replays' medians per solve; error: |u0 - u0*|_inf against OSQP at eps 1e-9.", ""]
    body = []
    for s in sw["solvers"]:
        it = f"{np.median(s.iters):.0f} / {max(s.iters)}" if s.iters else "-"
        body.append([s.name, f"{s.median_us:.1f}", f"{np.percentile(s.times_us, 90):.1f}", it, f"{s.u_err:.1e}",
                     s.settings])
    L += _table(["solver", "median us", "p90 us", "iterations median / max", "error max", "settings"], body)
    ce = sw["core_err"]
    L += ["", f"The core (bit-exact model, I_NW = {m['i_nw']}, I_MR = {m['i_mr']}) on the same loop: error max "
          f"{ce[0]:.1e}, median {ce[1]:.1e}; closed-loop cost {sw['cost_rel']:+.2e} relative to OSQP's optimum.", ""]
    lat, per, alone, what = _core_us(m)
    body = [[s.name, f"{s.ref_median_us:.1f} ({s.basis})", _f(ratio(s.ref_median_us, alone), "{:.2f}x"),
             _f(ratio(s.ref_median_us, lat), "{:.2f}x"), _f(ratio(s.ref_median_us, per), "{:.2f}x")]
            for s in sw["solvers"]]
    L += [f"Core {m['problem']} P = {m['P']} ({m['problems_in_flight']} problems in flight) at {what}"
          f"{' (' + _f(m['fmax_est_mhz'] or m['fmax_mhz'], '{:.1f}') + ' MHz)' if what != '150 MHz' else ''}: "
          f"one problem alone {_f(alone, '{:.0f}')} us, 2P back to back {_f(lat, '{:.0f}')} us (the last answer), "
          f"{_f(per, '{:.1f}')} us per problem at full throughput ({_f(1e6 / per if per else None, '{:.0f}')} QPs/s); "
          f"at 150 MHz {m['latency_us_150']:.0f} us for 2P, eq. (18) at 150 MHz {m['eq18_us_150']:.0f} us.", ""]
    L += _table(["solver", "median us (timer)", "/ core alone", "/ core latency 2P", "/ core per problem"], body)
    return L + ["", "x / core: software time per solve over the core's time (> 1: the core is faster). Latency: "
                "what a problem waits when 2P arrive together; per problem: latency / 2P, one solve's share at "
                "full throughput.", ""]


def _load(sw: dict) -> str:
    load = sw.get("load")
    vals = load if isinstance(load, list) else [load]
    vals = [v for v in vals if v is not None]
    return f" (1-minute load average {' and '.join(f'{v:.2f}' for v in vals)})" if vals else ""


def ipm_section(cores: list, recs: list[dict], sw: dict | None, info: dict) -> list[str]:
    """The "## Interior-point core" section of report.md."""
    r0 = next((r for r in recs if r["role"] == "masses"), recs[0])
    L = ["## Interior-point core", "",
         f"Algorithm 1 of 001 (infeasible primal-dual interior point, sparse QP of section II-B) as one core: the "
         f"Stage 1 engine and MINRES in its warm form, 2P problems in flight, {r0['format']}. {r0['problem']}: "
         f"n = {r0['n']}, m = {r0['m']}, T = {r0['T']} (N = {r0['N']}, M = {r0['M']}), the default design "
         f"(P = {r0['P']} from eq. (15), I_NW = {r0['i_nw']}, I_MR = {r0['i_mr']}). " + info.get("plan_text", ""), ""]
    L += _cycles_part(recs)
    L += _units_part(cores, recs)
    if sw:
        L += _software_part(r0, sw)
    L += ["### Step times (s; empty when cached or from the result store)", ""]
    L += _table(["core", "sbt (share)", "Verilator", "Yosys ECP5", "nextpnr", "Yosys xc7"],
                [[c.tag] + [_f(c.seconds.get(k), "{:.0f}", "") for k in
                            ("sbt", "verilator", "yosys_ecp5", "nextpnr", "yosys_xc7")] for c in cores])
    L += ["", f"Interior-point part: {info.get('runtime_s', 0) / 60:.1f} min. Files: ipm.csv (one row per core); per "
          "core under ipm/cores/: the SystemVerilog, core.json, the simulation, Yosys and nextpnr logs.", ""]
    if info.get("errors"):
        L += ["Interior-point steps that failed:", ""] + [f"- {e}" for e in info["errors"]] + [""]
    return L
