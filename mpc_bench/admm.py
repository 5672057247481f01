"""ADMM section of the benchmark (`make bench`): the ADMM core on masses_rate_soft
(examples/masses_rate_soft.yaml, n_A = 216, Imax = 40), over P and b, and a small problem for Fmax:

  cycles       L_A measured in Verilator (verif.admm.tb, `cycle_contract`) beside eq. (24) of 002. The simulated
               core is the Imax = 40 design (same widths and datapath) generated with IMAX reset value 5, so the
               simulation stays short; cycles per solve at Imax = 40 = the measured overhead + 40 L_A;
  resources    as for the FGM, beside Table I of 002 (P n_A multipliers);
  Fmax         the masses core needs several times the LFE5U-85F's MULT18X18D (the fit check says how many), so
               nextpnr runs on a small ADMM problem with input-rate and soft state constraints (n_A = 19) at
               P = 1, 2 with constraints/admm_core.lpf;
  latency      our cycles at 400 / 230 MHz beside Table III(b) of 002, and at the small core's ECP5 Fmax (an
               estimate: no ECP5 holds the masses core);
  software     over one closed loop of masses_rate_soft (problem B, the soft-constrained sparse QP (8)): OSQP
               (default and tuned), PIQP (sparse) and Clarabel (mpc_bench.qp_solvers), and Algorithm 2 in float64
               numpy on the unquantised data (the iteration of mpc_cores.admm.model.AdmmFloat), same Imax and warm
               start; single-threaded on one pinned CPU, wall and own-timer times per solve against the core's
               latency and throughput;
  MAC use      n_A^2 (M11 v) over multipliers x L_A.

Formulas, records and report lines: mpc_bench.admm_report. Writes admm.csv, admm_latency_vs_P.png,
admm_resources_vs_P.png and its part of report.md and fmax_vs_P.png.
"""
from __future__ import annotations

import dataclasses
import json
import time
from pathlib import Path

import numpy as np

from mpc_bench import qp
from mpc_bench.admm_report import (
    ADMM_SIM_IMAX, PAPER_TABLE3_ADMM, _est_lat_text, admm_fmax_estimate, admm_rows, admm_section,
    admm_summary_table,
)
from mpc_bench.baselines import prepare_admm_software
from mpc_bench.plots import by_b, latency_plot, resources_plot
from mpc_bench.report import _f
from mpc_bench.section import ints
from mpc_bench.tools import FMAX_SEEDS, FMAX_SEEDS_QUICK, PLACER_ARGS, cached_design
from mpc_cores.flow import REPO

MASSES_SOFT = REPO / "examples/masses_rate_soft.yaml"
# b = 18 is the spec's (and the lower bound 002 gives from Assumption 2). Yosys needs 25 min at P = 1 and 47 min
# at P = 2 per masses core on the bench's 2-core machine, growing with P; no P fits (P = 1 already needs 864
# MULT18X18D of 156), so the full sweep keeps to P = 1, 2 and b = 18 (--admm-P 1,2,4,8 and --admm-b 18,16 add
# more; b = 16 passes Assumption 2 too) and QUICK to P = 1, measured in Verilator only.
FULL_P, FULL_B = (1, 2), (18,)
QUICK_P, QUICK_B = (1,), (18,)
SMALL_FULL_P, SMALL_QUICK_P = (1, 2), (1,)
# Pipeline latencies of the small cores placed and routed for Fmax (role "fmax"): TARGET=ecp5 with l_M = 6, the
# MULT18X18D's three registers, fabric registers landing its outputs, a stage summing the partial products of
# words wider than 18 bits and a register after the product's saturation (docs/dsp.md); l_A = 2 gives the soft
# projection its three one-carry-chain steps and a step of selections. The sweeps keep the spec's l_A = l_M = 1
# (eq. (24), Table III(b)).
FMAX_LAT = dict(lat_add=2, lat_mul=6, target="ecp5")

# The small ADMM problem place and route can hold (the masses core cannot): a random stable plant (2 states,
# 1 input, horizon 3, 1 tracked output) with input-rate limits and one soft state; n_A = 19, so that P = 2 needs
# 2 x 19 products of 20 x 29 bits, 152 MULT18X18D of the LFE5U-85F's 156.
SMALL_ADMM = dict(name="small_rate_soft", nx=2, nu=1, N=3, ny=1, seed=1,
                  input_rate={"min": -0.3, "max": 0.3, "weight": 0.1},
                  soft_states={"indices": [0], "min": -0.5, "max": 0.5, "sigma1": 8, "sigma2": 1},
                  solver={"frac_bits": 18, "iterations": 40})


def small_admm_problem():
    """SMALL_ADMM as a problem: a random plant scaled to spectral radius 0.95 (like tests/conftest.py
    random_problem), Q = 1, R = 0.5, inputs in [-1, 0.8], states in [-3, 3], references of the first ny states in
    [-1, 1], and the input-rate and soft-state sections."""
    from mpc_cores.problem import problem_from_dict

    s = SMALL_ADMM
    rng = np.random.default_rng(s["seed"])
    A = rng.standard_normal((s["nx"], s["nx"]))
    A *= 0.95 / max(abs(np.linalg.eigvals(A)))
    B = rng.standard_normal((s["nx"], s["nu"]))
    d = {"name": s["name"], "model": {"A": A.tolist(), "B": B.tolist()}, "cost": {"Q": 1.0, "R": 0.5},
         "horizon": s["N"], "inputs": {"min": -1.0, "max": 0.8}, "states": {"min": -3.0, "max": 3.0},
         "tracking": {"outputs": list(range(s["ny"])), "min": -1.0, "max": 1.0},
         "input_rate": s["input_rate"], "soft_states": s["soft_states"], "solver": s["solver"]}
    return problem_from_dict(d, s["name"])



@dataclasses.dataclass
class Core(qp.Core):
    @property
    def hierarchical(self) -> bool:
        """ADMM cores that cannot be placed are synthesised without flattening, for their resources only: the P
        row units share one dot-product module, which Yosys then maps once. Flat, the masses ADMM core at P = 4
        ran out of the 4 GB a WebAssembly Yosys can address after 38 min."""
        return not self.placeable


class Section(qp.QpSection):
    name, label, eq = "admm", "ADMM", 24
    plot_files = ("admm_latency_vs_P.png", "admm_resources_vs_P.png")

    @staticmethod
    def add_arguments(ap) -> None:
        ap.add_argument("--admm-P", default=None, help="ADMM masses_rate_soft: P values (default 1,2; QUICK 1)")
        ap.add_argument("--admm-b", default=None, help="ADMM masses_rate_soft: frac_bits (default 18)")
        ap.add_argument("--admm-small-P", default=None,
                        help="ADMM small problem for Fmax: P values (default 1,2; QUICK 1)")
        ap.add_argument("--admm-steps", type=int, default=None, help="closed-loop steps for the ADMM software timing")

    def configure(self, a) -> None:
        super().configure(a)
        self.Ps = ints(a.admm_P, QUICK_P if a.quick else FULL_P)
        self.bs = ints(a.admm_b, QUICK_B if a.quick else FULL_B)
        self.small_Ps = ints(a.admm_small_P, SMALL_QUICK_P if a.quick else SMALL_FULL_P)
        self.steps = a.admm_steps or (120 if a.quick else 400)
        self.run.info.update(admm_Ps=self.Ps, admm_bs=self.bs, admm_small_Ps=self.small_Ps)

    def log_text(self) -> str:
        return f"ADMM P = {self.Ps}, b = {self.bs}, small P = {self.small_Ps}"

    def plan(self) -> None:
        from mpc_cores.admm.design import DesignError, design_admm
        from mpc_cores.problem import load_spec

        out, designs = self.run.out, self.design_dir
        self.problem = soft = load_spec(MASSES_SOFT)
        spec = MASSES_SOFT.read_bytes()
        t = time.perf_counter()
        for b in self.bs:
            try:
                # the word widths depend on b and the spec's Imax, not on P: one design per b
                d = cached_design(designs, f"admm_{soft.name}_b{b}", ("admm", spec, b),
                                  lambda b=b: design_admm(soft, frac_bits=b))
            except DesignError as e:
                self.error(f"ADMM b={b}: design refused: {e}")
                continue
            self.designs[b] = d
            for P in self.Ps:
                if not 1 <= P <= d.n:
                    self.error(f"ADMM P={P}: not in [1, n_A = {d.n}]")
                    continue
                self.cores.append(Core("admm", soft.name, P, b, out / "cores" / f"{soft.name}_p{P}_b{b}",
                                       dataclasses.replace(d, P=P, iterations=ADMM_SIM_IMAX), d.iterations,
                                       synth=not self.quick))
        if self.small_Ps:
            small = small_admm_problem()
            la, lm, tg = FMAX_LAT["lat_add"], FMAX_LAT["lat_mul"], FMAX_LAT["target"]
            d = cached_design(designs, f"admm_{small.name}_la{la}_lm{lm}_{tg}",
                              ("admm", json.dumps(SMALL_ADMM, sort_keys=True), la, lm, tg),
                              lambda: design_admm(small, **FMAX_LAT))
            for P in self.small_Ps:
                self.cores.append(Core("admm", small.name, P, d.b,
                                       out / "cores" / f"{small.name}_p{P}_b{d.b}_la{la}_lm{lm}_{tg}",
                                       dataclasses.replace(d, P=P, iterations=ADMM_SIM_IMAX), d.iterations,
                                       role="fmax", pnr_seeds=FMAX_SEEDS_QUICK if self.quick else FMAX_SEEDS,
                                       pnr_args=PLACER_ARGS))
        self.log(f"ADMM designs in {time.perf_counter() - t:.0f} s")

    def software_case(self):
        return prepare_admm_software(self.problem, self.designs, self.steps, 20)

    def job_costs(self, c: Core) -> tuple[float, float, float]:
        # rough seconds seen on a 2-core EPYC: the masses syntheses (25 min and more each) come last, smallest P
        # first, ECP5 before xc7, so that everything else is in when they run
        if c.role == "fmax":
            return (40, 60 + 400 * c.P, 60 * c.P)
        return (60 + 30 * c.P, -1000 - c.P, -2000 - c.P)

    def make_rows(self) -> list[dict]:
        est, _ = admm_fmax_estimate(self.cores)
        return admm_rows(self.cores, self.sw, est)

    # ------------------------------------------------------------------------------------- outputs

    def sweep(self) -> list[dict]:
        return [r for r in self.rows if r["role"] == "sweep"]

    def run_text(self, info: dict) -> str | None:
        if not self.cores:
            return None
        return (f"ADMM P = {', '.join(map(str, info['admm_Ps']))}, b = {', '.join(map(str, info['admm_bs']))}"
                f"{' (cycles only)' if any(not c.synth for c in self.cores) else ''}, "
                f"small problem P = {', '.join(map(str, info['admm_small_Ps']))}")

    def summary_md(self) -> list[str]:
        big = self.sweep()
        if not big:
            return []
        r0 = big[0]
        est = next((r["fmax_est_mhz"] for r in big if r.get("fmax_est_mhz")), None)
        return [f"### ADMM core, {r0['problem']} (n_A = {r0['n']}, nw = {r0['nw']}, Imax = {r0['imax']}, round to "
                "nearest)", "", *admm_summary_table(big), "",
                f"L_A meas: cycles per iteration measured in Verilator (eq. (24) of 002 in brackets). cycles/solve: "
                f"the overhead measured at Imax = {r0['imax_simulated']} + {r0['imax']} L_A (computed, not simulated "
                f"at {r0['imax']}). mult. ours: P max(n_A, nw + 1); Table I of 002: P n_A. fits LFE5U-85F: the "
                "synthesised core's hard blocks against the device's (no place and route when they do not fit). "
                "V6/S6: our cycles at 400/230 MHz, Table III(b) of 002 in brackets. us est.: our cycles (at the "
                f"small cores' latencies, {_est_lat_text(big)}) at "
                f"{_f(est, '{:.0f}')} MHz, the ECP5 Fmax of the small ADMM problem below (an estimate, the masses "
                "core fits no ECP5). x / core: median software time per solve on this CPU (the solver's own timer "
                "where it has one) over the core's latency, at the estimate / at 400 MHz; fastest solver: the "
                "software solver with the lowest median, its median and p99 over the core's latency at the estimate "
                "(all solvers: ADMM section, Software on this CPU). MAC use: n_A^2 / (multipliers x L_A).", ""]

    def fmax_rows(self) -> list[dict]:
        return [r for r in self.rows if r["role"] == "fmax"]

    def fmax_note(self) -> str:
        return (f"ADMM, on a small problem the device holds: l_A = {FMAX_LAT['lat_add']}, l_M = {FMAX_LAT['lat_mul']}, "
                f"TARGET={FMAX_LAT['target']}")

    def section_md(self) -> list[str]:
        return admm_section(self.cores, self.rows, self.sw) if self.rows else []

    def console_summary(self) -> list[str]:
        big = self.sweep()
        return [f"ADMM, {big[0]['problem']}", *admm_summary_table(big)] if big else []

    def plots(self, plt, out: Path) -> list[Path]:
        big = self.sweep()
        if not big:
            return []
        r0 = big[0]
        paths = [out / "admm_latency_vs_P.png", out / "admm_resources_vs_P.png"]
        latency_plot(plt, paths[0], big, self.sw, PAPER_TABLE3_ADMM, "III(b)", 0,
                     f"ADMM core, {r0['problem']} (n_A = {r0['n']}, Imax = {r0['imax']}): latency vs P")
        resources_plot(plt, paths[1], big, "P n_A", f"ADMM core, {r0['problem']}: resources vs P (Yosys)")
        return paths

    def plot_fmax(self, ax):
        if not self.rows:
            return None
        small = self.fmax_rows()
        for b in sorted({r["b"] for r in small}):
            pts = by_b(small, b, "fmax_mhz")
            if pts:
                ax.plot(*zip(*pts), "s--", label=f"ADMM small (n_A = {small[0]['n']}), b = {b}, "
                                                 f"l_A = {small[0]['lat_add']}, l_M = {small[0]['lat_mul']}")
        big = [r for r in self.rows if r["role"] == "sweep" and r.get("ecp5_MULT18X18D")]
        if big:
            lo = min(big, key=lambda r: r["ecp5_MULT18X18D"])
            ax.annotate(f"ADMM masses_rate_soft (n_A = {lo['n']}) fits at no P: {lo['ecp5_MULT18X18D']} MULT18X18D "
                        f"or more (P = {lo['P']}, b = {lo['b']}), 156 on the LFE5U-85F", (0.02, 0.97),
                        xycoords="axes fraction", fontsize=7, va="top", color="gray")
        return [r["P"] for r in small], [r["fmax_target_mhz"] for r in self.rows], qp.REFERENCE_CLOCKS
