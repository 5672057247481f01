"""Records and report lines of the DGP section of the benchmark (mpc_bench.dgp): one record per core (cycles against
core.json, resources, Fmax, iterations and latency over the closed loop and over random states, the software solvers
against the core), the section of report.md and the console summary. Pure functions of the section's results."""
from __future__ import annotations

import numpy as np

from mpc_bench.baselines import own_columns, slug, software_notes, timer_table
from mpc_bench.qp import _load_text, _mem_list
from mpc_bench.report import _f, _table, _tool_columns, latency_us, pnr_cells
from mpc_bench.tools import XC7_SCOPE, seeds_phrase


def latency_cycles(overhead: int, cycles_per_iteration: int, iters, zero=None, saving: int = 0) -> np.ndarray:
    """Cycles from the last input word to the first answer word: overhead + I x cycles_per_iteration, less
    `saving` (core.json's zero_start_saving_cycles) where `zero` (a solve's starting dual was all zero)."""
    c = overhead + np.asarray(iters, dtype=np.int64) * cycles_per_iteration
    return c if zero is None else c - np.asarray(zero, dtype=np.int64) * saving


def stats(v) -> tuple[float, float, float]:
    """(median, p99, max)"""
    v = np.asarray(v, dtype=float)
    return float(np.median(v)), float(np.percentile(v, 99)), float(v.max())


def fit_85f(ecp5: dict | None) -> str | None:
    """Whether Yosys's ECP5 resources fit the LFE5U-85F (mpc_bench.minres.logic_fit); None when not synthesised."""
    from mpc_bench.minres import logic_fit

    if not ecp5:
        return None
    over = logic_fit(ecp5)
    return "fits" if not over else "no: " + "; ".join(over)


def _case(r: dict, key: str, iters, met, over: int, L: int, fmax: float | None, zero=None, saving: int = 0) -> None:
    """The iteration and latency fields of one case ("loop", "cold") of a core's record; zero: the zero starts."""
    it = stats(iters)
    cycles = latency_cycles(over, L, iters, zero, saving)
    cyc = stats(cycles)
    r.update({f"{key}_solves": len(iters), f"{key}_met": int(np.sum(met)),
              f"{key}_iter_median": it[0], f"{key}_iter_p99": it[1], f"{key}_iter_max": int(it[2]),
              f"{key}_cycles_median": cyc[0], f"{key}_cycles_p99": cyc[1], f"{key}_cycles_max": int(cyc[2])})
    for name, v in zip(("median", "p99", "max"), cyc):
        r[f"{key}_us_{name}"] = latency_us(v, fmax)
    r[f"{key}_zero_starts"] = int(np.sum(zero)) if zero is not None else 0
    r[f"{key}_cycles_mean"] = float(np.mean(cycles))
    r[f"{key}_us_mean"] = latency_us(r[f"{key}_cycles_mean"], fmax)


def dgp_rows(cores: list, loop, sw: dict | None) -> list[dict]:
    """One record per core."""
    out = []
    for c in cores:
        cj, m = c.core, c.measured
        L, over = cj["cycles_per_iteration"], cj["solve_overhead_cycles"]
        r = {"role": c.role, "tag": c.tag, "problem": cj["name"], "accelerated": cj["accelerated"],
             "lanes": cj["lanes"], "n": cj["n"], "nw": cj["nw"], "mc": cj["mc"], "m": cj["m"],
             "b": cj["frac_bits"], "int_bits": cj["int_bits"], "width": cj["data_format"]["width"],
             "imax": cj["iterations"], "lat_add": cj["lat_add"], "lat_mul": cj["lat_mul"], "target": cj["target"],
             "cycles_per_iteration": L, "overhead": over, "cycles_at_imax": cj["cycles_at_imax"],
             "zero_start_saving": cj["zero_start_saving_cycles"],
             "issue_K": cj["issue_cycles"]["K"], "issue_G": cj["issue_cycles"]["G"],
             "issue_F": cj["issue_cycles"]["F"], "div_cycles": cj["div_cycles_per_word"],
             "multipliers": cj["multipliers"], "mult18_products": c.mult18,
             "measured_cycles_per_iteration": m["cycles_per_iteration"] if m else None,
             "measured_overhead": m["overhead"] if m else None,
             "measured_equals_corejson": (m["cycles_per_iteration"] == L and m["overhead"] == over) if m else None}
        _tool_columns(c, r)
        r["fit_85f"] = fit_85f(c.ecp5)
        f = r["fmax_mhz"]
        r["worst_us"] = latency_us(cj["cycles_at_imax"], f)
        if loop is not None and c.role in loop.iters:
            save = r["zero_start_saving"]
            _case(r, "loop", loop.iters[c.role], loop.met[c.role], over, L, f, loop.zero.get(c.role), save)
            _case(r, "cold", loop.cold_iters[c.role], loop.cold_met[c.role], over, L, f, loop.cold_zero.get(c.role),
                  save)
            r["core_err_max"], r["core_err_median"] = loop.core_err[c.role]
        _sw_columns(r, sw)
        out.append(r)
    return out


def _sw_columns(r: dict, sw: dict | None) -> None:
    """Per solver: its median and p99 wall time per solve, and, by its own timer where it has one (else by wall
    time), their ratios to the core's median and p99 latency over the loop, the throughput ratio (the core's solves
    per second over the solver's, both on the loop solved back to back: the solver's mean time over the core's mean
    latency), and the break-even clocks in MHz (the core's cycles over the solver's us: median, p99, mean), which
    need no Fmax."""
    med, p99, mean = r.get("loop_us_median"), r.get("loop_us_p99"), r.get("loop_us_mean")
    r["core_solves_per_s"] = 1e6 / mean if mean else None
    r.update(own_columns(sw, {"median": med, "p99": p99, "max": r.get("loop_us_max")}))
    for s in (sw or {}).get("solvers", []):
        k = slug(s.name)
        r.update({f"{k}_median_us": s.median_us, f"{k}_p99_us": s.p99_us, f"{k}_mean_us": s.mean_us,
                  f"{k}_error_max": s.u_err, f"{k}_basis": s.basis,
                  f"{k}_median_over_core": s.ref_median_us / med if med else None,
                  f"{k}_p99_over_core": s.ref_p99_us / p99 if p99 else None,
                  f"{k}_throughput_ratio": s.ref_mean_us / mean if mean else None})
        if "loop_cycles_median" in r:
            r.update({f"{k}_breakeven_mhz_median": r["loop_cycles_median"] / s.ref_median_us,
                      f"{k}_breakeven_mhz_p99": r["loop_cycles_p99"] / s.ref_p99_us,
                      f"{k}_breakeven_mhz_mean": r["loop_cycles_mean"] / s.ref_mean_us})


# ----------------------------------------------------------------------------------------- report

def _n(v) -> str:
    return _f(v, "{}")


def _form(r: dict) -> str:
    return "accelerated" if r["accelerated"] else "plain"


def _cycles_part(rows: list[dict]) -> list[str]:
    L = ["### Cycles", "",
         "core.json's contract: overhead + I x cycles per iteration from the last input word to the first answer "
         "word, I the iterations run (1..Imax), less the zero start's saving when the starting dual is all zero "
         "(every cold start: the first iteration's passes K and G skipped); cycles per iteration = pass K (at most "
         "ceil(n / P) ceil(mc / lanes) issue cycles) + its pipeline + pass G (at most ceil(mc / P) ceil(n / lanes)) "
         "+ its pipeline + 1. Measured: the cocotb test `cycle_contract` of verif/dgp/tb.py in Verilator, which asserts "
         "every answer's cycle against the contract (cold zero starts at Imax = 1, 2, 3; warm starts, the first "
         "from a nonzero dual) and reads CYCLES_PER_ITER.", ""]
    body = [[r["tag"], f"{r['issue_K']} + {r['issue_G']}", str(r["cycles_per_iteration"]), str(r["overhead"]),
             _n(r.get("zero_start_saving")),
             f"{_n(r['measured_overhead'])} + I x {_n(r['measured_cycles_per_iteration'])}"
             if r["measured_cycles_per_iteration"] is not None else "not run",
             _f(r["measured_equals_corejson"], "{}", "-"), f"{r['cycles_at_imax']} ({r['imax']})",
             str(r["multipliers"]), str(r["mult18_products"])] for r in rows]
    L += _table(["core", "issue K + G", "cycles / iteration", "overhead", "zero start saves", "measured", "= core.json",
                 "cycles at Imax (Imax)", "multipliers", "MULT18X18D of the products"], body)
    return L + [""]


def _resources_part(cores: list, rows: list[dict]) -> list[str]:
    L = ["### Resources (Yosys) and Fmax (nextpnr-ecp5, LFE5U-85F, CABGA381, speed 8)", ""]
    syn = [(c, r) for c, r in zip(cores, rows) if r.get("ecp5_LUT4") is not None or r.get("xc7_LUT") is not None]
    if syn:
        body = [[c.tag, _n(r.get("ecp5_MULT18X18D")), _n(r.get("ecp5_LUT4")), _n(r.get("ecp5_CCU2C")),
                 _n(r.get("ecp5_FF")), _n(r.get("ecp5_DP16KD")), _n(r.get("ecp5_LUTRAM")), r["fit_85f"] or "-",
                 _n(r.get("xc7_DSP48E1")), _n(r.get("xc7_LUT")), _n(r.get("xc7_FF")), _f(r.get("xc7_RAMB"), "{:g}")]
                for c, r in syn]
        L += _table(["core", "MULT18X18D", "LUT4", "CCU2C", "FF", "DP16KD", "DPR16X4", "LFE5U-85F", "DSP48E1", "LUT",
                     "FF", "RAMB36"], body)
        L += ["", "ECP5: `synth_ecp5`, fit against the LFE5U-85F (156 MULT18X18D, 208 DP16KD, 83640 LUT4 and FF; "
              "mpc_bench.minres.logic_fit: LUT4 + 2 CCU2C + 3 DPR16X4); " + XC7_SCOPE + "Memories as Yosys inferred them:", ""]
        L += [f"- {c.tag}: ECP5 {_mem_list(c.ecp5_mem, c.module) or '-'}; xc7 {_mem_list(c.xc7_mem, c.module) or '-'}"
              for c, _ in syn if c.ecp5_mem or c.xc7_mem] or ["- (none reported)"]
    else:
        L += ["No core was synthesised in this run" + (" (QUICK takes Yosys results from the cache only)."
                                                        if any("QUICK" in (c.pnr_note or "") for c in cores) else ".")]
    L += ["", f"constraints/dgp_core.lpf (the clock at 200 MHz, LVCMOS33), {seeds_phrase(cores)}, "
          "`--lpf-allow-unconstrained`: register to register.", ""]
    L += _table(["core", "Fmax MHz", "TRELLIS_COMB", "critical path (register to register)", "logic cells", "ns"],
                [[c.tag, *pnr_cells(c, _n(r.get("ecp5_TRELLIS_COMB_pnr")))] for c, r in zip(cores, rows)])
    for c in cores:
        cp = (c.pnr or {}).get("critical_path")
        if cp:
            L += ["", f"{c.tag}: RTL signals on the critical path: " + ", ".join(cp["signals"]) + "."]
    return L + [""]


def _iterations_part(rows: list[dict], loop) -> list[str]:
    mt = loop.meta
    L = ["### Iterations and latency", "",
         f"Closed loop: {mt['steps']} steps of the nominal plant from x = 0, references changing every {mt['hold']} "
         f"steps (mpc_cores.closedloop.reference_schedule, seed {mt['seed']}), under the {mt.get('lead', '')} "
         "core's bit-exact model (mpc_cores.dgp.control's golden controller, the design's Imax, its u0 applied); "
         f"the parameter words of {mt['sat_steps']} step(s) saturated at the core's input (the state outside the "
         "accepted box). Every core's model solves the loop's parameter words in sequence, "
         + ", ".join(f"{role} {'warm (from the previous dual)' if warm else 'cold (y = 0)'}"
                     for role, warm in mt.get("warm", {}).items())
         + f" as its design starts. Cold: {mt['states']} random states of the accepted box and random references, "
         "y = 0. Met: the stopping "
         "test held (otherwise the solve ran to Imax). Zero starts: the solves whose starting dual was all zero (every "
         "cold start; warm, after a solve that ended with no row active), which skip the first passes K and G. "
         "Latency: overhead + I x cycles per iteration, less the zero start's saving; us at the core's placed "
         "Fmax.", ""]
    body = []
    for r in rows:
        warm = loop.meta.get("warm", {}).get(r["role"])
        for key, what in (("loop", f"closed loop{', warm' if warm else ', cold' if warm is False else ''}"),
                          ("cold", "random states, cold")):
            if f"{key}_solves" not in r:
                continue
            body.append([r["tag"], what, f"{r[f'{key}_met']} / {r[f'{key}_solves']}", str(r[f"{key}_zero_starts"]),
                         f"{r[f'{key}_iter_median']:g} / {r[f'{key}_iter_p99']:.1f} / {r[f'{key}_iter_max']}",
                         f"{r[f'{key}_cycles_median']:.0f} / {r[f'{key}_cycles_p99']:.0f} / {r[f'{key}_cycles_max']}",
                         " / ".join(_f(r[f"{key}_us_{s}"], "{:.1f}") for s in ("median", "p99", "max"))])
    L += _table(["core", "case", "met", "zero starts", "iterations median / p99 / max", "cycles median / p99 / max",
                 "us median / p99 / max"], body)
    L += ["", "At Imax (the bound the core never exceeds): "
          + "; ".join(f"{r['tag']} {r['cycles_at_imax']} cycles" + (f", {r['worst_us']:.0f} us" if r["worst_us"]
                                                                     else "") for r in rows) + "."]
    errs = [f"{r['tag']} max {r['core_err_max']:.1e}, median {r['core_err_median']:.1e}" for r in rows
            if r.get("core_err_max") is not None]
    if errs:
        L += ["", "Accuracy of the cores' answers on the loop's QPs, |u0 - u0*|_inf against OSQP at eps 1e-9: "
              + "; ".join(errs) + "."]
    return L + [""]


def _software_part(rows: list[dict], sw: dict) -> list[str]:
    L = ["### Software on this CPU (same QPs)", "",
         "Each step's QP of the closed loop at the parameters the core used (its words after the input saturation), "
         "in its own units (the core's row scaling undone): min 1/2 z'Qz + (Phi w)'z subject to lo(w) <= G z <= "
         "hi(w) (mpc_cores.dgp.problem.dgp_qp and bounds(w)), replayed into each solver set up once, the linear term "
         f"and the bounds updated per step; {sw['repeats']} replay(s) each, half before and half after the hardware "
         f"jobs{_load_text(sw)}.", ""]
    L += timer_table(sw) + [""] + software_notes(sw)
    body = []
    for r in rows:
        if "loop_solves" not in r:
            continue
        for s in sw["solvers"]:
            k = slug(s.name)
            it = f"{np.median(s.iters):.0f} / {max(s.iters)}" if s.iters else "-"
            body.append([r["tag"], f"{r['loop_cycles_median']:.0f} / {r['loop_cycles_p99']:.0f}",
                         " / ".join(_f(r[f"loop_us_{q}"], "{:.1f}") for q in ("median", "p99")),
                         _f(r["core_solves_per_s"], "{:.0f}"), s.name, s.basis, f"{s.ref_median_us:.1f}",
                         f"{s.ref_p99_us:.1f}", it,
                         _f(r.get(f"{k}_median_over_core"), "{:.2f}x"), _f(r.get(f"{k}_p99_over_core"), "{:.2f}x"),
                         _f(r.get(f"{k}_throughput_ratio"), "{:.2f}x"),
                         " / ".join(_f(r.get(f"{k}_breakeven_mhz_{q}"), "{:.0f}") for q in ("median", "p99", "mean"))])
    if body:
        L += _table(["core", "core cycles median / p99", "core us median / p99", "core solves/s", "solver",
                     "timer", "median us", "p99 us", "iterations median / max", "median / core median",
                     "p99 / core p99", "throughput core / solver", "break-even MHz median / p99 / mean"], body)
        L += ["", "The core's latency per QP of the loop, one QP in flight, in cycles and in us at its placed Fmax "
              "(none when not placed); its solves per second: the loop solved back to back (1 / mean latency; the "
              "input words and the answer's later words not counted). Throughput core / solver: the solver's mean "
              "time per solve over the core's mean latency. Above 1 the core is ahead. Break-even: the clock at which "
              "the core's cycles take the solver's time (median against median, p99 against p99, mean against mean): "
              "a core clocked faster is ahead, whether or not it was placed.", ""]
    return L


def dgp_section(cores: list, rows: list[dict], loop, sw: dict | None, info: dict) -> list[str]:
    """The "## Dual gradient projection core" section of report.md."""
    r0 = rows[0]
    L = ["## Dual gradient projection core", "",
         f"Run of {info.get('date') or '-'} ({'QUICK' if info.get('quick') else 'full'}). Iteration (35) of 003 in "
         f"fixed point (mpc_cores.dgp): {r0['problem']}, n = {r0['n']}, {r0['mc']} two-sided rows (input box and "
         f"position limits at stages 1..N; m = {r0['m']} one-sided), nw = {r0['nw']}; {r0['width']}-bit data words "
         f"(p = {r0['b']} fraction bits from (36), r = {r0['int_bits']} from (37)), Imax = {r0['imax']}, "
         f"{r0['lanes']} lanes, TARGET={r0['target']} (l_A = {r0['lat_add']}, l_M = {r0['lat_mul']}). "
         + info.get("plan_text", ""), ""]
    L += _cycles_part(rows)
    L += _resources_part(cores, rows)
    if loop is not None:
        L += _iterations_part(rows, loop)
    if sw:
        L += _software_part(rows, sw)
    L += ["### Step times (s; empty when cached or from the result store)", ""]
    L += _table(["core", "sbt (share)", "Verilator", "Yosys ECP5", "nextpnr", "Yosys xc7"],
                [[c.tag] + [_f(c.seconds.get(k), "{:.0f}", "") for k in
                            ("sbt", "verilator", "yosys_ecp5", "nextpnr", "yosys_xc7")] for c in cores])
    L += ["", f"DGP part: {info.get('runtime_s', 0) / 60:.1f} min. Files: dgp.csv (one row per core); per core under "
          "dgp/cores/: the SystemVerilog, core.json, the simulation, Yosys and nextpnr logs.", ""]
    if info.get("errors"):
        L += ["DGP steps that failed:", ""] + [f"- {e}" for e in info["errors"]] + [""]
    return L


def summary_lines(rows: list[dict], sw: dict | None) -> list[str]:
    """The console summary: one line per core, then the software solvers against each placed core."""
    L = ["Dual gradient projection core (iteration (35) of 003, fixed point)"]
    for r in rows:
        meas = ("measured equal" if r["measured_equals_corejson"] else
                "measured DIFFERENT" if r["measured_equals_corejson"] is False else "not measured")
        res = (f"{_n(r.get('ecp5_MULT18X18D'))} MULT18X18D, {_n(r.get('ecp5_LUT4'))} LUT4, {_n(r.get('ecp5_FF'))} FF, "
               f"{_n(r.get('ecp5_DP16KD'))} DP16KD ({r['fit_85f']})" if r.get("fit_85f") else "not synthesised")
        line = (f"  {r['tag']}: {r['overhead']} + I x {r['cycles_per_iteration']} cycles ({meas}); {res}; Fmax "
                f"{_f(r['fmax_mhz'], '{:.1f} MHz', 'not placed')}")
        if "loop_solves" in r:
            line += (f"; iterations loop {r['loop_iter_median']:g} / {r['loop_iter_p99']:.1f} / {r['loop_iter_max']}"
                     f", cold {r['cold_iter_median']:g} / {r['cold_iter_p99']:.1f} / {r['cold_iter_max']} "
                     "(median / p99 / max)")
        if r.get("loop_us_median") is not None:
            line += f"; loop latency {r['loop_us_median']:.1f} us median, {r['loop_us_p99']:.1f} us p99"
        L.append(line)
    if sw:
        L.append("  software on the loop's QPs (median / p99 us by the solver's own timer where it has one; per core: "
                 "median over the core's median latency at its Fmax, and the clock at which the core's median cycles "
                 "take the solver's median):")
        for s in sw["solvers"]:
            k = slug(s.name)
            cmp = ", ".join(f"{r['role']} " + (f"{r[f'{k}_median_over_core']:.2f}x, " if r.get(f"{k}_median_over_core")
                                                else "") + f"break-even {r[f'{k}_breakeven_mhz_median']:.0f} MHz"
                            for r in rows if r.get(f"{k}_breakeven_mhz_median") is not None)
            L.append(f"    {s.name}: {s.ref_median_us:.1f} / {s.ref_p99_us:.1f} us ({s.basis}), error {s.u_err:.1e}"
                     + (f"; {cmp}" if cmp else ""))
    return L
