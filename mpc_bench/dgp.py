"""DGP section of the benchmark (`make bench`; also alone: `python -m mpc_bench.dgp`).

The dual gradient projection core (iteration (35) of 003, fixed point) on examples/masses_state.yaml (n = 40, 80
two-sided rows: the input box and the position limits at stages 1..N, 160 one-sided) for the ECP5 (TARGET=ecp5,
every product on MULT18X18D partial products), in both forms: accelerated (the spec's default) and plain; and the
accelerated form on P = 2 row units of 20 lanes at 15 fraction bits (ROLE_OPTIONS), the core that fits the device
with room to spare, without and with the shifted warm start (roles units and shifted), and the shifted core with its
dual and bounds in block RAM (role ram: ram_state, word- and cycle-identical to shifted).

  cycles      per iteration and the solve overhead of core.json, measured in Verilator (cocotb test `cycle_contract`
              of verif.dgp.tb, which asserts the answer's cycle overhead + I x cycles_per_iteration);
  resources   Yosys synth_ecp5 (MULT18X18D, LUT4, FF, DP16KD) and the fit on the LFE5U-85F; synth_xilinx xc7 in a
              full run on the cores not generated for TARGET=ecp5 (mpc_bench.tools.xc7_applies: none of these);
  Fmax        nextpnr-ecp5 on the LFE5U-85F (speed 8, constraints/dgp_core.lpf) for the cores that fit, seeds
              FMAX_SEEDS (QUICK: FMAX_SEEDS_QUICK);
  iterations  a closed loop of masses_state under the accelerated core's bit-exact model (mpc_cores.dgp.control: warm
              start, the design's Imax), each core's model on the same parameter words in sequence (warm or cold as
              its design starts: the plain form starts cold), and random states of the accepted box from a cold
              start: iterations to the stopping test (median, p99, max), latency in cycles (overhead + I x
              cycles_per_iteration) and in us at the placed Fmax;
  software    OSQP (warm start), DAQP (hot start, every row a general constraint lo <= G z <= hi) and Clarabel on the
              same QPs (the state-constrained QP of mpc_cores.dgp.problem at the parameters the core used after
              its input saturation), single-threaded on one pinned CPU: median and p99 time per solve, the error
              max |u0 - u0*|, and the ratios of their times to the core's latency and throughput.

QUICK: generation, the cores in Verilator, a shorter loop and fewer random states; Yosys and nextpnr results only
when a run before cached them for the same SystemVerilog (mpc_bench.tools.is_cached). Records and report lines:
mpc_bench.dgp_report. Alone it writes dgp.csv and dgp_report.md:

    python -m mpc_bench.dgp [--quick] [--out build/bench] [--jobs 2] [--no-xilinx] [--no-place] [--repeats R]

In `make bench` the option --dgp-no-place leaves out nextpnr (Section.add_arguments).
"""
from __future__ import annotations

import argparse
import datetime
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from mpc_bench import section
from mpc_bench.baselines import SwCase
from mpc_bench.dgp_report import dgp_rows, dgp_section, summary_lines
from mpc_bench.parsers import ECP5_85F, ecp5_resources
from mpc_bench.qp import QpSection
from mpc_bench.qp_solvers import Clarabel
from mpc_bench.report import write_alone
from mpc_bench.tools import (
    FMAX_SEEDS, FMAX_SEEDS_QUICK, Job, Log, ToolResults, cached_design, is_cached, run_cycle_test, run_yosys,
    synth_ecp5_and_pnr, synth_xc7, xc7_applies,
)
from mpc_cores.flow import REPO

SPEC = REPO / "examples/masses_state.yaml"
TARGET = "ecp5"
# the roles: the spec's default design in both forms (P = 1, 8 lanes, the fraction bits of (36)), the Fmax core
# of row units (accelerated, P row units of `lanes` each, 15 fraction bits: the loop meets the same iterations and
# accuracy as at (36)'s 27 bits, and every product fits two MULT18X18D), that core with the shifted warm start, and
# the shifted core with the dual and the bounds in block RAM (ram_state)
ROLES = ("accelerated", "plain", "units", "shifted", "ram")
_UNITS = dict(accelerated=True, P=2, lanes=20, frac_bits=15)
ROLE_OPTIONS = {"accelerated": dict(accelerated=True), "plain": dict(accelerated=False), "units": _UNITS,
                "shifted": dict(_UNITS, warm_shift=True), "ram": dict(_UNITS, warm_shift=True, ram_state=True)}
# the roles nextpnr places in a full run (QUICK: from the cache): the spec's default designs at 27 fraction bits
# fill most of the device's logic and route for hours, so only --dgp-place-all places them
PLACED = ("units", "shifted", "ram")
# The closed loop (mpc_cores.closedloop.reference_schedule: references held `HOLD` steps, their steady-state input
# inside mpc_cores.dgp.control.HOLDABLE of the input box) and the random states of the cold start.
STEPS_FULL, STEPS_QUICK, HOLD, SEED = 200, 60, 5, 1
COLD_FULL, COLD_QUICK = 500, 100


# ----------------------------------------------------------------------------------------- one core

@dataclass
class DgpBenchCore(ToolResults):
    """One generated DGP core and what the bench does with it: the cycle contract in Verilator, `synth` (Yosys
    ECP5, and xc7 when the run has it), `place` (nextpnr when it fits)."""
    problem: str
    out: Path
    design: object               # mpc_cores.dgp.design.DgpDesign
    role: str                    # "accelerated" or "plain"
    kind: str = "dgp"
    synth: bool = True
    place: bool = True

    @property
    def tag(self) -> str:
        d = self.design
        return f"DGP {self.problem} {self.role} P={d.P} lanes={d.lanes} b={d.b}"

    @property
    def mult18(self) -> int:
        """MULT18X18D the products take on the ECP5 (mpc_cores.target.dsp_count)."""
        from mpc_cores.dgp.report import _counts
        from mpc_cores.target import dsp_count

        d = self.design
        return dsp_count("ecp5", d.products(), _counts(d))

    @property
    def placeable(self) -> bool:
        return self.mult18 <= ECP5_85F["MULT18X18D"]

    @property
    def hierarchical(self) -> bool:
        return False


def measure_cycles(c: DgpBenchCore, test: str, log) -> None:
    """The cycle contract in Verilator: the testbench asserts every answer's cycle against core.json and records
    the cycles per iteration (read from the core's CYCLES_PER_ITER) and the overhead."""
    rec = next((r for r in run_cycle_test(c, test) if r.get("test") == test), None)
    if rec is None:
        raise RuntimeError(f"{test} wrote no record: see {c.out / 'sim' / 'sim.log'}")
    c.measured = rec
    same = (rec["cycles_per_iteration"] == c.core["cycles_per_iteration"]
            and rec["overhead"] == c.core["solve_overhead_cycles"])
    log(f"{c.tag}: measured {rec['overhead']} + I x {rec['cycles_per_iteration']} cycles, "
        f"{'equal to' if same else 'DIFFERENT from'} core.json ({c.seconds['verilator']:.0f} s)")


def synth_ecp5(c: DgpBenchCore, log) -> None:
    """synth_ecp5 and the fit on the LFE5U-85F (hard blocks, LUT4, FF); then nextpnr when the core is to be placed
    and fits (mpc_bench.tools.synth_ecp5_and_pnr reuses the cached synthesis)."""
    from mpc_bench.minres import logic_fit

    cells, c.ecp5_mem = run_yosys(c, "ecp5", log)
    c.ecp5 = ecp5_resources(cells)
    over = logic_fit(c.ecp5)
    if over:
        c.pnr_note = "does not fit: " + "; ".join(over)
        log(f"{c.tag}: no place and route, {c.pnr_note}")
    elif c.place:
        synth_ecp5_and_pnr(c, log)


# ----------------------------------------------------------------------------------------- the QPs and the loop

class StateQp:
    """The state-constrained QP of mpc_cores.dgp.problem in its own units (the core's row scaling sigma undone):
    min 1/2 z'Q z + (Phi w)'z subject to lo(w) <= G z <= hi(w)."""

    def __init__(self, qp):
        s = qp.sigma
        self.Q, self.Phi, self.G = np.asarray(qp.Q, dtype=float), np.asarray(qp.Phi, dtype=float), qp.G / s
        self.lo0, self.hi0, self.Lw = qp.lo0 / s, qp.hi0 / s, qp.Lw / s
        self.n, self.mc = self.Q.shape[0], self.G.shape[0]

    def q(self, w: np.ndarray) -> np.ndarray:
        return self.Phi @ w

    def bounds(self, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        c = self.Lw @ w
        return self.lo0 + c, self.hi0 + c


class OsqpState:
    """OSQP set up once; each solve updates q(w), lo(w) and hi(w) and starts from the previous solution (the
    library's warm_starting, on by default)."""
    name, timer = "OSQP warm", "info update_time + solve_time + polish_time"

    def __init__(self, sq: StateQp, settings: dict | None = None):
        import osqp

        self.sq = sq
        lo, hi = sq.bounds(np.zeros(sq.Phi.shape[1]))
        self.solver = osqp.OSQP()
        self.solver.setup(P=sp.triu(sp.csc_matrix(sq.Q), format="csc"), q=np.zeros(sq.n), A=sp.csc_matrix(sq.G),
                          l=lo, u=hi, verbose=False, **(settings or {}))
        st = self.solver.settings
        self.settings = ", ".join(f"{k} = {getattr(st, k)}" for k in (
            "eps_abs", "eps_rel", "polishing", "warm_starting", "adaptive_rho")) + " (defaults)"
        self.iters: list[int] = []

    def solve(self, w: np.ndarray):
        lo, hi = self.sq.bounds(w)
        self.solver.update(q=self.sq.q(w), l=lo, u=hi)
        res = self.solver.solve(raise_error=False)
        i = res.info
        self.iters.append(int(i.iter))
        return res.x, i.update_time + i.solve_time + i.polish_time


class DaqpState:
    """DAQP (dual active set) set up once with the mc rows as general constraints lo <= G z <= hi; each solve
    updates the linear term and both bounds (Model.update(f, bupper, blower)), which keeps the working set of the
    previous solve with its factors: the solve starts from it (hot start)."""
    name, timer = "DAQP hot start", "info solve_time (the solve, not the update)"

    def __init__(self, sq: StateQp):
        import daqp

        self.sq = sq
        lo, hi = sq.bounds(np.zeros(sq.Phi.shape[1]))
        self.model = daqp.Model()
        # DAQP keeps pointers into the arrays it is given: copies of its own
        ok, _ = self.model.setup(np.array(sq.Q, order="C"), np.zeros(sq.n), np.array(sq.G, order="C"),
                                 hi.copy(), lo.copy())
        if ok < 0:
            raise RuntimeError(f"DAQP setup failed: exit flag {ok}")
        st = self.model.settings
        self.settings = (f"primal_tol = {st['primal_tol']:g}, dual_tol = {st['dual_tol']:g} (defaults), {sq.mc} "
                         "general rows, working set kept between solves")
        self.iters: list[int] = []

    def solve(self, w: np.ndarray):
        lo, hi = self.sq.bounds(w)
        self.model.update(f=self.sq.q(w), bupper=hi, blower=lo)
        x, _, flag, info = self.model.solve()
        if flag < 0:
            raise RuntimeError(f"DAQP failed: exit flag {flag}")
        self.iters.append(int(info["iterations"]))
        return x, info["solve_time"]


class ClarabelState(Clarabel):
    """Clarabel (interior point) set up once with the rows as 2 mc nonnegative-cone rows [G; -G] z <= [hi; -lo];
    each solve updates q and b. Own time: mpc_bench.qp_solvers.Clarabel's (solve_time less the set-up and the
    earlier solves' post-processing)."""
    name = "Clarabel"

    def __init__(self, sq: StateQp):
        import clarabel

        self.sq = sq
        lo, hi = sq.bounds(np.zeros(sq.Phi.shape[1]))
        st = clarabel.DefaultSettings()
        st.verbose, st.max_threads = False, 1
        A = sp.vstack([sp.csc_matrix(sq.G), -sp.csc_matrix(sq.G)], format="csc")
        self.solver = clarabel.DefaultSolver(sp.triu(sp.csc_matrix(sq.Q), format="csc"), np.zeros(sq.n), A,
                                             np.concatenate([hi, -lo]), [clarabel.NonnegativeConeT(2 * sq.mc)], st)
        self.settings = (f"tol_gap_abs = {st.tol_gap_abs:g}, tol_feas = {st.tol_feas:g} (defaults), max_threads = 1, "
                         f"{2 * sq.mc} inequality rows")
        self.iters: list[int] = []
        self.post = 0.0

    def solve(self, w: np.ndarray):
        lo, hi = self.sq.bounds(w)
        self.solver.update(q=self.sq.q(w), b=np.concatenate([hi, -lo]))
        sol = self.solver.solve()
        self.iters.append(int(sol.iterations))
        total = sol.solve_time
        return np.array(sol.x), lambda: self._own(total)


SOLVERS = (("osqp", OsqpState), ("daqp", DaqpState), ("clarabel", ClarabelState))


def solver_makers(sq: StateQp) -> tuple[list, list[str]]:
    """Makers of the installed solvers, and the names of those whose package is missing."""
    import importlib.util

    have = [(m, cls) for m, cls in SOLVERS if importlib.util.find_spec(m) is not None]
    return [lambda cls=cls: cls(sq) for _, cls in have], [cls.name for m, cls in SOLVERS if (m, cls) not in have]


@dataclass
class DgpLoop:
    """The QPs of the closed loop and what the cores' bit-exact models do on them and on random states."""
    W: np.ndarray                # (steps, nw) the parameters the core used (its words after saturation, / 2^b)
    u_opt: np.ndarray            # (steps, nu) the optimal first input of each QP (OSQP, eps 1e-9)
    iters: dict                  # role -> iterations run per loop step
    met: dict                    # role -> stopping test met per loop step
    core_err: dict               # role -> (max, median) over the loop of |u0 - u0*|_inf
    cold_iters: dict             # role -> iterations run per random state, cold
    cold_met: dict               # role -> stopping test met per random state
    meta: dict                   # steps, hold, seed, states, sat_steps, lead (the role in the loop), imax and warm
                                 # (the design's warm start) per role
    zero: dict = field(default_factory=dict)        # role -> zero start (the starting dual all zero) per loop step
    cold_zero: dict = field(default_factory=dict)   # role -> zero start per random state (cold: all)


def closed_loop(designs: dict, steps: int, hold: int, seed: int, states: int) -> DgpLoop:
    """The closed loop of the problem under the accelerated core's golden controller (mpc_cores.dgp.control: the
    bit-exact model, warm start, the design's Imax, its u0 applied to the nominal plant; references of
    mpc_cores.closedloop.reference_schedule held `hold` steps); every core's model on the same parameter words in
    sequence (warm or cold as its design starts); every core from a cold start on `states` random states of the
    accepted box (random references in the reference box)."""
    from mpc_cores.closedloop import reference_schedule, run_closed_loop
    from mpc_cores.dgp.control import controllers
    from mpc_cores.dgp.model import DgpFixed
    from mpc_cores.dgp.problem import solve_osqp
    from mpc_cores.fixed import quantize

    lead_role = "accelerated" if "accelerated" in designs else next(iter(designs))
    lead = designs[lead_role]
    p, b = lead.problem, lead.b
    _, golden, holdable = controllers(lead)
    run_closed_loop(p, golden, np.zeros(p.nx), reference_schedule(p, steps, hold, seed, holdable))
    W = np.array(golden.w, dtype=float) / float(1 << b)
    u_opt = np.zeros((steps, p.nu))
    for k, w in enumerate(W):
        z, _, _, st = solve_osqp(lead.qp, w, eps=1e-9)
        if st != "solved":
            raise RuntimeError(f"the QP of loop step {k} has no solution (OSQP: {st})")
        u_opt[k] = z[: p.nu]
    rng = np.random.default_rng(seed)
    Wc = np.array([np.concatenate([rng.uniform(p.xmin, p.xmax), rng.uniform(p.rmin, p.rmax)]) for _ in range(states)])
    out = DgpLoop(W, u_opt, {}, {}, {}, {}, {}, {"steps": steps, "hold": hold, "seed": seed, "states": states,
                                                 "sat_steps": golden.sat_steps, "lead": lead_role, "imax": {},
                                                 "warm": {}})
    for role, d in designs.items():
        m = DgpFixed(d)
        its, met, u, zero = [], [], [], []
        for w in W:
            r = m.solve(quantize(w, d.b))
            its.append(int(r.iterations[0]))
            met.append(bool(r.met[0]))
            zero.append(bool(r.zero_start[0]))
            u.append(r.z[0][: p.nu] / float(1 << d.b))
        if role == lead_role and its != list(golden.iterations):
            raise RuntimeError("the golden model replayed on the loop's parameter words runs other iterations than "
                               "in the loop")
        err = np.abs(np.array(u) - u_opt).max(axis=1)
        out.iters[role], out.met[role], out.zero[role] = np.array(its), np.array(met), np.array(zero)
        out.core_err[role] = (float(err.max()), float(np.median(err)))
        rc = m.solve_batch(quantize(Wc, d.b))
        out.cold_iters[role], out.cold_met[role] = rc.iterations.copy(), rc.met.copy()
        out.cold_zero[role] = rc.zero_start.copy()
        out.meta["imax"][role], out.meta["warm"][role] = d.iterations, bool(d.warm_start)
    return out


# ----------------------------------------------------------------------------------------- the section

class Section(QpSection):
    name, label = "dgp", "DGP"
    appendix = True

    def __init__(self, run=None):
        self.loop: DgpLoop | None = None
        super().__init__(run)

    @staticmethod
    def add_arguments(ap: argparse.ArgumentParser) -> None:
        ap.add_argument("--dgp-place-all", action="store_true",
                        help="DGP: place the spec's default designs too (hours per seed), not only the row-unit core")
        ap.add_argument("--dgp-seeds", default=None,
                        help="DGP: comma-separated nextpnr seeds of a full run (default "
                             f"{','.join(map(str, FMAX_SEEDS))}; QUICK takes the cache's)")
        ap.add_argument("--dgp-no-place", action="store_true",
                        help="DGP: Yosys resources only, no nextpnr (the accelerated masses_state core nearly "
                             "fills the LFE5U-85F and routes slowly)")

    def configure(self, a) -> None:
        super().configure(a)
        self.repeats = getattr(a, "repeats", None) or (2 if a.quick else 6)
        self.place = not (getattr(a, "no_place", False) or getattr(a, "dgp_no_place", False))
        self.place_all = bool(getattr(a, "dgp_place_all", False))
        seeds = getattr(a, "dgp_seeds", None)
        try:
            self.seeds = tuple(int(x) for x in seeds.split(",")) if seeds else FMAX_SEEDS
        except ValueError:
            raise SystemExit(f"--dgp-seeds must be comma-separated integers: got {seeds!r}") from None
        self.steps = STEPS_QUICK if a.quick else STEPS_FULL
        self.states = COLD_QUICK if a.quick else COLD_FULL
        self.date = self.run.info.get("date") or datetime.datetime.now(datetime.timezone.utc).strftime(
            "%Y-%m-%d %H:%M UTC")

    def log_text(self) -> str:
        return "DGP masses_state accelerated, plain and on row units (ECP5)"

    def plan(self) -> None:
        from mpc_cores.dgp.design import design_dgp
        from mpc_cores.errors import DesignError
        from mpc_cores.problem import load_spec

        root = Path(self.run.out).resolve() / "dgp"
        problem, spec = load_spec(SPEC), SPEC.read_bytes()
        seeds = FMAX_SEEDS_QUICK if self.quick else self.seeds
        for role in ROLES:
            tag = f"{problem.name}_{role}_{TARGET}"
            try:
                d = cached_design(self.design_dir, f"dgp_{tag}", ("dgp", spec, role, TARGET, ROLE_OPTIONS[role]),
                                  lambda role=role: design_dgp(problem, target=TARGET, **ROLE_OPTIONS[role]))
            except DesignError as e:
                self.error(f"DGP {role}: design refused: {e}")
                continue
            self.designs[role] = d
            place = self.place and (role in PLACED or self.place_all)
            self.cores.append(DgpBenchCore(problem.name, root / "cores" / tag, d, role, place=place,
                                           pnr_seeds=seeds))
        self.plan_text = (f"Cores: {problem.name} accelerated and plain, TARGET={TARGET} (Verilator, Yosys ECP5"
                          f"{', xc7' if self.xilinx else ''}, nextpnr{'' if self.place else ' off'}"
                          + (" from the cache only)." if self.quick else
                             f", seeds {', '.join(map(str, seeds))}).") + f" Closed loop of {self.steps} steps, "
                          f"{self.states} random states cold.")
        self.log("DGP: " + self.plan_text)

    def software_case(self) -> SwCase:
        self.loop = closed_loop(self.designs, self.steps, HOLD, SEED, self.states)
        d = self.designs.get("accelerated") or next(iter(self.designs.values()))
        makers, missing = solver_makers(StateQp(d.qp))
        return SwCase("dgp", self.loop.W, self.loop.u_opt, d.nu, makers, {"missing": missing})

    def generation_failed(self, e: Exception) -> None:
        self.error(f"DGP generation: {e}")
        self.log(f"FAILED DGP generation: {e}")
        self.cores = [c for c in self.cores if c.core]

    def jobs(self) -> list[Job]:
        """Rough seconds on a 2-core machine (longest first): Verilator in wave 0, the syntheses in wave 1."""
        from mpc_cores import registry

        test = registry.get("dgp").cycle_test
        log, out = self.run.log, []
        for c in self.cores:
            hours = "not placed: the spec's default design routes for hours (--dgp-place-all places it)"
            if self.quick:
                # QUICK: Yosys and nextpnr results only where they are cached for this SystemVerilog (the row-unit
                # core's routing time on the LFE5U-85F is not known to fit QUICK's budget)
                wanted = c.place
                c.synth, c.place = is_cached(c, "ecp5"), c.place and is_cached(c, "nextpnr")
                if not c.synth:
                    c.pnr_note = "QUICK: no cached Yosys result for this SystemVerilog (a full run makes one)"
                elif not c.place:
                    c.pnr_note = ("QUICK: no cached place and route for this netlist (a full run makes one)" if wanted
                                  else hours if self.place else "not placed (--dgp-no-place)")
                if c.pnr_note:
                    log(f"{c.tag}: {c.pnr_note}")
            elif not c.place:
                c.pnr_note = "not placed (--dgp-no-place)" if not self.place else hours
            out.append(Job(60, f"{c.tag} verilator", lambda c=c: measure_cycles(c, test, log)))
            if c.synth:
                # Yosys about 260 s on the accelerated core; nextpnr over 40 min per seed on the default designs
                pnr = (900 if c.role in PLACED else 3600) * len(c.pnr_seeds) if c.place else 0
                out.append(Job(300 + pnr, f"{c.tag} ecp5", lambda c=c: synth_ecp5(c, log), wave=1))
                if self.xilinx and xc7_applies(c):
                    out.append(Job(600, f"{c.tag} xc7", lambda c=c: synth_xc7(c, log), wave=1))
        return out

    def make_rows(self) -> list[dict]:
        return dgp_rows(self.cores, self.loop, self.sw)

    def finish(self) -> None:
        super().finish()
        self.log(f"DGP part done in {self.elapsed / 60:.1f} min")

    # ------------------------------------------------------------------------------------- outputs

    def appendix_md(self) -> list[str]:
        if not self.rows:
            return []
        info = {"errors": self.errors, "runtime_s": self.elapsed, "plan_text": getattr(self, "plan_text", ""),
                "date": getattr(self, "date", ""), "quick": getattr(self, "quick", False)}
        return dgp_section(self.cores, self.rows, self.loop, self.sw, info)

    def console_summary(self) -> list[str]:
        return summary_lines(self.rows, self.sw) if self.rows else []


def main(argv=None) -> None:
    """The DGP section alone: dgp.csv and dgp_report.md in --out."""
    ap = argparse.ArgumentParser(prog="python -m mpc_bench.dgp", description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help=f"Yosys and nextpnr from the cache only, no Xilinx, a "
                    f"{STEPS_QUICK}-step loop and {COLD_QUICK} random states")
    ap.add_argument("--out", default=str(REPO / "build/bench"))
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--no-xilinx", action="store_true")
    ap.add_argument("--no-place", action="store_true", help="no nextpnr (as --dgp-no-place)")
    Section.add_arguments(ap)
    ap.add_argument("--repeats", type=int, default=None, help="software replays, half before and half after")
    a = ap.parse_args(argv)
    out = Path(a.out).resolve()
    log = Log()
    date = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    run = section.Run(a, out, log, {"errors": [], "sw_seconds": {}, "date": date})
    sec = Section(run)
    section.run_sections([sec], run)
    write_alone(sec, out, "dgp", "DGP core", a.quick, log)


if __name__ == "__main__":
    main()
