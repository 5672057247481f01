"""Interior-point section of the benchmark (`make bench`; also alone: `python -m mpc_bench.ipm`).

The interior-point core (Algorithm 1 of 001: Stage 1 engine + MINRES in its warm form, 2P problems in flight):
  cycles     core.json's latency of 2P problems sent back to back (warm; mpc_cores.ipm.timing) beside eq. (18) of
             001, 2 I_NW (P N + P) I_MR, their ratio, the Stage 1 program cycles and whether Stage 1 hides behind
             MINRES; for masses at the default design (P from eq. (15)), for a small problem (the double integrator
             of mpc_bench.minres, T = 3) at its default P and at P = 1; measured in Verilator (cocotb test `latency`
             of the kind's testbench: every answer's latency, cold and warm) on the small core at P = 1, and in a
             full run on masses at P = 1 too (the masses core at its default P is too big to simulate here);
  units      FMul, FAdd, FDiv, FSqrt instances of the generated SystemVerilog under the Stage 1 engine and the MINRES
             core, beside Table I of 001 (Stage 1 3i, linear solver 4M + 24);
  resources  Yosys synth_ecp5 (MULT18X18D, LUT4, FF, DP16KD; fit on the LFE5U-85F) on the small core at P = 1, and in
             a full run synth_xilinx xc7 on it and both on masses at P = 1 in binary32 and at its default P in
             e8m17 with the fast operator latencies and TARGET=ecp5 (the masses core that fits the part; no xc7:
             its products are MULT18X18D instances, mpc_bench.tools.xc7_applies);
  Fmax       nextpnr-ecp5 on the LFE5U-85F (speed 8, constraints/ipm_core.lpf) for the cores that fit (the masses
             core with PLACER_ARGS, the median of seeds 1, 2 and 3);
  software   OSQP (default and tuned), PIQP and Clarabel on the QPs of the masses closed loop under the core's
             bit-exact model, against the core's latency at that Fmax (an estimate for the cores not placed) and at
             001's 150 MHz.

QUICK: generation, the small core's Verilator run, one software replay before and one after; the small core's Yosys
ECP5 and nextpnr results only when a run before cached them for the same SystemVerilog (mpc_bench.tools.is_cached). Formulas, records and report lines: mpc_bench.ipm_report. Alone it
writes ipm.csv and ipm_report.md:

    python -m mpc_bench.ipm [--quick] [--out build/bench] [--jobs 2] [--no-xilinx] [--no-place] [--repeats R]
"""
from __future__ import annotations

import argparse
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mpc_bench import section
from mpc_bench.baselines import OSQP_DEFAULT, OSQP_TUNED, OsqpWarm, SwCase, _optimal_u0
from mpc_bench.ipm_report import ipm_rows, ipm_section, summary_table
from mpc_bench.minres import MASSES, SMALL, small_problem, synth_ecp5
from mpc_bench.minres_report import float_units
from mpc_bench.qp import QpSection
from mpc_bench.report import write_alone
from mpc_bench.tools import (FMAX_SEEDS, PLACER_ARGS, Job, Log, ToolResults, is_cached, run_cycle_test, synth_xc7,
                             xc7_applies)
from mpc_cores.flow import REPO

# the masses closed loop the software solvers replay (mpc_cores.ipm.study.loop)
STEPS_FULL, STEPS_QUICK, HOLD = 60, 20, 20


# ----------------------------------------------------------------------------------------- one core

@dataclass
class IpmCore(ToolResults):
    """One generated interior-point core and what the bench does with it: `simulate` (the latency test in
    Verilator), `synth` (Yosys ECP5, and xc7 when the run has it), `place` (nextpnr when it fits)."""
    problem: str
    out: Path
    design: object               # mpc_cores.ipm.design.IpmDesign
    role: str                    # "masses" (default design), "masses_p1", "masses_e8m17_fast", "small", "small_p1"
    kind: str = "ipm"
    simulate: bool = False
    synth: bool = False
    place: bool = False
    units: dict = field(default_factory=dict)     # part ("stage1", "minres", "total") -> {FMul: .., ...}
    compares: int | None = None

    @property
    def P(self) -> int:
        return self.core.get("P") or self.design.P

    @property
    def tag(self) -> str:
        fmt = (self.core or {}).get("format") or (self.design.format if self.design else "binary32")
        fast = self.design is not None and self.design.md.latency != "compact"
        target = self.design.md.target if self.design is not None else "generic"
        return f"IPM {self.problem} P={self.P or 'eq15'}" + ("" if fmt == "binary32" else f" {fmt}") + \
            (f" {self.design.md.latency}" if fast else "") + ("" if target == "generic" else f" {target}")

    @property
    def placeable(self) -> bool:
        return self.place

    @property
    def hierarchical(self) -> bool:
        return False


def count_units(c: IpmCore) -> None:
    """Floating-point operators of the generated SystemVerilog: the whole core, its Stage 1 engine and its MINRES
    core (instantiated as <module>_<part module>), and the comparator instances."""
    sv, top = c.sv.read_text(), c.module
    c.units = {"total": float_units(sv, top),
               "stage1": float_units(sv, f"{top}_{c.core['stage1_module']}"),
               "minres": float_units(sv, f"{top}_{c.core['minres_module']}")}
    c.compares = len(re.findall(r"^\s*\w*_FCompare_\w+\s+\w+\s*\(", sv, re.MULTILINE))


def measure_latency(c: IpmCore, test: str, log) -> None:
    """Every answer's latency in Verilator (the kind's cycle test); the records are compared with core.json in
    mpc_bench.ipm_report.ipm_rows."""
    rec = next((r for r in run_cycle_test(c, test) if r.get("test") == test), None)
    if rec is None:
        raise RuntimeError(f"{test} wrote no latency record: see {c.out / 'sim' / 'sim.log'}")
    c.measured = rec
    warm = max(rec["rounds"]["1"]["latency"].values())
    same = "equals" if warm == c.core["latency_cycles"] else "DIFFERS from"
    log(f"{c.tag}: measured latency {warm} cycles for 2P back to back, {same} core.json "
        f"{c.core['latency_cycles']} ({c.seconds['verilator']:.0f} s)")


# ----------------------------------------------------------------------------------------- software

class PiqpDense:
    """PIQP (proximal interior point, dense backend) on the condensed QP, set up once; each solve updates the linear
    term c = Phi w (an interior-point method: no warm start)."""

    def __init__(self, qp, name: str = "PIQP dense"):
        import piqp

        self.name, self.Phi = name, qp.Phi
        self.solver = piqp.DenseSolver()
        self.solver.settings.verbose = False
        self.solver.setup(np.asfortranarray(qp.H), np.zeros(qp.n), x_l=np.array(qp.lb, dtype=float),
                          x_u=np.array(qp.ub, dtype=float))
        st = self.solver.settings
        self.settings = f"eps_abs = {st.eps_abs:g}, eps_rel = {st.eps_rel:g} (defaults), box as x_l / x_u"
        self.iters: list[int] = []

    def solve(self, w: np.ndarray) -> np.ndarray:
        self.solver.update(c=self.Phi @ w)
        self.solver.solve()
        self.iters.append(int(self.solver.result.info.iter))
        return np.array(self.solver.result.x)


class ClarabelQp:
    """Clarabel (interior point, homogeneous embedding) on the condensed QP with the box as 2n nonnegative-cone rows,
    set up once; each solve updates q = Phi w."""

    def __init__(self, qp, name: str = "Clarabel"):
        import clarabel
        import scipy.sparse as sp

        self.name, self.Phi = name, qp.Phi
        n = qp.n
        st = clarabel.DefaultSettings()
        st.verbose = False
        A = sp.vstack([sp.identity(n), -sp.identity(n)], format="csc")
        b = np.concatenate([np.array(qp.ub, dtype=float), -np.array(qp.lb, dtype=float)])
        self.solver = clarabel.DefaultSolver(sp.triu(sp.csc_matrix(qp.H), format="csc"), np.zeros(n), A, b,
                                             [clarabel.NonnegativeConeT(2 * n)], st)
        self.settings = f"tol_gap_abs = {st.tol_gap_abs:g}, tol_feas = {st.tol_feas:g} (defaults)"
        self.iters: list[int] = []

    def solve(self, w: np.ndarray) -> np.ndarray:
        self.solver.update(q=self.Phi @ w)
        sol = self.solver.solve()
        self.iters.append(int(sol.iterations))
        return np.array(sol.x)


def software_case(problem, d, steps: int, hold: int) -> SwCase:
    """The masses closed loop under the core's bit-exact model (its QPs (x, r), its error against OSQP at eps 1e-9,
    its closed-loop cost against OSQP's optimum) and the software solvers."""
    from mpc_cores.closedloop import run_closed_loop
    from mpc_cores.ipm.control import IpmModelController
    from mpc_cores.ipm.study import loop, optimal_cost
    from mpc_cores.problem import condense

    refs, x0 = loop(problem, steps, hold)
    tr = run_closed_loop(problem, IpmModelController(d), x0, refs)
    W = np.hstack([tr.x[:-1], refs])
    qp = condense(problem)
    u_opt = _optimal_u0(problem, qp, W)
    err = np.abs(tr.u - u_opt).max(axis=1)
    makers = [lambda: OsqpWarm(qp, "OSQP default", OSQP_DEFAULT), lambda: OsqpWarm(qp, "OSQP tuned", OSQP_TUNED),
              lambda: PiqpDense(qp), lambda: ClarabelQp(qp)]
    return SwCase("ipm", W, u_opt, problem.nu, makers, {
        "core_err": (float(err.max()), float(np.median(err))), "steps": steps, "hold": hold,
        "cost_rel": tr.cost / optimal_cost(problem, steps, hold) - 1.0})


# ----------------------------------------------------------------------------------------- the section

class Section(QpSection):
    name, label = "ipm", "IPM"
    appendix = True

    def configure(self, a) -> None:
        super().configure(a)
        self.repeats = getattr(a, "repeats", None) or (2 if a.quick else 6)
        self.place = not getattr(a, "no_place", False)
        self.steps = STEPS_QUICK if a.quick else STEPS_FULL

    def log_text(self) -> str:
        return "IPM masses (default P" + ("" if self.quick else "; P = 1 simulated and synthesised") + \
            f"), {SMALL['name']} P = 1"

    def plan(self) -> None:
        from mpc_cores.ipm.design import design_ipm
        from mpc_cores.problem import load_spec

        root = Path(self.run.out).resolve() / "ipm"
        masses, small = load_spec(MASSES), small_problem()
        self.problem = masses
        full = not self.quick
        plan = [(masses, None, "masses", {}, None, None), (small, None, "small", {}, None, None),
                (small, 1, "small_p1", dict(simulate=True, synth=True, place=self.place), None, None)]
        if full:
            # masses: at P = 1 in binary32 (simulated; too big for the part), and the core for the part: e8m17 with
            # the fast operator latencies at its default P (eq. (15)), TARGET=ecp5 (the memories' DP16KD with their
            # output register), placed with a stronger timing weight
            plan += [(masses, 1, "masses_p1", dict(simulate=True, synth=True), None, None),
                     (masses, None, "masses_e8m17_fast",
                      dict(synth=True, place=self.place, pnr_args=PLACER_ARGS, pnr_seeds=FMAX_SEEDS), "e8m17", "fast")]
        for p, P, role, steps, fmt, lat in plan:
            target = "ecp5" if lat == "fast" else None
            d = design_ipm(p, P=P, format=fmt, latency=lat, target=target)
            if role == "masses":
                self.designs[p.name] = d
            folder = f"{p.name}_{f'p{P}' if P else 'default'}" + (f"_{fmt}" if fmt else "") + (f"_{lat}" if lat else "") \
                + (f"_{target}" if target else "")
            self.cores.append(IpmCore(p.name, root / "cores" / folder, d, role, **steps))
        self.plan_text = (f"Cores: masses at its default P (cycles from core.json), {small.name} (n = {small.nx}, "
                          f"m = {small.nu}, T = {small.N}) at its default P and at P = 1 (Verilator, Yosys ECP5"
                          f"{', xc7' if self.xilinx else ''}, nextpnr{'' if self.place else ' off'}"
                          + ("); masses at P = 1 (Verilator, Yosys) and in e8m17 with the fast latencies at its "
                             "default P (Yosys, nextpnr)." if full else
                             " from the cache only); QUICK: masses not simulated or synthesised."))
        self.log("IPM: " + self.plan_text)

    def software_case(self) -> SwCase:
        return software_case(self.problem, self.designs[self.problem.name], self.steps, HOLD)

    def generation_failed(self, e: Exception) -> None:
        self.error(f"IPM generation: {e}")
        self.log(f"FAILED IPM generation: {e}")
        self.cores = [c for c in self.cores if c.core]

    def jobs(self) -> list[Job]:
        """Rough seconds on a 2-core machine (longest first): Verilator in wave 0, the syntheses in wave 1."""
        from mpc_cores import registry

        test = registry.get("ipm").cycle_test
        log, out = self.run.log, []
        for c in self.cores:
            count_units(c)
            big = c.role.startswith("masses")
            if self.quick and c.synth:
                # QUICK: Yosys and nextpnr only where their results for this SystemVerilog are cached
                c.synth, c.place = is_cached(c, "ecp5"), c.place and is_cached(c, "nextpnr")
                if not c.synth:
                    c.pnr_note = "QUICK: no cached Yosys result for this SystemVerilog (a full run makes one)"
                    log(f"{c.tag}: {c.pnr_note}")
            if c.simulate:
                out.append(Job(300 if big else 60, f"{c.tag} verilator", lambda c=c: measure_latency(c, test, log)))
            if c.synth:
                out.append(Job(1500 if big else 600, f"{c.tag} ecp5", lambda c=c: synth_ecp5(c, log), wave=1))
                if self.xilinx and xc7_applies(c):
                    out.append(Job(900 if big else 300, f"{c.tag} xc7", lambda c=c: synth_xc7(c, log), wave=1))
            elif not c.pnr_note:
                c.pnr_note = "not synthesised in this run"
        return out

    def make_rows(self) -> list[dict]:
        return ipm_rows(self.cores, self.sw)

    def finish(self) -> None:
        super().finish()
        self.log(f"IPM part done in {self.elapsed / 60:.1f} min")

    # ------------------------------------------------------------------------------------- outputs

    def appendix_md(self) -> list[str]:
        if not self.rows:
            return []
        info = {"errors": self.errors, "runtime_s": self.elapsed, "plan_text": getattr(self, "plan_text", "")}
        return ipm_section(self.cores, self.rows, self.sw, info)

    def console_summary(self) -> list[str]:
        if not self.rows:
            return []
        L = ["Interior-point core (Algorithm 1 of 001, binary32)", "", *summary_table(self.rows)]
        m = next((r for r in self.rows if r["role"] == "masses"), None)
        if self.sw and m:
            L += ["", f"Software on the {self.sw['steps']}-step masses loop (median us per solve; core error max "
                  f"{self.sw['core_err'][0]:.1e}, closed-loop cost {self.sw['cost_rel']:+.1e} vs optimum):"]
            L += [f"  {s.name}: {s.median_us:.1f} us" for s in self.sw["solvers"]]
        return L


def main(argv=None) -> None:
    """The interior-point section alone: ipm.csv and ipm_report.md in --out."""
    ap = argparse.ArgumentParser(prog="python -m mpc_bench.ipm", description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="no masses core in Verilator or Yosys, no Xilinx, a "
                    f"{STEPS_QUICK}-step software loop")
    ap.add_argument("--out", default=str(REPO / "build/bench"))
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--no-xilinx", action="store_true")
    ap.add_argument("--no-place", action="store_true", help="no nextpnr")
    ap.add_argument("--repeats", type=int, default=None, help="software replays, half before and half after")
    a = ap.parse_args(argv)
    out = Path(a.out).resolve()
    log = Log()
    run = section.Run(a, out, log, {"errors": [], "sw_seconds": {}})
    sec = Section(run)
    section.run_sections([sec], run)
    write_alone(sec, out, "ipm", "interior-point core", a.quick, log)


if __name__ == "__main__":
    main()
