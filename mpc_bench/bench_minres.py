"""Benchmark of the MINRES core (the MINRES part of `make bench`; entry point `run_minres`).

MINRES core, masses (examples/masses.yaml: n = 8, m = 4, T = 10, so N = 216, M = 20; Imax = the design's), over P:
  cycles       per MINRES iteration measured in Verilator (cocotb test `cycles_per_iteration` of verif.minres.tb:
               LAST_CYCLES of a batch of P problems at Imax = 3 and 4), beside P N + P of 001 (eq. (17)) and the
               core.json contract; batch cycles at the design's Imax = the measured overhead + Imax x per iteration;
  resources    Yosys synth_ecp5 (MULT18X18D, LUT4, FF, DP16KD, distributed RAM) and synth_xilinx -family xc7, beside
               the floating-point operator count of Table I of 001 (4M + 24 for the linear solver); 001 gives no
               LUT, register, DSP or memory counts for its design, only plots;
  Fmax         nextpnr-ecp5 on the LFE5U-85F (speed 8) with constraints/minres_core.lpf, for every core that fits;
               when masses needs more hard blocks than the device has, on a small MINRES problem that fits;
  latency      per batch of P problems and per problem (batch / P) at that Fmax, and 001's (P N + P) Imax cycles
               at its 150 MHz beside ours at 150 MHz;
  software     on this CPU, on the same KKT systems as the testbench makes them (H + W with random interior-point
               weights, random b): scipy.sparse.linalg.minres and the float64 MINRES of mpc_cores/minres/model.py
               (`minres64`, the core's iteration), median time per solve at the core's Imax, and the ratio to the
               core's latency;
  utilisation  useful flops per iteration (the nonzeros of the KKT matrix, not the band's zeros, and the vector
               and scalar updates) over the floating-point operators x cycles per iteration.

    python -m mpc_bench.bench_minres [--quick] [--out build/bench] [--jobs 2] [--P 1,2,4,8] [--no-xilinx]
"""
from __future__ import annotations

import argparse
import math
import os
import re
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mpc_bench.bench import (
    CONSTRAINTS, ECP5_85F, PNR_SEED, Log, ToolResults, _f, _table, ecp5_fit, generate, latency_us, lpf_frequency,
    machine, ratio, run_cycle_test, run_jobs, synth_ecp5_and_pnr, synth_xc7, write_csv,
)
from mpc_cores.flow import REPO

MASSES = REPO / "examples/masses.yaml"
FULL_P = (1, 2, 3, 4, 8)
QUICK_P = (1,)
# 001 section VIII-C: "a clock frequency above 150MHz is achievable" (Virtex-6, post place and route).
F_001_MHZ = 150.0
# eq. (15) of 001 with the constants of its implementation
K1_001, K2_001 = 24, 154
# Table I of 001: floating-point units of the linear solver: 4M - 3 in the dot-product block, 27 others.
OTHER_001 = 27
# A small MINRES problem that place and route can hold when masses does not fit (see small_problem): n = 2,
# m = 1, T = 3, so N = 19, M = 5; P = 1 (slots stretched to eq. (15)'s chain, the smallest memories).
SMALL = dict(name="dint", T=3)
SMALL_P = 1
# systems the software and the golden models solve
SW_SYSTEMS_FULL, SW_SYSTEMS_QUICK = 24, 8
MODEL_SYSTEMS = 3
WEIGHTS = (0.1, 10.0)   # log-uniform interior-point weights, as verif/minres/tb.py draws them


# ----------------------------------------------------------------------------------------- one core

@dataclass
class MinresCore(ToolResults):
    """One generated MINRES core with what the bench measures on it (mpc_bench.bench's generation, Yosys and nextpnr
    steps serve it)."""
    problem: str
    P: int
    out: Path
    design: object               # mpc_cores.minres.design.MinresDesign
    role: str = "sweep"          # "sweep": masses over P; "fmax": the small problem for place and route
    kind: str = "minres"
    units: dict = field(default_factory=dict)
    place: bool = True           # False: synthesis for resources only, no nextpnr

    @property
    def tag(self) -> str:
        return f"MINRES {self.problem} P={self.P}"

    @property
    def placeable(self) -> bool:
        """Whether nextpnr should run after synthesis; whether the hard blocks fit is checked on the synthesised
        counts (bench.ecp5_fit)."""
        return self.place

    @property
    def hierarchical(self) -> bool:
        return False


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


def band_flops(N: int, M: int) -> int:
    """What the core issues for the same iteration: every one of the 2M - 1 band products and 2M - 2 tree adds of
    every row (structural zeros included), and the same vector and scalar updates."""
    return N * (4 * M - 3) + 16 * N + 15


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


# ----------------------------------------------------------------------------------------- steps on one core

def measure_cycles(c: MinresCore, log) -> None:
    """Cycles per iteration and per batch of the core in Verilator (cocotb test cycles_per_iteration, which also
    checks every output word against the bit-exact model)."""
    rec = next((r for r in run_cycle_test(c, "cycles_per_iteration") if r.get("test") == "cycles"), None)
    if rec is None:
        raise RuntimeError(f"cycles_per_iteration wrote no cycle record: see {c.out / 'sim' / 'sim.log'}")
    c.measured = rec
    log(f"{c.tag}: measured {rec['cycles_per_iteration']} cycles/iteration (P N + P = {rec['PN_plus_P']}), "
        f"batch cycles {rec['batch_cycles']} ({c.seconds['verilator']:.0f} s)")


def count_units(c: MinresCore) -> None:
    c.units = float_units(c.sv.read_text(), c.module)


# ----------------------------------------------------------------------------------------- software on this CPU

@dataclass
class Systems:
    """KKT systems of one problem as the testbench makes them: diag = H_ii + w_i (random interior-point weights,
    log-uniform in WEIGHTS), b standard normal, both rounded to binary32; K the binary32 matrix the core uses."""
    diag: list
    b: list
    K: list                      # dense float64 N x N (binary32 values)
    imax: int
    model: object                # MinresCoreModel


def make_systems(d, count: int, seed: int = 1) -> Systems:
    from mpc_cores.minres.kkt import random_weights
    from mpc_cores.minres.model import MinresCoreModel

    rng = np.random.default_rng(seed)
    model = MinresCoreModel(d.n, d.m, d.T, d.rom, d.lat["lat_add"])
    diags, bs, Ks = [], [], []
    for _ in range(count):
        w = random_weights(rng, d.n, d.m, d.T, *WEIGHTS)
        diag = (np.asarray(d.h_diag) + w).astype(np.float32)
        diags.append(diag)
        bs.append(rng.standard_normal(model.N).astype(np.float32))
        Ks.append(model.matrix(diag))
    return Systems(diags, bs, Ks, d.iterations, model)


def rel_residual(K: np.ndarray, x: np.ndarray, b: np.ndarray) -> float:
    b = np.asarray(b, dtype=float)
    return float(np.linalg.norm(b - K @ np.asarray(x, dtype=float)) / np.linalg.norm(b))


class ScipyMinres:
    """scipy.sparse.linalg.minres on the CSR matrix, rtol = 0 and maxiter = Imax: it runs Imax iterations unless
    its own tests find the residual at machine precision first (the iterations are counted)."""
    name = "scipy.sparse.linalg.minres"

    def __init__(self, K: np.ndarray, imax: int):
        import scipy.sparse as sp

        self.A = sp.csr_matrix(K)
        self.imax = imax
        self.iters = 0

    def __call__(self, b: np.ndarray) -> np.ndarray:
        from scipy.sparse.linalg import minres

        self.iters = 0

        def cb(_):
            self.iters += 1

        x, _ = minres(self.A, np.asarray(b, dtype=float), rtol=0.0, maxiter=self.imax, callback=cb)
        return x


class NumpyMinres:
    """The float64 MINRES of mpc_cores/minres/model.py (`minres64`, the core's iteration) on the dense matrix, Imax
    iterations."""
    name = "numpy MINRES float64 (minres64)"

    def __init__(self, K: np.ndarray, imax: int):
        self.K = np.ascontiguousarray(K)
        self.imax = imax
        self.iters = imax

    def __call__(self, b: np.ndarray) -> np.ndarray:
        from mpc_cores.minres.model import minres64

        return minres64(self.K, b, self.imax)


SOLVERS = (("scipy", ScipyMinres), ("numpy", NumpyMinres))


def time_software(s: Systems, repeats: int) -> dict:
    """Wall time per solve (us) of each software solver on every system, `repeats` passes; the solver is set up
    per system outside the timing (matrix conversion), the solve timed with time.perf_counter."""
    import gc

    out = {}
    for key, cls in SOLVERS:
        times = np.zeros((repeats, len(s.b)))
        res, iters = [], []
        for r in range(repeats):
            for k, (K, b) in enumerate(zip(s.K, s.b)):
                solver = cls(K, s.imax)
                gc.collect()
                gc.disable()
                try:
                    t0 = time.perf_counter()
                    x = solver(b)
                    times[r, k] = time.perf_counter() - t0
                finally:
                    gc.enable()
                if r == 0:
                    res.append(rel_residual(K, x, b))
                    iters.append(solver.iters)
        out[key] = {"name": cls.name, "times_us": times * 1e6, "residual_max": max(res),
                    "residual_median": float(np.median(res)), "iterations": iters}
    return out


def merge_times(a: dict | None, b: dict | None) -> dict | None:
    """Two timing sessions (before and after the hardware jobs) as one: every pass kept."""
    if a is None or b is None:
        return a or b
    return {k: dict(a[k], times_us=np.vstack([a[k]["times_us"], b[k]["times_us"]])) for k in a}


def median_us(times_us: np.ndarray) -> float:
    """The smallest per-pass median time per solve: other processes on the machine only ever add time."""
    return float(np.median(np.atleast_2d(times_us), axis=1).min())


def model_accuracy(s: Systems, count: int) -> dict:
    """Relative residual ||b - K x|| / ||b|| of the core's bit-exact binary32 model at Imax (the core's own
    output words) and of the float64 MINRES, on the first `count` systems, and of a direct solve."""
    from mpc_cores.minres.model import minres64

    core, f64, direct = [], [], []
    for K, diag, b in list(zip(s.K, s.diag, s.b))[:count]:
        r = s.model.solve(diag, b, s.imax)
        core.append(rel_residual(K, r.x, b) if not r.flag else float("nan"))
        f64.append(rel_residual(K, minres64(K, b, s.imax), b))
        direct.append(rel_residual(K, np.linalg.solve(K, np.asarray(b, dtype=float)), b))
    return {"systems": len(core), "core_max": max(core), "core_median": float(np.median(core)),
            "f64_max": max(f64), "direct_max": max(direct),
            "cond": float(np.median([np.linalg.cond(K) for K in s.K[:count]]))}


# ----------------------------------------------------------------------------------------- records

def fmax_estimate(cores: list[MinresCore]) -> tuple[float | None, str]:
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


def minres_rows(cores: list[MinresCore], sw: dict | None, nnz: dict) -> list[dict]:
    """One flat record per core: the CSV rows and the source of every MINRES table. `nnz`: problem -> nonzeros of
    its KKT matrix (with the interior-point weights)."""
    from mpc_bench.bench import _tool_columns

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
            "nnz": nnz.get(c.problem), "useful_flops": flops, "band_flops": band_flops(N, M),
            "utilisation": utilisation(flops, ops, cj["slot_cycles"]) if flops and ops else None,
            "utilisation_band": utilisation(band_flops(N, M), ops, cj["slot_cycles"]) if ops else None,
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


def _fmax_rows(cores: list[MinresCore], recs: list[dict]) -> list[str]:
    body = []
    for c, r in zip(cores, recs):
        cp = (c.pnr or {}).get("critical_path")
        head = [c.problem, str(r["N"]), str(r["M"]), str(c.P)]
        if c.pnr:
            body.append(head + [f"{c.pnr['fmax_mhz']:.1f}", _n(r.get("ecp5_TRELLIS_COMB_pnr")),
                                f"{cp['from']} ({cp['source_kind']}) -> {cp['to']}" if cp else "-",
                                f"{cp['logic_levels']}: " + ", ".join(f"{v} {k}" for k, v in cp["kinds"].items())
                                if cp else "-",
                                f"{cp['total_ns']:.2f} ({cp['clk_to_q_ns']:.2f} clk-to-q, {cp['logic_ns']:.2f} logic, "
                                f"{cp['routing_ns']:.2f} routing)" if cp else "-"])
        else:
            body.append(head + ["-", "-", c.pnr_note or "not run", "-", "-"])
    L = _table(["problem", "N", "M", "P", "Fmax MHz", "TRELLIS_COMB", "critical path (register to register)",
                "logic cells", "ns"], body)
    for c in cores:
        cp = (c.pnr or {}).get("critical_path")
        if cp:
            L += ["", f"{c.tag}: RTL signals on the critical path: " + ", ".join(cp["signals"])
                  + f"; longest net {cp['max_net'][1]} ({cp['max_net'][0]:.2f} ns)."]
    return L


def minres_section(cores: list[MinresCore], recs: list[dict], sw: dict | None, info: dict) -> list[str]:
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
          "dot-product block and 27 others for its linear solver, 4M + 24; ours has 2M - 1 + 17 FMul, "
          "2M - 2 + 8 + 2 l_A FAdd, 4 FDiv and 2 FSqrt (README, MINRES core): the same 4M - 3 in the dot-product "
          f"block and {_n(r0['fp_units'] - (4 * r0['M'] - 3) if r0['fp_units'] else None)} others (the 2-norm's own "
          "accumulator, l_A partial sums per streaming accumulator, a fully pipelined scalar part). 001 reports no LUT, register, DSP "
          "or memory counts for a given problem (Fig. 6 plots them against n for a Virtex-6 VSX475T synthesised "
          "with XST), so there is nothing to put beside the Yosys counts. ECP5: `synth_ecp5`; xc7: `synth_xilinx "
          "-family xc7 -flatten` (RAMB in 36 Kb blocks); Yosys gives no timing for the Xilinx part. The vector "
          "memories have asynchronous reads and up to five read ports, which no block RAM offers: Yosys builds "
          "them from distributed RAM or flip-flops, which is why FF and LUT4 grow with P.", "",
          "Memories as Yosys inferred them (memory_libmap):", ""]
    L += [f"- {c.tag}: ECP5 {mem_list(c.ecp5_mem) or '-'}; xc7 {mem_list(c.xc7_mem) or '-'}" for c in cores
          if c.ecp5_mem or c.xc7_mem] or ["- (none reported)"]
    L += ["", "Storage words (core.json): " + "; ".join(
        f"P = {r['P']}: {r['storage_words']} (001's bound {r['storage_bound_001']}, dense-band CDS "
        f"{r['storage_dense_cds']})" for r in br) + ".", ""]
    L += ["### Fmax and critical path (nextpnr-ecp5, LFE5U-85F, CABGA381, speed 8)", ""]
    tgt = next((r["fmax_target_mhz"] for r in recs if r.get("fmax_target_mhz")), None) \
        or lpf_frequency(CONSTRAINTS.joinpath("minres_core.lpf").read_text())
    L += [f"constraints/minres_core.lpf (`--freq {_f(tgt, '{:g}')}`, 001's clock), seed {PNR_SEED}, "
          "`--lpf-allow-unconstrained`: the LPF has the clock only, so the Fmax is register to register. "
          + info.get("pnr_text", ""), ""]
    L += _fmax_rows(cores, recs)
    if small:
        s0 = small[0][1]
        L += ["", f"`{s0['problem']}` is a small MINRES problem built in mpc_bench/bench_minres.py (a double integrator, "
              f"n = {s0['n']}, m = {s0['m']}, T = {s0['T']}: N = {s0['N']}, M = {s0['M']}) with the same "
              "operators, scalar part and memories; its dot-product block has 2M - 1 = "
              f"{2 * s0['M'] - 1} products where masses has {2 * r0['M'] - 1}."]
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
          "the full band of 2M - 1 products and 2M - 2 adds per row (zeros of the band included) and the same "
          "updates. The idle share is the band's zeros, the scalar units (busy a few cycles per slot), the "
          "FDiv/FSqrt counted as one operator each, and the stretched slots when P is below eq. (15).", ""]
    L += ["### Step times (s; empty when cached)", ""]
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


# ----------------------------------------------------------------------------------------- run

def small_problem():
    """SMALL as an MPC problem: a double integrator (position, velocity; one force input) at Ts = 0.2 s, horizon
    3, Q = 1, R = 0.1, QN from the Riccati equation: n = 2, m = 1, T = 3, so N = 19, M = 5."""
    from mpc_cores.problem import problem_from_dict

    spec = {"name": SMALL["name"], "model": {"Ac": [[0.0, 1.0], [0.0, 0.0]], "Bc": [[0.0], [1.0]], "Ts": 0.2},
            "cost": {"Q": 1.0, "R": 0.1, "QN": "dare"}, "horizon": SMALL["T"],
            "inputs": {"min": -1.0, "max": 1.0}, "states": {"min": -5.0, "max": 5.0}}
    return problem_from_dict(spec, SMALL["name"])


def logic_fit(res: dict) -> list[str]:
    """What the synthesised core needs beyond the LFE5U-85F: its hard blocks (bench.ecp5_fit), its LUT4 (a CCU2C
    holds two, a DPR16X4 takes two and their write logic) and its flip-flops."""
    over = list(ecp5_fit(res))
    luts = res.get("LUT4", 0) + 2 * res.get("CCU2C", 0) + 3 * res.get("LUTRAM", 0)
    if luts > ECP5_85F["LUT4"]:
        over.append(f"{luts} LUT4 (LUT4 + 2 CCU2C + 3 DPR16X4) needed, {ECP5_85F['LUT4']} on the LFE5U-85F")
    if res.get("FF", 0) > ECP5_85F["FF"]:
        over.append(f"{res['FF']} FF needed, {ECP5_85F['FF']} on the LFE5U-85F")
    return over


def synth_ecp5(c: MinresCore, log) -> None:
    """synth_ecp5; then nextpnr (bench.synth_ecp5_and_pnr, which reuses the cached synthesis) when the core is to
    be placed and fits the LFE5U-85F."""
    from mpc_bench.bench import _yosys, ecp5_resources

    cells, c.ecp5_mem = _yosys(c, "ecp5", log)
    c.ecp5 = ecp5_resources(cells)
    over = logic_fit(c.ecp5)
    if over:
        c.pnr_note = "does not fit: " + "; ".join(over)
        log(f"{c.tag}: no place and route, {c.pnr_note}")
    elif not c.place:
        c.pnr_note = "not placed (resources only)"
    else:
        synth_ecp5_and_pnr(c, log)


def run_minres(out: Path, quick: bool, jobs: int, log, xilinx: bool, Ps: tuple | None = None,
               place: bool | None = None, small: bool | None = None, synth_Ps: tuple | None = None) -> dict:
    """The MINRES part of the benchmark: cores under out/minres/cores, returns {"rows": one record per core (for
    minres.csv), "section": report.md lines ("## MINRES core"), "summary": README table lines, "errors": failed
    steps}. quick: P = QUICK_P, no place and route of masses, fewer software passes; xilinx: also synth_xilinx.
    Ps, place (nextpnr on the masses cores), small (the small problem for Fmax) and synth_Ps (the masses cores
    Yosys synthesises; default all: 13 min for P = 1 on a 2-core EPYC, more with P) override the defaults."""
    from mpc_cores.minres.design import DesignError, design_minres
    from mpc_cores.problem import load_spec

    t_start = time.perf_counter()
    Ps = tuple(Ps or (QUICK_P if quick else FULL_P))
    place = (not quick) if place is None else place
    small = (not quick) if small is None else small
    synth_Ps = tuple(Ps if synth_Ps is None else synth_Ps)
    root = Path(out).resolve() / "minres"
    if root.parts[:2] == ("/", "tmp"):
        raise ValueError(f"{root}: the YoWASP tools see their own private /tmp, choose a folder elsewhere")
    (root / "cores").mkdir(parents=True, exist_ok=True)
    info: dict = {"errors": [], "sw_seconds": {}}
    problem = load_spec(MASSES)
    cores: list[MinresCore] = []
    designs = {}
    for P in Ps:
        try:
            d = design_minres(problem, P=P)
        except DesignError as e:
            info["errors"].append(f"MINRES P={P}: design refused: {e}")
            continue
        designs[problem.name] = d
        cores.append(MinresCore(problem.name, P, root / "cores" / f"{problem.name}_p{P}", d, place=place))
    if small:
        sp = small_problem()
        ds = design_minres(sp, P=SMALL_P)
        designs[sp.name] = ds
        cores.append(MinresCore(sp.name, SMALL_P, root / "cores" / f"{sp.name}_p{SMALL_P}", ds, role="fmax"))
    log(f"MINRES: masses P = {', '.join(map(str, Ps))}" + (f", {SMALL['name']} P = {SMALL_P} for Fmax" if small else "")
        + f"; place and route {'on' if place else 'off'} for masses; Xilinx synthesis {'on' if xilinx else 'off'}")

    # Software and golden model on the KKT systems, before the hardware jobs (and the timing again after them).
    sw: dict = {}
    nnz: dict = {}
    systems = None
    t = time.perf_counter()
    try:
        for name, d in designs.items():
            if name == problem.name:
                systems = make_systems(d, SW_SYSTEMS_QUICK if quick else SW_SYSTEMS_FULL)
                nnz[name] = int(np.count_nonzero(systems.K[0]))
            else:
                nnz[name] = int(np.count_nonzero(make_systems(d, 1).K[0]))
        if systems is not None:
            sw[problem.name] = {"systems": len(systems.b), "accuracy": model_accuracy(systems, 1 if quick else MODEL_SYSTEMS)}
    except Exception as e:  # the report goes on without the software columns
        info["errors"].append(f"MINRES software set-up: {e}")
        log(f"FAILED MINRES software set-up: {e}")
    info["sw_seconds"]["systems and model"] = time.perf_counter() - t
    repeats = 2 if quick else 6

    def timing() -> dict | None:
        if systems is None:
            return None
        t = time.perf_counter()
        try:
            return time_software(systems, repeats // 2)
        except Exception as e:
            info["errors"].append(f"MINRES software timing: {e}")
            log(f"FAILED MINRES software timing: {e}")
            return None
        finally:
            info["sw_seconds"]["timing"] = info["sw_seconds"].get("timing", 0.0) + time.perf_counter() - t

    loads = [os.getloadavg()[0]]
    sw1 = timing()

    try:
        generate(cores, log)
    except Exception as e:  # the generator's message says what it refused
        info["errors"].append(f"MINRES generation: {e}")
        log(f"FAILED MINRES generation: {e}")
        cores = [c for c in cores if c.core]
    sims, hw = [], []
    for c in cores:
        count_units(c)
        # rough seconds on a 2-core machine, for longest-first scheduling
        sims.append((100 + 20 * c.P, f"{c.tag} verilator", lambda c=c: measure_cycles(c, log)))
        if c.role == "sweep" and c.P not in synth_Ps:
            c.pnr_note = "not synthesised in this run"
            continue
        hw.append((400 * c.P + (600 if c.place else 0), f"{c.tag} ecp5", lambda c=c: synth_ecp5(c, log)))
        if xilinx and c.role == "sweep":
            hw.append((300 * c.P, f"{c.tag} xc7", lambda c=c: synth_xc7(c, log)))
    # the cycle measurements (about a minute each) before the syntheses (many minutes each)
    info["errors"] += run_jobs(sims, jobs, log)
    info["errors"] += run_jobs(hw, jobs, log)
    loads.append(os.getloadavg()[0])
    sw2 = timing()
    merged = merge_times(sw1, sw2)
    if merged and problem.name in sw:
        sw[problem.name].update(solvers=merged, repeats=2 * (repeats // 2) if sw2 else repeats // 2, load=loads)
    else:
        sw.pop(problem.name, None)
    rows = minres_rows(cores, sw, nnz)
    info["runtime_s"] = time.perf_counter() - t_start
    placed = [c for c in cores if c.pnr]
    info["pnr_text"] = (("Placed and routed: " + ", ".join(c.tag for c in placed) + ". ") if placed else
                        "No core was placed and routed in this run. ") + (
        "" if place else "Place and route of the masses cores was off in this run (QUICK or --no-place). ") + (
        f"Yosys synthesised the masses cores at P = {', '.join(map(str, synth_Ps))} only (13 min for P = 1 on a "
        "2-core EPYC, longer with P). " if set(Ps) - set(synth_Ps) else "")
    sweep = [r for r in rows if r["role"] == "sweep"]
    section = minres_section(cores, rows, sw, info)
    summary = [f"MINRES core, {sweep[0]['problem']} (N = {sweep[0]['N']}, M = {sweep[0]['M']}, Imax = "
               f"{sweep[0]['imax']}, binary32)", "", *summary_table(sweep)] if sweep else []
    log(f"MINRES part done in {info['runtime_s'] / 60:.1f} min")
    return {"rows": rows, "section": section, "summary": summary, "errors": info["errors"]}


def main(argv=None) -> None:
    from mpc_bench.bench import _ints

    ap = argparse.ArgumentParser(prog="python -m mpc_bench.bench_minres", description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help=f"P = {','.join(map(str, QUICK_P))}, no place and route, "
                    "no Xilinx, fewer software passes")
    ap.add_argument("--out", default=str(REPO / "build/bench"))
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--P", default=None, help=f"masses P values (default {','.join(map(str, FULL_P))})")
    ap.add_argument("--no-xilinx", action="store_true")
    ap.add_argument("--no-place", action="store_true", help="no nextpnr on the masses cores")
    ap.add_argument("--no-small", action="store_true", help=f"no {SMALL['name']} core for Fmax")
    ap.add_argument("--synth-P", default=None, help="masses P values to synthesise (default: all of --P)")
    a = ap.parse_args(argv)
    out = Path(a.out).resolve()
    log = Log()
    res = run_minres(out, a.quick, a.jobs, log, not (a.quick or a.no_xilinx), Ps=_ints(a.P, ()) or None,
                     place=False if a.no_place else None, small=False if a.no_small else None,
                     synth_Ps=_ints(a.synth_P, ()) if a.synth_P else None)
    out.mkdir(parents=True, exist_ok=True)
    write_csv(out / "minres.csv", res["rows"])
    m = machine()
    head = ["# Benchmark of the MINRES core", "",
            f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())} · {m['cpu']}, {m['cores']} cores "
            f"({m['logical']} logical CPUs) · {m['system']} · Python {m['python']} · "
            f"{'QUICK' if a.quick else 'full'} run", ""]
    (out / "minres_report.md").write_text("\n".join(head + res["section"]) + "\n")
    print("\n" + "\n".join(res["summary"]))
    log(f"wrote {out / 'minres.csv'} and {out / 'minres_report.md'}")
    if res["errors"]:
        print("\nfailed steps:\n  " + "\n  ".join(res["errors"]))
        raise SystemExit(1)


if __name__ == "__main__":
    main()
