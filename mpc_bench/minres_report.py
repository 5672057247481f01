"""Formulas, records and report lines of the MINRES section of the benchmark (mpc_bench.minres): the cycle and
operator counts of 001 (eq. (15), (17), Table I), the floating-point operators of the generated SystemVerilog, one
record per core (minres.csv), the README summary table and the "## MINRES core" part of report.md."""
from __future__ import annotations

import math
import re

import numpy as np

from mpc_bench.baselines_minres import SOLVERS, WEIGHTS, median_us
from mpc_bench.parsers import lpf_frequency
from mpc_bench.report import _f, _table, _tool_columns, latency_us, pnr_cells, ratio
from mpc_bench.tools import CONSTRAINTS, seeds_phrase

# 001 section VIII-C: "a clock frequency above 150MHz is achievable" (Virtex-6, post place and route).
F_001_MHZ = 150.0
# eq. (15) of 001 with the constants of its implementation
K1_001, K2_001 = 24, 154
# Table I of 001: floating-point units of the linear solver: 4M - 3 in the dot-product block, 27 others.
OTHER_001 = 27


# ----------------------------------------------------------------------------------------- arithmetic

def eq15_001(N: int, M: int) -> int:
    """P of eq. (15) of 001 with the constants of its implementation (k1 = 24, k2 = 154)."""
    depth = math.ceil(math.log2(2 * M - 1)) if M > 1 else 0
    return -(-(3 * N + K1_001 * depth + K2_001) // N)


def cycles_001(N: int, P: int, imax: int) -> int:
    """Cycles of one linear solve of P problems in 001, (P N + P) Imax (eq. (17))."""
    return (P * N + P) * imax


def batch_cycles(overhead: int, imax: int, cycles_per_iteration: int) -> int:
    """Cycles of a batch at Imax iterations: the cycle contract of core.json, overhead + Imax x per iteration
    (the overhead is batch_cycles_imax0: the init pass, the pipeline drain and the output)."""
    return overhead + imax * cycles_per_iteration


def measured_overhead(batch: dict, cycles_per_iteration: int) -> int:
    """Batch cycles at Imax = 0 from batches measured at several Imax ({imax: cycles}); they must agree."""
    vals = {int(cyc) - int(imax) * cycles_per_iteration for imax, cyc in batch.items()}
    if len(vals) != 1:
        raise ValueError(f"batch cycles {batch} are not affine in Imax with {cycles_per_iteration} per iteration")
    return vals.pop()


def useful_flops(nnz: int, N: int) -> int:
    """Floating-point operations one MINRES iteration of one problem needs (the iteration of
    mpc_cores/minres/model.py, x_0 = 0): the matrix-vector product on the nonzeros of the KKT matrix (nnz multiplies,
    nnz - N adds), delta = v'y and ||u||^2 (2N - 1 each), u = (y - delta v) - gamma v_{j-1} (4N), v_{j+1} = u /
    gamma (N), w_{j+1} = ((v - a3 w_{j-1}) - a2 w_j) / a1 (5N), x += c eta w_{j+1} (2N), and 17 scalar
    operations (sqrt, Givens rotation, coefficients): 2 nnz + 15 N + 15."""
    return 2 * nnz + 15 * N + 15


def band_flops(N: int, K: int) -> int:
    """What the core issues for the same iteration: the K slot products and K - 1 tree adds of every row (unused
    slots and the band's corners outside the matrix included), and the same vector and scalar updates."""
    return N * (2 * K - 1) + 16 * N + 15


def utilisation(flops: int, operators: int, slot_cycles: int) -> float:
    """Useful flops of one problem's iteration over the operator-cycles of its slot: P problems share P slots of
    S cycles each, so this is P flops / (operators x P S)."""
    return flops / (operators * slot_cycles)


_MODULE = re.compile(r"^module\s+(\w+)\s*[(#]", re.MULTILINE)
_INSTANCE = re.compile(r"^\s*(\w+)\s+(?:#\s*\(.*?\)\s*)?(\w+)\s*\(", re.MULTILINE)
FLOAT_KINDS = ("FMul", "FAdd", "FDiv", "FSqrt")


def float_units(sv: str, top: str) -> dict[str, int]:
    """Floating-point operators instantiated under `top` in Chisel-emitted SystemVerilog, by kind (FMul, FAdd,
    FDiv, FSqrt; a module counts as its kind when its name holds `_<kind>_`), counted through the hierarchy."""
    bodies: dict[str, str] = {}
    starts = [(m.group(1), m.start()) for m in _MODULE.finditer(sv)]
    for k, (name, s) in enumerate(starts):
        end = starts[k + 1][1] if k + 1 < len(starts) else len(sv)
        bodies[name] = sv[s:end]
    if top not in bodies:
        raise ValueError(f"module {top} not in the SystemVerilog")

    def kind(name: str) -> str | None:
        return next((k for k in FLOAT_KINDS if f"_{k}_" in f"_{name}_" or name.startswith(f"{k}_")), None)

    memo: dict[str, dict[str, int]] = {}

    def count(name: str, stack: tuple = ()) -> dict[str, int]:
        if name in memo:
            return memo[name]
        if name in stack:
            raise ValueError(f"recursive instantiation of {name}")
        k = kind(name)
        if k:
            memo[name] = {k: 1}
            return memo[name]
        tot: dict[str, int] = {}
        body = bodies[name].split("\n", 1)[1] if "\n" in bodies[name] else ""
        for m in _INSTANCE.finditer(body):
            child = m.group(1)
            if child in bodies:
                for kk, v in count(child, stack + (name,)).items():
                    tot[kk] = tot.get(kk, 0) + v
        memo[name] = tot
        return tot

    got = count(top)
    return {k: got.get(k, 0) for k in FLOAT_KINDS}


# ----------------------------------------------------------------------------------------- records

def fmax_estimate(cores: list) -> tuple[float | None, str]:
    """The lowest nextpnr Fmax among the placed cores, and which core it is (the clock the unplaced cores are
    quoted at)."""
    got = [(c.pnr["fmax_mhz"], c.tag) for c in cores if c.pnr]
    return min(got) if got else (None, "")


def _sw_columns(r: dict, sw: dict | None, lat_batch: float | None, P: int) -> None:
    """Software medians and their ratios to the core's latency (at its Fmax or the estimate; and at 150 MHz)."""
    for key, _ in SOLVERS:
        us = median_us(sw[key]["times_us"]) if sw and key in sw else None
        r[f"{key}_us"] = us
        r[f"{key}_us_per_iteration"] = us / r["imax"] if us is not None else None
        r[f"{key}_over_core_batch"] = ratio(us, lat_batch)
        r[f"{key}_over_core_per_problem"] = ratio(us, lat_batch / P if lat_batch else None)
        r[f"{key}_over_core_batch_150"] = ratio(us, r["latency_batch_us_150"])
        r[f"{key}_over_core_per_problem_150"] = ratio(us, r["latency_per_problem_us_150"])


def minres_rows(cores: list, sw: dict | None, nnz: dict) -> list[dict]:
    """One flat record per core: the CSV rows and the source of every MINRES table. `nnz`: problem -> nonzeros of
    its KKT matrix (with the interior-point weights)."""
    est, _ = fmax_estimate(cores)
    out = []
    for c in cores:
        cj, m = c.core, c.measured
        N, M, P, imax = cj["N"], cj["M"], cj["P"], c.design.iterations
        cpi = m["cycles_per_iteration"] if m else None
        over = measured_overhead(m["batch_cycles"], cpi) if m else None
        bc_meas = batch_cycles(over, imax, cpi) if m else None
        bc_cj = batch_cycles(cj["batch_cycles_imax0"], imax, cj["cycles_per_iteration"])
        cyc = bc_meas if bc_meas is not None else bc_cj
        p001 = eq15_001(N, M)
        ops = sum(c.units.values()) if c.units else None
        r = {
            "problem": c.problem, "role": c.role, "P": P, "n": cj["n"], "m": cj["m"], "T": cj["T"], "N": N, "M": M,
            "imax": imax, "lat_add": cj["lat_add"], "lat_mul": cj["lat_mul"], "lat_div": cj["lat_div"],
            "lat_sqrt": cj["lat_sqrt"], "P_eq15": cj["P_eq15"], "P_eq15_001": p001, "slot_cycles": cj["slot_cycles"],
            "cycles_per_iteration_measured": cpi, "cycles_per_iteration_corejson": cj["cycles_per_iteration"],
            "cycles_PN_plus_P": P * N + P,
            "batch_overhead_measured": over, "batch_overhead_corejson": cj["batch_cycles_imax0"],
            "batch_cycles_measured": bc_meas, "batch_cycles_corejson": bc_cj,
            "cycles_001_same_P": cycles_001(N, P, imax), "cycles_001_eq15": cycles_001(N, p001, imax),
            "fmul": c.units.get("FMul"), "fadd": c.units.get("FAdd"), "fdiv": c.units.get("FDiv"),
            "fsqrt": c.units.get("FSqrt"), "fp_units": ops, "fp_units_001": 4 * M + 24,
            "multipliers_corejson": cj["multipliers"],
            "storage_words": cj["storage_words"], "storage_bound_001": cj["storage_bound_001"],
            "storage_dense_cds": cj["storage_dense_cds"],
        }
        _tool_columns(c, r)
        f = c.pnr["fmax_mhz"] if c.pnr else None
        lat = latency_us(cyc, f)
        lat_est = latency_us(cyc, est) if f is None else None
        lat_b = lat if lat is not None else lat_est
        flops = useful_flops(nnz[c.problem], N) if c.problem in nnz else None
        r.update({
            "fmax_est_mhz": est if f is None else None,
            "latency_batch_us": lat, "latency_per_problem_us": lat / P if lat else None,
            "latency_batch_us_est": lat_est, "latency_per_problem_us_est": lat_est / P if lat_est else None,
            "latency_batch_us_150": latency_us(cyc, F_001_MHZ),
            "latency_per_problem_us_150": latency_us(cyc, F_001_MHZ) / P,
            "latency_001_us_150": latency_us(cycles_001(N, p001, imax), F_001_MHZ),
            "latency_001_per_problem_us_150": latency_us(cycles_001(N, p001, imax), F_001_MHZ) / p001,
            "nnz": nnz.get(c.problem), "useful_flops": flops, "band_flops": band_flops(N, cj["K"]), "K": cj["K"],
            "utilisation": utilisation(flops, ops, cj["slot_cycles"]) if flops and ops else None,
            "utilisation_band": utilisation(band_flops(N, cj["K"]), ops, cj["slot_cycles"]) if ops else None,
        })
        _sw_columns(r, (sw or {}).get(c.problem, {}).get("solvers"), lat_b, P)
        out.append(r)
    return out


# ----------------------------------------------------------------------------------------- report

def _n(v) -> str:
    return _f(v, "{}")


def _fit_text(r: dict) -> str:
    if r.get("fmax_mhz") is not None:
        return f"{r['fmax_mhz']:.1f}"
    note = r.get("pnr_note") or ""
    if note.startswith("does not fit"):
        return "no fit"
    return "-"


def summary_table(recs: list[dict]) -> list[str]:
    """Compact table for the README: one row per core of the sweep."""
    hdr = ["P", "cycles/iter meas. (P N + P)", "batch cycles (Imax)", "FP operators (001)", "MULT18X18D / DSP48E1",
           "LUT4 / LUT", "FF ECP5 / xc7", "Fmax MHz", "us per batch", "us per problem", "scipy / core",
           "numpy / core", "utilisation"]
    body = []
    for r in recs:
        est = r["fmax_mhz"] is None and r.get("latency_batch_us_est") is not None
        at150 = r["fmax_mhz"] is None and not est
        star = " (est.)" if est else " (150 MHz)" if at150 else ""
        sfx = "_150" if at150 else ""
        body.append([
            str(r["P"]), f"{_n(r['cycles_per_iteration_measured'])} ({r['cycles_PN_plus_P']})",
            f"{_n(r['batch_cycles_measured'])} ({r['imax']})", f"{_n(r['fp_units'])} ({r['fp_units_001']})",
            f"{_n(r.get('ecp5_MULT18X18D'))} / {_n(r.get('xc7_DSP48E1'))}",
            f"{_n(r.get('ecp5_LUT4'))} / {_n(r.get('xc7_LUT'))}", f"{_n(r.get('ecp5_FF'))} / {_n(r.get('xc7_FF'))}",
            _fit_text(r) if not est else f"{_fit_text(r)}, est. {r['fmax_est_mhz']:.1f}",
            _f(r["latency_batch_us"] or r.get("latency_batch_us_est") or r["latency_batch_us_150"], "{:.0f}") + star,
            _f(r["latency_per_problem_us"] or r.get("latency_per_problem_us_est") or r["latency_per_problem_us_150"],
               "{:.0f}") + star,
            _f(r[f"scipy_over_core_per_problem{sfx}"], "{:.1f}x"), _f(r[f"numpy_over_core_per_problem{sfx}"], "{:.1f}x"),
            _f(100 * r["utilisation"] if r["utilisation"] is not None else None, "{:.0f} %"),
        ])
    return _table(hdr, body)


def mem_list(mems: dict[str, str]) -> str:
    """'vmem -> FF, wmem -> TRELLIS_DPR16X4, ...' from yosys memory_libmap results ('Top.vmem_ext.Memory' ->
    'vmem'); memories yosys made from case statements (the ROM columns, '$auto$proc_rom...') counted per kind."""
    named, unnamed = [], {}
    for k, v in sorted(mems.items()):
        parts = k.split(".")
        name = parts[-2] if len(parts) > 2 and parts[-1] in ("Memory", "mem") else parts[-1]
        name = name.removesuffix("_ext")
        if "$" in name:
            unnamed[v] = unnamed.get(v, 0) + 1
        else:
            named.append(f"{name} -> {v}")
    return ", ".join(named + [f"{n} ROM/unnamed -> {v}" for v, n in sorted(unnamed.items())])


def _fmax_rows(cores: list, recs: list[dict]) -> list[str]:
    body = []
    for c, r in zip(cores, recs):
        head = [c.problem, str(r["N"]), str(r["M"]), str(c.P)]
        body.append(head + pnr_cells(c, _n(r.get("ecp5_TRELLIS_COMB_pnr")) if c.pnr else "-"))
    L = _table(["problem", "N", "M", "P", "Fmax MHz", "TRELLIS_COMB", "critical path (register to register)",
                "logic cells", "ns"], body)
    for c in cores:
        cp = (c.pnr or {}).get("critical_path")
        if cp:
            L += ["", f"{c.tag}: RTL signals on the critical path: " + ", ".join(cp["signals"])
                  + f"; longest net {cp['max_net'][1]} ({cp['max_net'][0]:.2f} ns)."]
    return L


def minres_section(cores: list, recs: list[dict], sw: dict | None, info: dict) -> list[str]:
    """The "## MINRES core" section of report.md."""
    big = [(c, r) for c, r in zip(cores, recs) if c.role == "sweep"]
    small = [(c, r) for c, r in zip(cores, recs) if c.role == "fmax"]
    br = [r for _, r in big]
    r0 = (br or recs)[0]
    L = ["## MINRES core", ""]
    L += [f"The linear solver of the interior-point method of 001 (MINRES on the banded KKT matrix in compressed "
          f"diagonal storage, binary32, P problems interleaved) for {r0['problem']} (n = {r0['n']}, m = {r0['m']}, "
          f"T = {r0['T']}: N = {r0['N']}, M = {r0['M']}), Imax = {r0['imax']} (the design's: the spec gives no "
          f"MINRES iteration count, so Imax = N), operator latencies l_A = {r0['lat_add']}, l_M = {r0['lat_mul']}, "
          f"l_div = {r0['lat_div']}, l_sqrt = {r0['lat_sqrt']}; P = " + ", ".join(str(r["P"]) for r in br)
          + f". This core's eq. (15) gives P = {r0['P_eq15']} (001's constants k1 = {K1_001}, k2 = {K2_001}: "
          f"P = {r0['P_eq15_001']}).", ""]
    if br:
        L += ["### Cycles (Verilator)", "",
              "cocotb test `cycles_per_iteration` (verif/minres/tb.py): a batch of P random problems at Imax = 3 "
              "and one at Imax = 4, every output word checked against the bit-exact model; LAST_CYCLES of each "
              "batch, their difference is the cycles per iteration (also read from CYCLES_PER_ITER). Batch cycles "
              f"at Imax = {r0['imax']} are computed: the measured overhead (batch cycles at Imax = 0) + "
              f"{r0['imax']} x cycles per iteration, as core.json's `batch_cycles_formula` defines them.", ""]
        body = [[str(r["P"]), str(r["slot_cycles"]), _n(r["cycles_per_iteration_measured"]),
                 str(r["cycles_per_iteration_corejson"]), str(r["cycles_PN_plus_P"]),
                 _n(r["batch_overhead_measured"]), str(r["batch_overhead_corejson"]),
                 _n(r["batch_cycles_measured"]), str(r["batch_cycles_corejson"]), str(r["cycles_001_same_P"]),
                 str(r["cycles_001_eq15"])] for r in br]
        L += _table(["P", "slot S", "cycles/iter measured", "core.json", "P N + P (001)", "overhead measured",
                     "core.json", f"batch cycles (Imax = {r0['imax']})", "core.json", "001: (P N + P) Imax",
                     f"001 at its P = {r0['P_eq15_001']}"], body)
        L += ["", f"With P >= {r0['P_eq15']} (this core's eq. (15)) a slot is N cycles and one iteration of P "
              "problems takes P N cycles, P fewer than 001's P N + P: the 2-norm has its own accumulator instead "
              "of a pass through the dot-product block. With a smaller P the chain from a slot's feed to its next "
              "v_(j+1) (`need` cycles) does not fit in P N, so the slots stretch to S = ceil(need / P) and an "
              "iteration takes P S > P N + P. 001 counts iterations only; our batch adds the init pass "
              "(v_1 = b / ||b||), the pipeline drain and the output stream (the overhead). The column "
              f"(P N + P) Imax at our P is 001's formula only where P is below its eq. (15) (P = {r0['P_eq15_001']}): "
              "its schedule needs that many problems in flight.", ""]
    L += ["### Floating-point operators and resources (Yosys)", ""]
    body = [[c.problem, str(r["P"]), _n(r["fmul"]), _n(r["fadd"]), _n(r["fdiv"]), _n(r["fsqrt"]), _n(r["fp_units"]),
             str(r["fp_units_001"]), _n(r.get("ecp5_MULT18X18D")), _n(r.get("ecp5_LUT4")), _n(r.get("ecp5_CCU2C")),
             _n(r.get("ecp5_FF")), _n(r.get("ecp5_DP16KD")), _n(r.get("ecp5_LUTRAM")), _n(r.get("xc7_DSP48E1")),
             _n(r.get("xc7_LUT")), _n(r.get("xc7_FF")), _f(r.get("xc7_RAMB"), "{:g}"), _n(r.get("xc7_LUTRAM"))]
            for c, r in zip(cores, recs)]
    L += _table(["problem", "P", "FMul", "FAdd", "FDiv", "FSqrt", "FP ops", "001 Table I", "MULT18X18D", "LUT4",
                 "CCU2C", "FF", "DP16KD", "DPR16X4", "DSP48E1", "LUT", "FF", "RAMB36", "LUTRAM/SRL"], body)
    L += ["", "FP operators: instances of the float library's FMul, FAdd, FDiv and FSqrt in the generated "
          "SystemVerilog (counted through the hierarchy). 001's Table I counts 4M - 3 floating-point units in the "
          "dot-product block and 27 others for its linear solver, 4M + 24; ours has K + 8 FMul, "
          "K + 9 FAdd, 3 FDiv and 1 FSqrt with the shared scalar part and reductions (K + 17, K - 1 + 8 + 2 l_A, 4 "
          "and 2 where the slots are too short for them; docs/minres.md): 2K - 1 in the dot-product block, K the "
          f"most nonzeros of a row of the band ({r0['K']} for {r0['problem']} "
          f"against 2M - 1 = {2 * r0['M'] - 1}), and {_n(r0['fp_units'] - (2 * r0['K'] - 1) if r0['fp_units'] else None)} others (the 2-norm's own "
          "accumulator, l_A partial sums per streaming accumulator, the scalar part). 001 reports no LUT, register, DSP "
          "or memory counts for a given problem (Fig. 6 plots them against n for a Virtex-6 VSX475T synthesised "
          "with XST), so there is nothing to put beside the Yosys counts. ECP5: `synth_ecp5`; xc7: `synth_xilinx "
          "-family xc7 -flatten` (RAMB in 36 Kb blocks); Yosys gives no timing for the Xilinx part. The vector "
          "memories are simple-dual-port block RAMs (one write and one registered read port each; v is kept in "
          "three copies, one per reader, and w in two banks by the parity of the iteration), so their words go to "
          "DP16KD / RAMB and FF and LUT4 hardly grow with P; the band's constant coefficients (per row key and slot) "
          "stay in logic.", "",
          "Memories as Yosys inferred them (memory_libmap):", ""]
    L += [f"- {c.tag}: ECP5 {mem_list(c.ecp5_mem) or '-'}; xc7 {mem_list(c.xc7_mem) or '-'}" for c in cores
          if c.ecp5_mem or c.xc7_mem] or ["- (none reported)"]
    L += ["", "Storage words (core.json): " + "; ".join(
        f"P = {r['P']}: {r['storage_words']} (001's bound {r['storage_bound_001']}, dense-band CDS "
        f"{r['storage_dense_cds']})" for r in br) + ".", ""]
    L += ["### Fmax and critical path (nextpnr-ecp5, LFE5U-85F, CABGA381, speed 8)", ""]
    tgt = next((r["fmax_target_mhz"] for r in recs if r.get("fmax_target_mhz")), None) \
        or lpf_frequency(CONSTRAINTS.joinpath("minres_core.lpf").read_text())
    L += [f"constraints/minres_core.lpf (`--freq {_f(tgt, '{:g}')}`, 001's clock), {seeds_phrase(cores)}, "
          "`--lpf-allow-unconstrained`: the LPF has the clock only, so the Fmax is register to register. "
          + info.get("pnr_text", ""), ""]
    L += _fmax_rows(cores, recs)
    if small:
        s0 = small[0][1]
        L += ["", f"`{s0['problem']}` is a small MINRES problem built in mpc_bench/minres.py (a double integrator, "
              f"n = {s0['n']}, m = {s0['m']}, T = {s0['T']}: N = {s0['N']}, M = {s0['M']}) with the same "
              "operators, scalar part and memories; its dot-product block has K = "
              f"{s0['K']} products where masses has {r0['K']}."]
    est = next((r["fmax_est_mhz"] for r in br if r.get("fmax_est_mhz")), None)
    L += ["", "### Latency", ""]
    if est:
        L += [f"Cores without a place and route result are quoted at {est:.1f} MHz, the lowest Fmax of the placed "
              "cores (an estimate, marked est.).", ""]
    body = [[str(r["P"]), _n(r["batch_cycles_measured"] or r["batch_cycles_corejson"]),
             _f(r["fmax_mhz"], "{:.1f}", _f(r.get("fmax_est_mhz"), "{:.1f} (est.)")),
             _f(r["latency_batch_us"] or r["latency_batch_us_est"], "{:.1f}"),
             _f(r["latency_per_problem_us"] or r["latency_per_problem_us_est"], "{:.1f}"),
             _f(r["latency_batch_us_150"], "{:.1f}"), _f(r["latency_per_problem_us_150"], "{:.1f}"),
             f"{r['latency_001_us_150']:.1f} / {r['latency_001_per_problem_us_150']:.1f}"] for r in br]
    L += _table(["P", f"batch cycles (Imax = {r0['imax']})", "Fmax MHz", "us per batch", "us per problem",
                 "us per batch at 150 MHz", "us per problem at 150 MHz",
                 f"001 at 150 MHz, P = {r0['P_eq15_001']}: batch / per problem"], body)
    L += ["", "us per batch: the latency of every problem of the batch (P problems go in together and come out "
          "together). us per problem: per batch / P, the time per solve at full throughput. 001 gives no latency "
          "table for one linear solve, only eq. (17) and (18) and plots: its column is (P N + P) Imax cycles "
          "(eq. (17)) with the P of its eq. (15) at the 150 MHz of section VIII-C, for the same N and Imax.", ""]
    if sw and r0["problem"] in sw:
        s = sw[r0["problem"]]
        acc = s.get("accuracy") or {}
        L += ["### Software on this CPU", "",
              f"{s['systems']} KKT systems of {r0['problem']} as the testbench makes them (H + W with interior-point "
              f"weights log-uniform in [{WEIGHTS[0]:g}, {WEIGHTS[1]:g}] on the constrained variables, b standard "
              "normal, both rounded to binary32; the matrix is the binary32 one the core multiplies by), each "
              f"solved {s['repeats']} time(s) by each solver, half before the hardware jobs and half after"
              + (f" (1-minute load average {' and '.join(f'{v:.2f}' for v in s['load'])})" if s.get("load") else "")
              + f". Both run Imax = {r0['imax']} iterations from x_0 = 0: scipy with rtol = 0 and maxiter = Imax "
              "(its iterations counted), numpy the float64 MINRES of mpc_cores/minres/model.py on the dense matrix. "
              "Median: the smallest of the passes' median times per solve (other processes only add time); "
              "one thread each (the timing loop is sequential).", ""]
        body = []
        for key, _ in SOLVERS:
            t = s["solvers"][key]
            it = t["iterations"]
            body.append([t["name"], f"{median_us(t['times_us']):.0f}", f"{np.percentile(t['times_us'], 90):.0f}",
                         f"{median_us(t['times_us']) / r0['imax']:.1f}", f"{min(it)} / {max(it)}",
                         f"{t['residual_median']:.1e} / {t['residual_max']:.1e}"])
        L += _table(["solver", "median us per solve", "p90 us", "us per iteration", "iterations min / max",
                     "relative residual median / max"], body)
        if acc:
            L += ["", f"The core (bit-exact binary32 model, the words the RTL returns) on the first {acc['systems']} "
                  f"system(s): relative residual ||b - K x|| / ||b|| median {acc['core_median']:.1e}, max "
                  f"{acc['core_max']:.1e} after {r0['imax']} iterations; float64 MINRES {acc['f64_max']:.1e}; "
                  f"a direct solve {acc['direct_max']:.1e} (median condition number {acc['cond']:.0f}). MINRES on "
                  "this indefinite system is not converged to float64 precision in N iterations; the binary32 core "
                  "comes within a small factor of the float64 iteration."]
        L += [""]
        body = [[str(r["P"]), _f(r["latency_batch_us"] or r["latency_batch_us_est"], "{:.0f}"),
                 _f(r["latency_per_problem_us"] or r["latency_per_problem_us_est"], "{:.0f}"),
                 _f(r["scipy_over_core_batch"], "{:.1f}x"), _f(r["scipy_over_core_per_problem"], "{:.1f}x"),
                 _f(r["numpy_over_core_batch"], "{:.1f}x"), _f(r["numpy_over_core_per_problem"], "{:.1f}x"),
                 f"{_f(r['scipy_over_core_batch_150'], '{:.1f}x')} / {_f(r['scipy_over_core_per_problem_150'], '{:.1f}x')}",
                 f"{_f(r['numpy_over_core_batch_150'], '{:.1f}x')} / {_f(r['numpy_over_core_per_problem_150'], '{:.1f}x')}"]
                for r in br]
        L += _table(["P", "core us per batch", "core us per problem", "scipy / core batch",
                     "scipy / core per problem", "numpy / core batch", "numpy / core per problem",
                     "scipy / core at 150 MHz: batch / per problem", "numpy / core at 150 MHz: batch / per problem"],
                    body)
        L += ["", "x / core batch: software time per solve over the core's latency for a batch (what one problem "
              "waits); x / core per problem: over the batch latency / P (throughput with P problems in flight). "
              "The last two columns put the core at 001's 150 MHz."
              + (" Latencies at the estimated Fmax where the core was not placed." if est else ""), ""]
    L += ["### Utilisation", ""]
    body = [[c.problem, str(r["P"]), _n(r["nnz"]), _n(r["useful_flops"]), str(r["band_flops"]), _n(r["fp_units"]),
             str(r["slot_cycles"]), _f(100 * r["utilisation"] if r["utilisation"] is not None else None, "{:.1f} %"),
             _f(100 * r["utilisation_band"] if r["utilisation_band"] is not None else None, "{:.1f} %")]
            for c, r in zip(cores, recs)]
    L += _table(["problem", "P", "nnz(K)", "useful flops per iteration", "issued (band)", "FP operators", "slot S",
                 "utilisation", "issued / capacity"], body)
    L += ["", "Useful flops of one problem's iteration: 2 nnz(K) - N for the matrix-vector product on the KKT "
          "matrix's nonzeros (with the interior-point weights), 16 N - 2 for delta, u, ||u||^2, v_(j+1), w_(j+1) "
          "and x, 17 scalar operations: 2 nnz + 15 N + 15. Capacity: every FMul, FAdd, FDiv and FSqrt can start "
          "one operation per cycle, and a problem owns the whole datapath for its slot of S cycles (P problems, P "
          "slots per iteration), so utilisation = useful flops / (operators x S). Issued: what the core computes, "
          "K products and K - 1 adds per row (the row's slots, unused ones included) and the same "
          "updates. The idle share is the unused slots, the scalar units (busy a few cycles per slot), the "
          "FDiv/FSqrt counted as one operator each, and the stretched slots when P is below eq. (15).", ""]
    L += ["### Step times (s; empty when cached or from the result store)", ""]
    body = [[c.tag] + [_f(c.seconds.get(k), "{:.0f}", "") for k in ("sbt", "verilator", "yosys_ecp5", "nextpnr",
                                                                     "yosys_xc7")] for c in cores]
    L += _table(["core", "sbt (share)", "Verilator", "Yosys ECP5", "nextpnr", "Yosys xc7"], body)
    L += ["", f"MINRES part: {info.get('runtime_s', 0) / 60:.1f} min"
          + (", software timing and model " + ", ".join(f"{k} {v:.0f} s" for k, v in info.get("sw_seconds", {}).items())
             if info.get("sw_seconds") else "") + ". Files: minres.csv (every number above, one row per core); per "
          "core under minres/cores/: the SystemVerilog, core.json, the simulation, Yosys and nextpnr logs and "
          "reports.", ""]
    if info.get("errors"):
        L += ["MINRES steps that failed:", ""] + [f"- {e}" for e in info["errors"]] + [""]
    return L

