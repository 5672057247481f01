"""MINRES section of the benchmark (`make bench`; also alone: `python -m mpc_bench.minres`).

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
               core's latency (mpc_bench.baselines_minres);
  utilisation  useful flops per iteration (the nonzeros of the KKT matrix, not the band's zeros, and the vector
               and scalar updates) over the floating-point operators x cycles per iteration.

The section is self-contained in report.md (its own step times and failed steps, after the shared tables); its
formulas, records and report lines are mpc_bench.minres_report. Alone it writes minres.csv and minres_report.md:

    python -m mpc_bench.minres [--quick] [--out build/bench] [--jobs 2] [--P 1,2,4,8] [--no-xilinx] [--no-place]
                               [--no-small] [--synth-P 1]
"""
from __future__ import annotations

import argparse
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mpc_bench import float_ops, section
from mpc_bench.baselines_minres import make_systems, merge_times, model_accuracy, time_software
from mpc_bench.minres_report import float_units, minres_rows, minres_section, summary_table
from mpc_bench.parsers import ECP5_85F, ecp5_fit, ecp5_resources
from mpc_bench.report import write_alone
from mpc_bench.tools import Job, Log, ToolResults, run_cycle_test, run_yosys, synth_ecp5_and_pnr, synth_xc7
from mpc_cores.flow import REPO

MASSES = REPO / "examples/masses.yaml"
FULL_P = (1, 2, 3, 4, 8)
QUICK_P = (1,)
# A small MINRES problem that place and route can hold when masses does not fit (see small_problem): n = 2,
# m = 1, T = 3, so N = 19, M = 5; P = 1 (slots stretched to eq. (15)'s chain, the smallest memories).
SMALL = dict(name="dint", T=3)
SMALL_P = 1
# systems the software and the golden models solve
SW_SYSTEMS_FULL, SW_SYSTEMS_QUICK = 24, 8
MODEL_SYSTEMS = 3


# ----------------------------------------------------------------------------------------- one core

@dataclass
class MinresCore(ToolResults):
    """One generated MINRES core with what the bench measures on it (the generation, Yosys and nextpnr steps of
    mpc_bench.tools serve it)."""
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
        counts (mpc_bench.parsers.ecp5_fit)."""
        return self.place

    @property
    def hierarchical(self) -> bool:
        return False


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


def small_problem():
    """SMALL as an MPC problem: a double integrator (position, velocity; one force input) at Ts = 0.2 s, horizon
    3, Q = 1, R = 0.1, QN from the Riccati equation: n = 2, m = 1, T = 3, so N = 19, M = 5."""
    from mpc_cores.problem import problem_from_dict

    spec = {"name": SMALL["name"], "model": {"Ac": [[0.0, 1.0], [0.0, 0.0]], "Bc": [[0.0], [1.0]], "Ts": 0.2},
            "cost": {"Q": 1.0, "R": 0.1, "QN": "dare"}, "horizon": SMALL["T"],
            "inputs": {"min": -1.0, "max": 1.0}, "states": {"min": -5.0, "max": 5.0}}
    return problem_from_dict(spec, SMALL["name"])


def logic_fit(res: dict) -> list[str]:
    """What the synthesised core needs beyond the LFE5U-85F: its hard blocks (mpc_bench.parsers.ecp5_fit), its
    LUT4 (a CCU2C holds two, a DPR16X4 takes two and their write logic) and its flip-flops."""
    over = list(ecp5_fit(res))
    luts = res.get("LUT4", 0) + 2 * res.get("CCU2C", 0) + 3 * res.get("LUTRAM", 0)
    if luts > ECP5_85F["LUT4"]:
        over.append(f"{luts} LUT4 (LUT4 + 2 CCU2C + 3 DPR16X4) needed, {ECP5_85F['LUT4']} on the LFE5U-85F")
    if res.get("FF", 0) > ECP5_85F["FF"]:
        over.append(f"{res['FF']} FF needed, {ECP5_85F['FF']} on the LFE5U-85F")
    return over


def synth_ecp5(c: MinresCore, log) -> None:
    """synth_ecp5; then nextpnr (mpc_bench.tools.synth_ecp5_and_pnr, which reuses the cached synthesis) when the
    core is to be placed and fits the LFE5U-85F."""
    cells, c.ecp5_mem = run_yosys(c, "ecp5", log)
    c.ecp5 = ecp5_resources(cells)
    over = logic_fit(c.ecp5)
    if over:
        c.pnr_note = "does not fit: " + "; ".join(over)
        log(f"{c.tag}: no place and route, {c.pnr_note}")
    elif not c.place:
        c.pnr_note = "not placed (resources only)"
    else:
        synth_ecp5_and_pnr(c, log)


# ----------------------------------------------------------------------------------------- the section

class Section(section.Section):
    name, label = "minres", "MINRES"
    appendix = True

    def __init__(self, run=None):
        self.designs: dict = {}
        self.nnz: dict = {}
        self.systems = None
        self.halves: list = []
        self.loads: list = []
        self.sw_seconds: dict = {}
        self.pnr_text = ""
        self.float_ops: list = []
        super().__init__(run)

    def configure(self, a) -> None:
        self.quick = a.quick
        self.xilinx = not (a.quick or a.no_xilinx)
        self.repeats = 2 if a.quick else 6
        # QUICK: cycles and software only (Yosys alone takes 13 min on the masses MINRES core)
        self.options(synth_Ps=() if a.quick else None)

    def options(self, Ps: tuple | None = None, place: bool | None = None, small: bool | None = None,
                synth_Ps: tuple | None = None) -> None:
        """Ps (default QUICK_P or FULL_P), place (nextpnr on the masses cores; default: not QUICK), small (the
        small problem for Fmax; default: not QUICK) and synth_Ps (the masses cores Yosys synthesises; default
        all: 13 min for P = 1 on a 2-core EPYC, more with P)."""
        self.Ps = tuple(Ps or (QUICK_P if self.quick else FULL_P))
        self.place = (not self.quick) if place is None else place
        self.small = (not self.quick) if small is None else small
        self.synth_Ps = tuple(self.Ps if synth_Ps is None else synth_Ps)

    def log_text(self) -> str:
        return f"MINRES P = {self.Ps}"

    def plan(self) -> None:
        from mpc_cores.minres.design import DesignError, design_minres
        from mpc_cores.problem import load_spec

        root = Path(self.run.out).resolve() / "minres"
        (root / "cores").mkdir(parents=True, exist_ok=True)
        problem = load_spec(MASSES)
        self.problem_name = problem.name
        for P in self.Ps:
            try:
                d = design_minres(problem, P=P)
            except DesignError as e:
                self.error(f"MINRES P={P}: design refused: {e}")
                continue
            self.designs[problem.name] = d
            self.cores.append(MinresCore(problem.name, P, root / "cores" / f"{problem.name}_p{P}", d, place=self.place))
        if self.small:
            sp = small_problem()
            ds = design_minres(sp, P=SMALL_P)
            self.designs[sp.name] = ds
            self.cores.append(MinresCore(sp.name, SMALL_P, root / "cores" / f"{sp.name}_p{SMALL_P}", ds, role="fmax"))
        self.log(f"MINRES: masses P = {', '.join(map(str, self.Ps))}"
                 + (f", {SMALL['name']} P = {SMALL_P} for Fmax" if self.small else "")
                 + f"; place and route {'on' if self.place else 'off'} for masses; Xilinx synthesis "
                 f"{'on' if self.xilinx else 'off'}")

    def prepare_software(self) -> None:
        """The KKT systems and the golden model's accuracy on them, before the hardware jobs."""
        self.sw = {}
        t = time.perf_counter()
        try:
            for name, d in self.designs.items():
                if name == self.problem_name:
                    self.systems = make_systems(d, SW_SYSTEMS_QUICK if self.quick else SW_SYSTEMS_FULL)
                    self.nnz[name] = int(np.count_nonzero(self.systems.K[0]))
                else:
                    self.nnz[name] = int(np.count_nonzero(make_systems(d, 1).K[0]))
            if self.systems is not None:
                self.sw[self.problem_name] = {"systems": len(self.systems.b), "accuracy": model_accuracy(
                    self.systems, 1 if self.quick else MODEL_SYSTEMS)}
        except Exception as e:  # the report goes on without the software columns
            self.error(f"MINRES software set-up: {e}")
            self.log(f"FAILED MINRES software set-up: {e}")
        self.sw_seconds["systems and model"] = time.perf_counter() - t

    def time_software(self, half: str) -> None:
        self.loads.append(os.getloadavg()[0])
        res = None
        if self.systems is not None:
            t = time.perf_counter()
            try:
                res = time_software(self.systems, self.repeats // 2)
            except Exception as e:
                self.error(f"MINRES software timing: {e}")
                self.log(f"FAILED MINRES software timing: {e}")
            self.sw_seconds["timing"] = self.sw_seconds.get("timing", 0.0) + time.perf_counter() - t
        self.halves.append(res)

    def generation_failed(self, e: Exception) -> None:
        self.error(f"MINRES generation: {e}")
        self.log(f"FAILED MINRES generation: {e}")
        self.cores = [c for c in self.cores if c.core]

    def jobs(self) -> list[Job]:
        """Rough seconds on a 2-core machine, for longest-first scheduling; the cycle measurements (about a minute
        each, wave 0) before the syntheses (many minutes each, wave 1)."""
        log, out = self.run.log, []
        for c in self.cores:
            count_units(c)
            out.append(Job(100 + 20 * c.P, f"{c.tag} verilator", lambda c=c: measure_cycles(c, log)))
            if c.role == "sweep" and c.P not in self.synth_Ps:
                c.pnr_note = "not synthesised in this run"
                continue
            out.append(Job(400 * c.P + (600 if c.place else 0), f"{c.tag} ecp5", lambda c=c: synth_ecp5(c, log),
                           wave=1))
            if self.xilinx and c.role == "sweep":
                out.append(Job(300 * c.P, f"{c.tag} xc7", lambda c=c: synth_xc7(c, log), wave=1))
        # the floating-point operators the MINRES and interior-point cores are built from, placed on their own
        try:
            self.float_ops = float_ops.plan(Path(self.run.out).resolve() / "minres" / "float", self.quick)
            out += float_ops.jobs(self.float_ops, log)
        except Exception as e:
            self.error(f"floating-point operators: {e}")
            self.float_ops = []
        return out

    def finish(self) -> None:
        sw1, sw2 = (self.halves + [None, None])[:2]
        self.sw = self.sw or {}
        merged = merge_times(sw1, sw2)
        name = getattr(self, "problem_name", None)
        if merged and name in self.sw:
            reps = self.repeats // 2
            self.sw[name].update(solvers=merged, repeats=2 * reps if sw2 else reps, load=self.loads)
        else:
            self.sw.pop(name, None)
        self.rows = minres_rows(self.cores, self.sw, self.nnz)
        placed = [c for c in self.cores if c.pnr]
        self.pnr_text = (("Placed and routed: " + ", ".join(c.tag for c in placed) + ". ") if placed else
                         "No core was placed and routed in this run. ") + (
            "" if self.place else "Place and route of the masses cores was off in this run (QUICK or --no-place). ") + (
            f"Yosys synthesised the masses cores at P = {', '.join(map(str, self.synth_Ps))} only (13 min for P = 1 "
            "on a 2-core EPYC, longer with P). " if set(self.Ps) - set(self.synth_Ps) else "")
        self.log(f"MINRES part done in {self.elapsed / 60:.1f} min")

    # ------------------------------------------------------------------------------------- outputs

    def appendix_md(self) -> list[str]:
        if not self.rows:
            return []
        info = {"errors": self.errors, "sw_seconds": self.sw_seconds, "runtime_s": self.elapsed,
                "pnr_text": self.pnr_text}
        return minres_section(self.cores, self.rows, self.sw, info) + float_ops.section_md(self.float_ops)

    def console_summary(self) -> list[str]:
        sweep = [r for r in self.rows if r["role"] == "sweep"]
        return [f"MINRES core, {sweep[0]['problem']} (N = {sweep[0]['N']}, M = {sweep[0]['M']}, Imax = "
                f"{sweep[0]['imax']}, binary32)", "", *summary_table(sweep)] if sweep else []


def main(argv=None) -> None:
    """The MINRES section alone: minres.csv and minres_report.md in --out."""
    ap = argparse.ArgumentParser(prog="python -m mpc_bench.minres", description=__doc__.split("\n\n")[0])
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
    run = section.Run(a, out, log, {"errors": [], "sw_seconds": {}})
    sec = Section(run)
    sec.options(Ps=section.ints(a.P, ()) or None, place=False if a.no_place else None,
                small=False if a.no_small else None, synth_Ps=section.ints(a.synth_P, ()) if a.synth_P else None)
    section.run_sections([sec], run)
    write_alone(sec, out, "minres", "MINRES core", a.quick, log)


if __name__ == "__main__":
    main()
