"""FGM section of the benchmark (`make bench`): the FGM core on masses (examples/masses.yaml, n = 40, Imax = 15),
over P and frac_bits b:

  cycles       per iteration and per solve, measured in Verilator (cocotb test `cycle_contract` of verif.fgm.tb),
               beside eq. (23) of 002 and Imax L_F, the count behind Table III(a) of 002;
  resources    Yosys synth_ecp5 (MULT18X18D, LUT4, FF, DP16KD) and synth_xilinx -family xc7 (DSP48E1, LUT, FF,
               RAMB), beside the multipliers of Table I of 002, P (N n_u + 2);
  Fmax         nextpnr-ecp5 on the LFE5U-85F (speed 8, CABGA381) with constraints/fgm_core.lpf, and the
               critical path it reports; also on cores pipelined for Fmax (TARGET=ecp5, b = 15, l_M = 5);
  latency      cycles / Fmax, beside Table III(a) of 002 (Virtex-6 at 400 MHz, Spartan-6 at 230 MHz);
  software     on this CPU over one closed loop of masses (problem A, the condensed box QP): OSQP with default and
               with tuned embedded settings, DAQP (hot start), PIQP (dense), ProxQP (dense, warm start), Clarabel
               and quadprog (mpc_bench.qp_solvers), and FGM in float64 numpy with the same Imax, on the same QPs,
               single-threaded on one pinned CPU; median, p99 and max time per solve by wall clock and by each
               solver's own timer, and their ratios to the core's latency and throughput;
  MAC use      useful multiply-accumulates per iteration (n^2 for (I - H_n) y, 2n for the y update) over
               multipliers x cycles per iteration.

Writes fgm.csv, fgm_latency_vs_P.png, fgm_resources_vs_P.png and its part of report.md and fmax_vs_P.png.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from mpc_bench.baselines import (
    NumpyFgm, closed_loop_qps, core_ratios, fastest_cell, own_columns, prepare_fgm_software, slug, solver_section,
)
from mpc_bench.dgp_report import fit_85f, stats
from mpc_bench.plots import by_b, latency_plot, resources_plot
from mpc_bench.qp import (
    F_S6_MHZ, F_V6_MHZ, REFERENCE_CLOCKS, Core, QpSection, _core_latency, _fmax_section, _memories,
    _resource_cells, _software_solvers, _load_text,
)
from mpc_bench.report import _f, _table, _tool_columns, _x, latency_us, ratio
from mpc_bench.section import ints
from mpc_bench.tools import FMAX_SEEDS, FMAX_SEEDS_QUICK, PLACER_ARGS, cached_design
from mpc_cores.flow import REPO

MASSES = REPO / "examples/masses.yaml"
FULL_P, FULL_B = (1, 2, 4, 8), (12, 16)
QUICK_P, QUICK_B = (1,), (16,)
# The cores placed and routed for Fmax (role "fmax"): TARGET=ecp5, every product on a MULT18X18D with its input,
# pipeline and output registers, and l_M = 5: one stage more registers the operands in fabric before the DSP and
# one the DSP's output in fabric (docs/dsp.md, docs/benchmark.md). b = 15 keeps every operand of masses at 18 bits (the state words take 19 at b = 16), so a product
# is one MULT18X18D: P = 3 (126 of the 85F's 156) is the largest P that Yosys fits, but nextpnr did not route it
# within an hour (docs/benchmark.md), so it is not among the defaults. The sweeps keep the spec's l_A = l_M = 1, the
# latencies of eq. (23) and Table III(a) of 002.
FMAX_LAT = dict(lat_add=1, lat_mul=5, target="ecp5")
FMAX_B = 15
# The Fmax cores as (P, K_p, copies): one problem at a time (the latency reference); K_p = 2 problems interleaved
# on the row units (docs/fgm.md), which keeps every turn busy at P = 1 (K_p ceil(n/P) = 80 >= L_F = 60); and
# P = 3, the largest P whose multipliers fit the LFE5U-85F (126 of its 156 MULT18X18D), the shortest latency.
# Copies of a core placed together on one device (mpc_bench.harness; `--fgm-fmax 1x2x2`), the throughput one
# LFE5U-85F gives, are not in the default set: two copies of the K_p = 2 core were still routing after 40 minutes
# with 13k wires overused, for each of three seeds.
FMAX_FULL, FMAX_QUICK = ((1, 1, 1), (1, 2, 1), (3, 1, 1)), ((1, 1, 1),)
# The Fmax cores of one problem have the exit test (docs/fgm.md) at EXIT_TOL = 2^-9 (in the units of u, 64 LSB at
# b = 15): over the software loop their latency is overhead + I L_F with I the iterations the golden model runs
# there, warm-started step after step as in the loop; Imax bounds the worst case.
FMAX_EXIT_TOL = 2.0 ** -9
LOOP_HOLD = 30                   # the software loop's references hold this many steps


def fmax_cores(text: str | None, default) -> tuple[tuple[int, int, int], ...]:
    """`--fgm-fmax` items: P, P x K_p, or P x K_p x copies (e.g. "1,1x2,1x2x2")"""
    if not text:
        return default
    out = []
    for item in text.split(","):
        parts = [int(x) for x in item.strip().split("x")]
        if not 1 <= len(parts) <= 3 or min(parts) < 1:
            raise ValueError(f"--fgm-fmax item {item.strip()!r}: expected P, P x K_p or P x K_p x copies")
        out.append(tuple(parts + [1] * (3 - len(parts))))
    return tuple(out)

# Table III(a) of 002 (FGM, masses, Imax = 15): P -> (multipliers, Virtex-6 T_s at 400 MHz in us,
# Spartan-6 T_s at 230 MHz in us).
PAPER_TABLE3 = {1: (42, 1.95, 3.39), 2: (84, 1.20, 2.09), 3: (126, 0.98, 1.70), 4: (168, 0.82, 1.43),
                8: (336, 0.64, 1.10), 16: (672, 0.56, 0.98), 32: (1344, 0.53, 0.91)}

SW_KEYS = (("OSQP default", "osqp_default"), ("OSQP tuned", "osqp_tuned"), (NumpyFgm.name, "numpy_fgm"))


# ----------------------------------------------------------------------------------------- arithmetic

def useful_macs(n: int) -> int:
    """Multiply-accumulates one FGM iteration needs: n^2 for (I - H_n) y, 2n for y = (1 + beta) z - beta z_prev."""
    return n * n + 2 * n


def mac_utilisation(n: int, multipliers: int, cycles_per_iteration: int) -> float:
    """Useful MACs per iteration over what the multipliers could do in that many cycles."""
    return useful_macs(n) / (multipliers * cycles_per_iteration)


def eq23(n: int, P: int, lat_add: int, lat_mul: int) -> int:
    """L_F of eq. (23) of 002."""
    depth = math.ceil(math.log2(n)) if n > 1 else 0
    return -(-n // P) + lat_add * depth + 2 * lat_mul + 3 * lat_add + 1


def paper_multipliers(n: int, P: int) -> int:
    """Table I of 002: P (N n_u + 2) multipliers for the FGM architecture (n = N n_u)."""
    return P * (n + 2)


def paper_memory_blocks(n: int, nx: int, P: int) -> tuple[int, int]:
    """Table I of 002: P (N n_u + n_x + 4) memory blocks of ceil(N n_u / P) words for the FGM architecture."""
    return P * (n + nx + 4), -(-n // P)


# ----------------------------------------------------------------------------------------- records and tables

def loop_columns(r: dict, c: Core, iters, sw: dict | None) -> None:
    """A core with the exit test over the software loop: its iterations per step (median, p99, max), its latency
    overhead + I L_F in cycles and in us at its Fmax, and each solver's own-timer figures over that latency."""
    cj = c.core
    it = np.asarray(iters, dtype=np.int64)
    cyc = cj["solve_overhead_cycles"] + it * cj["cycles_per_iteration"]
    lat = {}
    for q, i, c in zip(("median", "p99", "max"), stats(it), stats(cyc)):
        r[f"loop_iter_{q}"], r[f"loop_cycles_{q}"] = i, c
        lat[q] = r[f"loop_us_{q}"] = latency_us(c, r["fmax_mhz"])
    r.update({"exit_tol": cj.get("exit_tol_value"), "loop_solves": len(it),
              "loop_exit_share": float(np.mean(it < cj["iterations"])), **own_columns(sw, lat)})


def fgm_rows(cores: list[Core], sw: dict | None, loops: dict | None = None) -> list[dict]:
    """One flat record per FGM core: the CSV rows and the source of every FGM table; `loops`: core tag ->
    iterations per step over the software loop, for the cores with the exit test (loop_columns)."""
    loops = loops or {}
    med = {r.name: r.ref_median_us for r in sw["solvers"]} if sw else {}
    out = []
    for c in cores:
        cj = c.core
        n, P = cj["n"], c.P
        cpi = c.measured["cycles_per_iteration"] if c.measured else None
        cps = c.measured["cycles_per_solve"] if c.measured else None
        cyc = cps if cps is not None else cj["cycles_per_solve"]
        kp = cj.get("problems", 1)
        # interleaving: the latency's worst case (the wait for the problem's turn) and the solves per cycle measured
        # with frames always waiting; one problem: its latency, and one solve per latency
        cyc_max = (c.measured or {}).get("latency_max", cj.get("latency_cycles", {}).get("max", cyc))
        period = (c.measured or {}).get("solve_period")
        per_pass = period / (kp * (cj["iterations"] + 1)) if kp > 1 and period else None
        paper_cyc = cj["iterations"] * eq23(n, P, cj["lat_add"], cj["lat_mul"])
        t3 = PAPER_TABLE3.get(P) if (n, cj["iterations"]) == (40, 15) else None
        lat = _core_latency(c, cyc)
        r = {
            "problem": c.problem, "role": c.role, "P": P, "b": c.b, "n": n, "nw": cj["nw"], "nx": cj["nx"],
            "imax": cj["iterations"],
            "lat_add": cj["lat_add"], "lat_mul": cj["lat_mul"],
            "cycles_per_iteration_measured": cpi, "cycles_per_iteration_corejson": cj["cycles_per_iteration"],
            "cycles_eq23": cj["cycles_eq23"],
            "cycles_per_solve_measured": cps, "cycles_per_solve_corejson": cj["cycles_per_solve"],
            "solve_overhead_corejson": cj["solve_overhead_cycles"],
            "cycles_per_solve_paper": paper_cyc,
            "multipliers": cj["multipliers"], "multipliers_table1": paper_multipliers(n, P),
            "multipliers_table3": t3[0] if t3 else None,
        }
        _tool_columns(c, r)
        lat_max = _core_latency(c, cyc_max)
        # solves per second of the device: every copy of the core at the placed clock
        rate = c.copies * kp / period * c.pnr["fmax_mhz"] * 1e6 if kp > 1 and period and c.pnr else None
        r.update({
            "problems": kp, "copies": c.copies, "cycles_per_solve_max": cyc_max, "solve_period_measured": period,
            "latency_us_ecp5": lat, "latency_us_ecp5_max": lat_max,
            "latency_us_v6_ours": latency_us(cyc, F_V6_MHZ), "latency_us_v6_paper": t3[1] if t3 else None,
            "latency_us_s6_ours": latency_us(cyc, F_S6_MHZ), "latency_us_s6_paper": t3[2] if t3 else None,
            "mac_utilisation": mac_utilisation(n, cj["multipliers"], per_pass or cpi or cj["cycles_per_iteration"]),
        })
        for name, key in SW_KEYS:
            r[f"{key}_us"] = med.get(name)
            r[f"{key}_over_core"] = ratio(med.get(name), lat)
        r.update(core_ratios(lat_max, sw, rate))
        r["fit_85f"] = fit_85f(c.ecp5)
        r["early_exit"] = bool(cj.get("early_exit"))
        if c.tag in loops:
            loop_columns(r, c, loops[c.tag], sw)
        out.append(r)
    return out


def exit_table(recs: list[dict], sw: dict | None) -> list[str]:
    """The cores with the exit test over the software loop, against DAQP's own timer."""
    recs = [r for r in recs if "loop_us_median" in r]
    if not recs:
        return []
    daqp = next((s for s in (sw or {}).get("solvers", []) if s.name.startswith("DAQP")), None)
    k = slug(daqp.name) if daqp else None
    body = []
    for r in recs:
        qs = ("median", "p99", "max")
        body.append([str(r["P"]), str(r["b"]), _f(r["fmax_mhz"], "{:.1f}"), f"{r['exit_tol']:.3g}",
                     " / ".join(f"{r[f'loop_iter_{q}']:g}" for q in qs),
                     _f(100 * r["loop_exit_share"] if r.get("loop_exit_share") is not None else None, "{:.0f} %"),
                     " / ".join(_f(r[f"loop_us_{q}"], "{:.2f}") for q in qs),
                     " / ".join(_f(r.get(f"{k}_own_{q}_us") if k else None, "{:.2f}") for q in qs),
                     " / ".join(_f(r.get(f"{k}_own_{q}_over_core") if k else None, "{:.1f}x") for q in qs)])
    return ["", "### The exit test over the software loop", ""] + _table(
        ["P", "b", "Fmax MHz", "EXIT_TOL", "iterations median / p99 / max", "solves ended by the test",
         "core us median / p99 / max",
         "DAQP own us median / p99 / max", "DAQP own / core"], body) + [
        "", f"The same {recs[0]['loop_solves']} QPs as the software timing, in the loop's order: the core's golden "
        "model, warm-started step after step, ends each solve at the exit test (docs/fgm.md) or at Imax; core us: "
        "overhead + I L_F cycles (core.json's contract) at the placed Fmax. DAQP own: its solve timer (C level), "
        "hot-started on the same QPs. Above 1x the core is ahead.", ""]


def fgm_summary_table(recs: list[dict]) -> list[str]:
    hdr = ["P", "b", "L_F meas (eq. 23)", "cycles/solve", "mult. ours (Table I)", "MULT18X18D / DSP48E1",
           "LUT4 / LUT", "FF ECP5 / xc7", "Fmax ECP5 MHz", "latency us ECP5", "V6 us ours (paper)",
           "S6 us ours (paper)", "OSQP def. / core", "OSQP tuned / core", "numpy / core",
           "fastest solver / core (median, p99)", "MAC use"]
    body = []
    for r in recs:
        body.append([
            str(r["P"]), str(r["b"]),
            f"{_f(r['cycles_per_iteration_measured'], '{}')} ({r['cycles_eq23']})",
            _f(r["cycles_per_solve_measured"], "{}"),
            *_resource_cells(r),
            _f(r["fmax_mhz"], "{:.1f}", "no fit" if r["pnr_note"].startswith("does not fit") else "-"),
            _f(r["latency_us_ecp5"], "{:.2f}"),
            f"{_f(r['latency_us_v6_ours'])} ({_f(r['latency_us_v6_paper'])})",
            f"{_f(r['latency_us_s6_ours'])} ({_f(r['latency_us_s6_paper'])})",
            _x(r["osqp_default_over_core"]), _x(r["osqp_tuned_over_core"]), _x(r["numpy_fgm_over_core"]),
            fastest_cell(r), _f(100 * r["mac_utilisation"], "{:.0f} %"),
        ])
    return _table(hdr, body)


# kept for callers of the FGM-only bench
summary_table = fgm_summary_table


def fgm_section(cores: list[Core], recs: list[dict], sw: dict | None) -> list[str]:
    fast = [(c, r) for c, r in zip(cores, recs) if c.role == "fmax"]
    cores = [c for c in cores if c.role == "sweep"]
    recs = [r for r in recs if r["role"] == "sweep"]
    L = ["## FGM core: masses", "", "### Cycles (Verilator)", ""]
    body = [[str(r["P"]), str(r["b"]), _f(r["cycles_per_iteration_measured"], "{}"),
             str(r["cycles_per_iteration_corejson"]), str(r["cycles_eq23"]), _f(r["cycles_per_solve_measured"], "{}"),
             str(r["cycles_per_solve_corejson"]), str(r["solve_overhead_corejson"]), str(r["cycles_per_solve_paper"])]
            for r in recs]
    L += _table(["P", "b", "L_F measured", "L_F core.json", "eq. (23)", "cycles/solve measured", "core.json",
                 "overhead (core.json)", "Imax x eq. (23) (Table III)"], body)
    L += ["", "Cycles per solve run from the handshake of the last input word to the first output word; Table III "
          "of 002 counts Imax L_F only, so ours are higher by the overhead of the cycle contract in core.json (the "
          "Phi_n w pass and the I/O handshake).", "", "### Resources (Yosys)", ""]
    body = [[str(r["P"]), str(r["b"]), str(r["multipliers"]), str(r["multipliers_table1"]),
             _f(r.get("ecp5_MULT18X18D"), "{}"), _f(r.get("ecp5_LUT4"), "{}"), _f(r.get("ecp5_CCU2C"), "{}"),
             _f(r.get("ecp5_FF"), "{}"), _f(r.get("ecp5_DP16KD"), "{}"), _f(r.get("ecp5_LUTRAM"), "{}"),
             _f(r.get("xc7_DSP48E1"), "{}"), _f(r.get("xc7_LUT"), "{}"), _f(r.get("xc7_FF"), "{}"),
             _f(r.get("xc7_RAMB"), "{:g}"), _f(r.get("xc7_LUTRAM"), "{}"),
             "{} x {}".format(*paper_memory_blocks(r["n"], r["nx"], r["P"]))] for r in recs]
    L += _table(["P", "b", "mult. ours", "Table I", "MULT18X18D", "LUT4", "CCU2C", "FF", "DP16KD",
                 "DPR16X4", "DSP48E1", "LUT", "FF", "RAMB36", "LUTRAM/SRL", "Table I memories x words"], body)
    L += ["", "ECP5: `synth_ecp5` (CCU2C carry cells hold two LUT4 each; DPR16X4 is distributed RAM). xc7: "
          "`synth_xilinx -family xc7 -flatten` (RAMB in 36 Kb blocks, a RAMB18E1 counts half). Yosys gives no "
          "timing for the Xilinx part. Table I of 002 keeps every column of the matrices in its own memory of "
          "ceil(n/P) words; this core keeps per row unit one RAM of 2 ceil(n/P) rows of max(n, nw) coefficients "
          "and one of ceil(n/P) bound pairs, which Yosys splits into as many blocks as the width needs, or "
          "puts in distributed RAM when they are shallow.", "", "Memories as Yosys inferred them (memory_libmap):", ""]
    L += _memories(cores)
    L += ["", "### Fmax and critical path (nextpnr-ecp5, LFE5U-85F, CABGA381, speed 8)", ""]
    L += _fmax_section(cores, recs, "fgm_core.lpf")
    if fast:
        lat = FMAX_LAT
        L += ["", f"Pipelined for Fmax: TARGET={lat['target']}, b = {FMAX_B}, l_A = {lat['lat_add']}, "
              f"l_M = {lat['lat_mul']} (operands registered in fabric, then the MULT18X18D's input, pipeline and "
              "output registers; docs/dsp.md), the rest as above:", ""]
        L += _fmax_section(*map(list, zip(*fast)), "fgm_core.lpf")
    if fast:
        L += interleave_table([r for _, r in fast], sw)
        L += exit_table([r for _, r in fast], sw)
    L += ["", "### Latency against Table III(a) of 002", ""]
    body = [[str(r["P"]), str(r["b"]), _f(r["cycles_per_solve_measured"], "{}"), _f(r["fmax_mhz"], "{:.1f}"),
             _f(r["latency_us_ecp5"], "{:.3f}"), _f(r["latency_us_v6_ours"], "{:.3f}"),
             _f(r["latency_us_v6_paper"]), _f(r["latency_us_s6_ours"], "{:.3f}"), _f(r["latency_us_s6_paper"])]
            for r in recs]
    L += _table(["P", "b", "cycles/solve", "Fmax ECP5", "us ECP5", "us at 400 MHz", "Table III V6",
                 "us at 230 MHz", "Table III S6"], body)
    if sw:
        lo, hi = sw["u_box"]
        L += ["", "### Software on this CPU", "",
              f"One closed loop of masses ({sw['steps']} steps, references changing every {sw['hold']} steps, "
              f"x0 = 0, driven by the float FGM), replayed {sw['repeats']} time(s) into each solver: the same QPs "
              "for all, each started as said below (OSQP and numpy from their own previous solution). Median: the "
              "smallest of the replays' median times per solve (other processes only add time); p90 and max over "
              "all solves. "
              "Wall time per solve with time.perf_counter, including q = Phi w and the Python call; half the "
              "replays before the synthesis jobs start and half after they end" + _load_text(sw)
              + f". Error: max and median over the loop of |u0 - u0*|, u0* from OSQP at eps 1e-9 (inputs in "
              f"[{lo:g}, {hi:g}]).",
              ""]
        L += _software_solvers(sw)
        L += ["", "Core (bit-exact golden model, same QPs): " + ", ".join(
            f"b = {b}: error max {e[0]:.2e}, median {e[1]:.2e}" for b, e in sorted(sw["core_err"].items())) + ".", ""]
        body = [[str(r["P"]), str(r["b"]), _f(r["latency_us_ecp5"], "{:.3f}"),
                 _f(r["osqp_default_over_core"], "{:.0f}x"), _f(r["osqp_tuned_over_core"], "{:.0f}x"),
                 _f(r["numpy_fgm_over_core"], "{:.0f}x"),
                 _f(ratio(r["osqp_tuned_us"], r["latency_us_v6_ours"]), "{:.0f}x"),
                 _f(ratio(r["numpy_fgm_us"], r["latency_us_v6_ours"]), "{:.0f}x")] for r in recs]
        L += _table(["P", "b", "core us (ECP5)", "OSQP default / core", "OSQP tuned / core", "numpy FGM / core",
                     "OSQP tuned / core at 400 MHz", "numpy / core at 400 MHz"], body)
        L += solver_section(
            recs, sw, "ECP5",
            "The QP of every step (problem A): min 1/2 z'H z + (Phi w)'z over the input box, n = "
            f"{recs[0]['n'] if recs else '-'} variables, H dense. DAQP, PIQP and ProxQP get the box as variable "
            "bounds, OSQP as n identity rows, Clarabel and quadprog as 2n inequality rows. DAQP is hot-started: its "
            "workspace keeps the previous solve's working set (the active bounds and their factors) and starts "
            "from it; ProxQP and OSQP start from the previous solution; PIQP and Clarabel (interior point) start "
            "cold; quadprog keeps nothing between calls but gets R^-1 (H = R'R) once.",
            "Core us: cycles per solve / Fmax on the ECP5; core solves/s: 1 / that latency (one QP in flight; the "
            "next input frame is buffered during the solve, the nu output beats after it are not counted).")
    L += ["", "### MAC utilisation", ""]
    body = [[str(r["P"]), str(r["b"]), str(useful_macs(r["n"])), str(r["multipliers"]),
             _f(r["cycles_per_iteration_measured"], "{}"),
             str(r["multipliers"] * (r["cycles_per_iteration_measured"] or r["cycles_per_iteration_corejson"])),
             f"{100 * r['mac_utilisation']:.1f} %"] for r in recs]
    L += _table(["P", "b", "useful MACs/iteration", "multipliers", "L_F", "multiplier-cycles", "utilisation"], body)
    L += ["", "Useful: n^2 for (I - H_n) y and 2n for y = (1 + beta) z - beta z_prev. The idle share is the "
          "pipeline fill of each iteration (l_A ceil(log2 n) + 2 l_M + 3 l_A + 1 cycles of eq. (23)), the "
          "multipliers of the last row block when P does not divide n, and the nw-wide part of the tree unused "
          "when nw < n (none here).", ""]
    return L


def interleave_table(recs: list[dict], sw: dict | None) -> list[str]:
    """The Fmax cores' latency range, throughput and MAC use (K_p problems interleaved), against DAQP when run."""
    daqp = next((s for s in (sw or {}).get("solvers", []) if s.name.startswith("DAQP")), None)
    body = []
    for r in recs:
        k = slug(daqp.name) if daqp else None
        body.append([str(r["P"]), str(r["problems"]), str(r["copies"]), _f(r["fmax_mhz"], "{:.1f}"),
                     f"{r['cycles_per_solve_measured'] or r['cycles_per_solve_corejson']}"
                     + (f" to {r['cycles_per_solve_max']}" if r["problems"] > 1 else ""),
                     _f(r["latency_us_ecp5_max"], "{:.2f}"), _f(r["solve_period_measured"], "{}"),
                     _f(r.get("core_solves_per_s"), "{:.0f}"), f"{100 * r['mac_utilisation']:.1f} %",
                     _f(r.get(f"{k}_p99_over_core") if k else None, "{:.1f}x"),
                     _f(r.get(f"{k}_throughput_ratio") if k else None, "{:.2f}x")])
    L = ["", "### Interleaved problems (K_p, Verilator and nextpnr)", ""]
    L += _table(["P", "K_p", "cores", "Fmax MHz", "latency cycles", "worst latency us", "solve period (meas.)",
                 "solves/s", "MAC use", "DAQP p99 / worst latency", "solves/s / DAQP's at its median"], body)
    L += ["", "K_p problems share the row units, a pass of one problem per turn (docs/fgm.md). Latency: from the "
          "last input word to the first output word, measured in Verilator; with K_p > 1 up to R - 1 cycles more "
          "wait for the problem's turn (the worst case is what the DAQP column uses). Solve period: cycles between "
          "two answers of one problem with frames always waiting, measured; solves/s: cores x K_p / period x Fmax "
          "(one problem: 1 / latency), where cores independent copies of the core are placed and routed together on "
          "the one LFE5U-85F (each with its own ports; a user's interconnect spreads the frames). MAC use: "
          "(n^2 + 2n) per iteration over multipliers x the cycles of one pass, period / (K_p (Imax + 1)) when "
          "interleaving.", ""]
    return L


# ----------------------------------------------------------------------------------------- the section

class Section(QpSection):
    name, label, eq = "fgm", "FGM", 23
    plot_files = ("fgm_latency_vs_P.png", "fgm_resources_vs_P.png")

    @staticmethod
    def add_arguments(ap) -> None:
        ap.add_argument("--P", default=None, help="FGM: comma-separated P values (default 1,2,4,8; QUICK 1)")
        ap.add_argument("--b", default=None, help="FGM: comma-separated frac_bits (default 12,16; QUICK 16)")
        ap.add_argument("--fgm-fmax", default=None, help="FGM masses pipelined for Fmax (TARGET=ecp5, b = 15, "
                                                         "l_A = 1, l_M = 5): P, P x K_p or P x K_p x copies items "
                                                         "(default 1,1x2,3; QUICK 1)")
        ap.add_argument("--steps", type=int, default=None, help="closed-loop steps for the FGM software timing")

    def configure(self, a) -> None:
        super().configure(a)
        self.Ps = ints(a.P, QUICK_P if a.quick else FULL_P)
        self.fmax = fmax_cores(a.fgm_fmax, FMAX_QUICK if a.quick else FMAX_FULL)
        self.bs = ints(a.b, QUICK_B if a.quick else FULL_B)
        self.steps = a.steps or (200 if a.quick else 600)
        self.run.info.update(Ps=self.Ps, bs=self.bs, fgm_fmax=self.fmax)

    def log_text(self) -> str:
        return f"FGM P = {self.Ps}, b = {self.bs}"

    def plan(self) -> None:
        from mpc_cores.fgm.design import DesignError, design_fgm
        from mpc_cores.problem import load_spec

        out, designs = self.run.out, self.design_dir
        self.problem = problem = load_spec(MASSES)
        spec = MASSES.read_bytes()
        for b in self.bs:
            for P in self.Ps:
                try:
                    d = cached_design(designs, f"fgm_masses_p{P}_b{b}", ("fgm", spec, P, b),
                                      lambda P=P, b=b: design_fgm(problem, P=P, frac_bits=b))
                except DesignError as e:
                    self.error(f"FGM P={P} b={b}: design refused: {e}")
                    continue
                self.designs[b] = d
                self.cores.append(Core("fgm", "masses", P, b, out / "cores" / f"masses_p{P}_b{b}", d, d.iterations))
        la, lm, tg = FMAX_LAT["lat_add"], FMAX_LAT["lat_mul"], FMAX_LAT["target"]
        for P, kp, copies in self.fmax:
            tag = f"masses_p{P}_b{FMAX_B}_la{la}_lm{lm}_{tg}" + (f"_k{kp}" if kp > 1 else "_exit") \
                + (f"_x{copies}" if copies > 1 else "")
            ex = dict(early_exit=True, exit_tol=FMAX_EXIT_TOL) if kp == 1 else {}
            try:
                d = cached_design(designs, f"fgm_{tag}", ("fgm", spec, P, FMAX_B, la, lm, tg, kp, tuple(ex.items())),
                                  lambda P=P, kp=kp, ex=ex: design_fgm(problem, P=P, frac_bits=FMAX_B, problems=kp,
                                                                       **FMAX_LAT, **ex))
            except DesignError as e:
                self.error(f"FGM P={P} l_A={la} l_M={lm} K_p={kp}: design refused: {e}")
                continue
            self.cores.append(Core("fgm", "masses", P, FMAX_B, out / "cores" / tag, d, d.iterations, role="fmax",
                                   pnr_seeds=FMAX_SEEDS_QUICK if self.quick else FMAX_SEEDS, copies=copies,
                                   pnr_args=PLACER_ARGS, floorplan=copies == 1))

    def software_case(self):
        return prepare_fgm_software(self.problem, self.designs, self.steps, LOOP_HOLD)

    def exit_loops(self) -> dict:
        """tag -> iterations per step of each core with the exit test over the software loop's QPs (the same
        closed_loop_qps as software_case), its golden model warm-started step after step"""
        from mpc_cores.fgm.model import FgmFixed
        from mpc_cores.fixed import quantize
        from mpc_cores.problem import condense

        exits = [c for c in self.cores if getattr(c.design, "early_exit", False)]
        if not exits:
            return {}
        ref = self.designs[max(self.designs)] if self.designs else exits[0].design
        W = closed_loop_qps(self.problem, condense(self.problem), ref, self.steps, LOOP_HOLD)
        out = {}
        for c in exits:
            m = FgmFixed(c.design)
            out[c.tag] = [m.solve(quantize(w, c.design.b)).iterations for w in W]
        return out

    def job_costs(self, c: Core) -> tuple[float, float, float]:
        # rough seconds seen on a 2-core EPYC; place and route dominates
        return (30, (60 + 15 * c.P + (350 * c.P if c.placeable else 0)) * c.copies, 40 * c.P)

    def make_rows(self) -> list[dict]:
        return fgm_rows(self.cores, self.sw, self.exit_loops())

    # ------------------------------------------------------------------------------------- outputs

    def sweep(self) -> list[dict]:
        return [r for r in self.rows if r["role"] == "sweep"]

    def run_text(self, info: dict) -> str | None:
        if not self.cores:
            return None
        return f"FGM P = {', '.join(map(str, info['Ps']))}, b = {', '.join(map(str, info['bs']))}"

    def summary_md(self) -> list[str]:
        fgm = self.sweep()
        if not fgm:
            return []
        r0 = fgm[0]
        return [f"### FGM core, {r0['problem']} (n = {r0['n']}, nw = {r0['nw']}, Imax = {r0['imax']}, truncation)", "",
                *fgm_summary_table(fgm), "",
                "L_F meas: cycles per iteration measured in Verilator (eq. (23) of 002 in brackets). mult. ours: "
                "`multipliers` of core.json, P (max(n, nw) + 2); Table I of 002: P (N n_u + 2). latency: measured "
                "cycles per solve / Fmax. V6/S6: our measured cycles at 400/230 MHz, Table III(a) of 002 in "
                "brackets. x / core: median software time per solve on this CPU (the solver's own timer where it "
                "has one) over the core's latency on the ECP5; fastest solver: the software solver with the lowest "
                "median, its median and p99 over the core's latency (all solvers: FGM section, Software on this "
                "CPU). MAC use: (n^2 + 2n) / (multipliers x L_F).",
                ""]

    def fmax_rows(self) -> list[dict]:
        return [r for r in self.rows if r["role"] == "fmax"]

    def fmax_note(self) -> str:
        return f"FGM: l_M = {FMAX_LAT['lat_mul']}, TARGET={FMAX_LAT['target']}"

    def section_md(self) -> list[str]:
        return fgm_section(self.cores, self.rows, self.sw) if self.rows else []

    def console_summary(self) -> list[str]:
        fgm = self.sweep()
        return ["FGM, masses", *fgm_summary_table(fgm)] if fgm else []

    def plots(self, plt, out: Path) -> list[Path]:
        fgm = self.sweep()
        if not fgm:
            return []
        r0 = fgm[0]
        paths = [out / "fgm_latency_vs_P.png", out / "fgm_resources_vs_P.png"]
        latency_plot(plt, paths[0], fgm, self.sw, PAPER_TABLE3, "III(a)", -1,
                     f"FGM core, {r0['problem']} (n = {r0['n']}, Imax = {r0['imax']}): latency vs P")
        resources_plot(plt, paths[1], fgm, "P (N n_u + 2)", f"FGM core, {r0['problem']}: resources vs P (Yosys)")
        return paths

    def plot_fmax(self, ax):
        if not self.rows:
            return None
        fgm, fast = self.sweep(), self.fmax_rows()
        for recs, mk in ((fgm, "o-"), (fast, "o--")):
            for b in sorted({r["b"] for r in recs}):
                pts = by_b(recs, b, "fmax_mhz")
                if pts:
                    ax.plot(*zip(*pts), mk, label=f"FGM masses, b = {b}, l_A = {recs[0]['lat_add']}, "
                                                  f"l_M = {recs[0]['lat_mul']}")
        for P in sorted({r["P"] for r in fgm}):
            missing = [r for r in fgm if r["P"] == P and r["fmax_mhz"] is None]
            if missing:
                note = missing[0]["pnr_note"]
                why = ("FGM does not fit\n" + note.split(": ", 1)[1].split(";")[0].replace(" needed,", "\n>")
                       if note.startswith("does not fit") else "no result")
                ax.annotate(why, (P, 15), fontsize=7, ha="center", color="gray")
        return [r["P"] for r in fgm + fast], [r["fmax_target_mhz"] for r in fgm], REFERENCE_CLOCKS
