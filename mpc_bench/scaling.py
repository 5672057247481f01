"""How the FGM and DGP cores' cost grows with the problem, against DAQP and OSQP on the same QPs: the last part of a
full `make bench` (Section below), and alone `make scaling` (`python -m mpc_bench.scaling [--quick] [--out
build/bench] [--clock-mhz F]`).

The plants: a chain of M masses between two walls (examples/masses.yaml for M = 4: nx = 2M, nu = M, the M positions
tracked), horizon N, so n = N M variables. For every (M, N) of the grid:

  design      the FGM core for TARGET=ecp5 (b = 15, l_A = 1, l_M = 5, the FGM section's Fmax cores) with the exit test;
              the design check at a 1 % target chooses Imax (the test off) and EXIT_TOL (mpc_cores.check); the row
              units P: the largest power of two whose MULT18X18D and DP16KD estimates (the design flow's) fit the
              LFE5U-85F (156 and 208); no P that fits: the instance does not fit
  latency     one closed loop of the plant (mpc_bench.baselines.closed_loop_qps, references held 30 steps), the
              core's golden model warm-started step after step: its iterations per step, its cycles per step
              (core.json's overhead + I L_F), in us at the FGM clock
  software    DAQP (hot start) and OSQP (tuned) on the same condensed QPs, single-threaded on one pinned CPU: median,
              p99 and max per solve by their own timers (C level), and the error of u0 against OSQP at eps 1e-9

The state-constrained rows (mpc_bench.scaling_dgp): the same chains with hard position limits at every stage, the
DGP core against DAQP and OSQP on the state-constrained QPs, its us at the DGP clock.

The clocks: in `make bench`, the placed Fmax of the run's FGM exit-test core and of its DGP row-unit core; alone, the
same from --out's fgm.csv and dgp.csv, or --clock-mhz for both; 200 MHz (the constraint) for a kind with no placed
core. The sweep's cores are not placed themselves, so their us are estimates, and the report says which clock each
kind's rows take.

Writes scaling.csv (a `core` column: fgm or dgp), scaling.png and, alone, scaling.md into --out, and with --docs DIR a
dated copy of scaling.md there.
"""
from __future__ import annotations

import argparse
import csv
import datetime
from pathlib import Path

import numpy as np

from mpc_bench.chains import NoLoop, chain, references_held
from mpc_bench.section import Section as BenchSection

GRID_FULL = ((2, 4, 6, 8), (5, 10, 20, 30))      # masses M, horizons N
GRID_QUICK = ((2, 4), (5, 10))
STEPS_FULL, STEPS_QUICK, HOLD = 200, 60, 30
FMAX_DESIGN = dict(frac_bits=15, lat_add=1, lat_mul=5, target="ecp5", early_exit=True)
DSP_85F, BRAM_85F = 156, 208
TARGET_GAP = 1.0


def fitting_design(problem, log):
    """(design, check, P) of the largest power-of-two P whose hard blocks fit the LFE5U-85F, or (None, reason, 0)"""
    from mpc_cores import registry
    from mpc_cores.check import CheckFailed, checked_design
    from mpc_cores.errors import DesignError

    kind = registry.get("fgm")
    n = problem.N * problem.nu
    best = None
    P = 1
    while P <= n:
        try:
            d = kind.design(problem, P=P, **FMAX_DESIGN)
        except DesignError as e:
            return None, f"refused: {e}", 0
        f = kind.facts(d)
        if f["dsp_ecp5"] > DSP_85F or f["bram_ecp5"] > BRAM_85F:
            break
        best = P
        P *= 2
    if best is None:
        f = kind.facts(kind.design(problem, P=1, **FMAX_DESIGN))
        return None, f"does not fit at P = 1: {f['dsp_ecp5']} MULT18X18D, {f['bram_ecp5']} DP16KD", 0
    try:
        d, res = checked_design(kind, problem, dict(P=best, **FMAX_DESIGN), target=TARGET_GAP)
    except CheckFailed as e:
        return None, f"check: {e}", best
    log(f"{problem.name}: P = {best}, Imax = {d.iterations}, EXIT_TOL {d.exit_tol} LSB")
    return d, res, best


def stats(v) -> dict:
    """{"median", "p99", "max"} of v (mpc_bench.dgp_report.stats)"""
    from mpc_bench.dgp_report import stats as quantiles

    return dict(zip(("median", "p99", "max"), quantiles(v)))


def measure(M: int, N: int, steps: int, clock: float, repeats: int, log) -> dict:
    from mpc_bench.baselines import _optimal_u0, _time_solver, closed_loop_qps, pinned
    from mpc_bench.qp_solvers import OSQP_TUNED, Daqp, Osqp, box_qp, installed
    from mpc_cores import registry
    from mpc_cores.fgm.model import FgmFixed
    from mpc_cores.fixed import quantize
    from mpc_cores.problem import condense
    from mpc_cores.quiet import c_output_silenced

    p = chain(M, N)
    qp = condense(p)
    r = {"core": "fgm", "M": M, "N": N, "nx": p.nx, "nu": p.nu, "n": qp.n}
    d, res, P = fitting_design(p, log)
    r["P"] = P
    if d is None:
        r["note"] = res
        return r
    f = registry.get("fgm").facts(d)
    r.update(imax=d.iterations, exit_tol_lsb=d.exit_tol, b=d.b, cycles_per_iteration=d.cycles_per_iteration,
             overhead=d.solve_overhead, mult18x18d=f["dsp_ecp5"], dp16kd_est=f["bram_ecp5"],
             check_gap_pct=res.gap, note="")
    with references_held():
        W = closed_loop_qps(p, qp, d, steps, HOLD)
    u_opt = _optimal_u0(p, qp, W)
    m = FgmFixed(d)
    its, err = [], []
    for k, w in enumerate(W):
        s = m.solve(quantize(w, d.b))
        its.append(s.iterations)
        err.append(float(np.abs(s.z[: p.nu] / (1 << d.b) - u_opt[k]).max()))
    cyc = d.solve_overhead + np.asarray(its) * d.cycles_per_iteration
    for q, v in stats(its).items():
        r[f"core_iter_{q}"] = v
    for q, v in stats(cyc).items():
        r[f"core_cycles_{q}"] = v
        r[f"core_us_{q}"] = v / clock
    r["core_error_max"] = max(err)
    lqp = box_qp(qp)
    makers = [(name, mk) for name, cls, mk in (
        ("daqp", Daqp, lambda: Daqp(lqp, "DAQP hot start", {})),
        ("osqp_tuned", Osqp, lambda: Osqp(lqp, "OSQP tuned", OSQP_TUNED))) if installed(cls)]
    with pinned(), c_output_silenced():
        for key, mk in makers:
            sw = _time_solver(mk, W, p.nu, u_opt, repeats)
            own = sw.own_us if sw.own_us is not None else sw.times_us
            for q, v in stats(own).items():
                r[f"{key}_own_{q}_us"] = v
                r[f"{key}_own_{q}_over_core"] = v / r[f"core_us_{q}"]
            r[f"{key}_error_max"] = sw.u_err
    return r


def table(rows: list[dict]) -> list[str]:
    from mpc_bench.report import _table, loop_cells

    body = []
    for r in rows:
        if "core_us_median" not in r:
            body.append([str(r["M"]), str(r["N"]), str(r["n"]), "-", r.get("note", "")[:90]] + ["-"] * 6)
            continue
        body.append([str(r["M"]), str(r["N"]), str(r["n"]), str(r["P"]),
                     f"{r['mult18x18d']} / {r['dp16kd_est']}, Imax {r['imax']}, L_F {r['cycles_per_iteration']}",
                     *loop_cells(r, "osqp_tuned", "{:.1f}x")])
    return _table(["M", "N", "n", "P", "MULT18X18D / DP16KD (est.), Imax, L_F", "core iterations med / p99 / max",
                   "core us med / p99 / max", "DAQP own us med / p99 / max",
                   "DAQP / core med / p99 / max", "OSQP tuned own us med / p99 / max", "error max core / DAQP"], body)


def plot(rows: list[dict], path: Path, clocks: dict) -> None:
    """Latency against n: the FGM core on the input box (left), the DGP core with state constraints (right), each
    beside DAQP's own timer on the same QPs"""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(13, 5), sharey=True)
    for ax, core, what in zip(axes, ("fgm", "dgp"), ("input box", "input box and hard position limits")):
        for M in sorted({r["M"] for r in rows}):
            rr = [r for r in rows if r["M"] == M and r.get("core", "fgm") == core and "core_us_median" in r]
            if not rr:
                continue
            n = [r["n"] for r in rr]
            line, = ax.plot(n, [r["core_us_median"] for r in rr], "o-", label=f"{core.upper()} core, M = {M} (median)")
            ax.plot(n, [r["core_us_max"] for r in rr], "o:", color=line.get_color(),
                    label=f"{core.upper()} core, M = {M} (max)")
            if all("daqp_own_median_us" in r for r in rr):
                ax.plot(n, [r["daqp_own_median_us"] for r in rr], "s--", color=line.get_color(), alpha=0.6,
                        label=f"DAQP own timer, M = {M} (median)")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("decision variables n = N M")
        ax.set_title(f"{core.upper()} core at {clocks[core][0]:.1f} MHz, {what}", fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7)
    axes[0].set_ylabel("latency per solve, us")
    fig.suptitle("Chains of M masses, horizon N, against DAQP on the same QPs")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _verdict(rows: list[dict]) -> list[str]:
    """Where the core is ahead of DAQP's own timer (median and maximum), and the largest instance that fits"""
    fits = [r for r in rows if "core_us_median" in r]
    wins = [r for r in fits if (r.get("daqp_own_median_over_core") or 0) >= 1
            and (r.get("daqp_own_max_over_core") or 0) >= 1]
    return ["Where the core is ahead of DAQP at the median and at the maximum: "
            + (", ".join(f"M = {r['M']}, N = {r['N']} (n = {r['n']})" for r in wins) or "none") + ".",
            "Largest instance of the grid that fits the LFE5U-85F: "
            + (f"n = {max(r['n'] for r in fits)}" if fits else "none") + "."]


def placed_clocks(fgm_rows: list[dict], dgp_rows: list[dict]) -> dict:
    """{"fgm": MHz, "dgp": MHz} of the placed cores the sweep's cores are estimated at: the FGM section's exit-test
    core (role fmax) and the DGP section's row-unit core (role units), from their records or CSV rows; a kind
    with no placed core is left out"""
    clocks = {}
    for r in fgm_rows:
        if r.get("role") == "fmax" and str(r.get("early_exit")) == "True" and r.get("fmax_mhz"):
            clocks["fgm"] = float(r["fmax_mhz"])
            break
    for r in dgp_rows:
        if r.get("role") == "units" and r.get("fmax_mhz"):
            clocks["dgp"] = float(r["fmax_mhz"])
    return clocks


def csv_rows(path: Path) -> list[dict]:
    return list(csv.DictReader(path.open())) if path.exists() else []


CLOCK_SOURCE = {"fgm": "the placed Fmax of the FGM section's exit-test masses core (P = 1)",
                "dgp": "the placed Fmax of the DGP section's row-unit masses_state core"}


def clock_texts(clocks: dict, given: float | None) -> dict:
    """{"fgm": (MHz, text), "dgp": (MHz, text)}: the clock of each kind's rows and where it comes from"""
    out = {}
    for core in ("fgm", "dgp"):
        if given:
            out[core] = (given, f"at {given:.1f} MHz (given)")
        elif core in clocks:
            out[core] = (clocks[core], f"at {clocks[core]:.1f} MHz ({CLOCK_SOURCE[core]}: an estimate for these "
                                       "cores, which are not placed)")
        else:
            out[core] = (200.0, "at 200.0 MHz (the constraint: no placed core of this kind in the run)")
    return out


def sweep(quick: bool, clocks: dict, repeats: int, log) -> tuple[list[dict], list[str]]:
    """The grid's rows (FGM, then DGP) and the design choices made on the way; `clocks` as clock_texts gives"""
    from tqdm import tqdm

    from mpc_bench import scaling_dgp

    Ms, Ns = GRID_QUICK if quick else GRID_FULL
    steps = STEPS_QUICK if quick else STEPS_FULL
    rows, notes = [], []
    grid = [(core, M, N) for core in ("fgm", "dgp") for M in Ms for N in Ns]
    for core, M, N in tqdm(grid, desc="scaling", unit="instance", disable=None):
        log(f"scaling: {core.upper()} M = {M}, N = {N}")
        clock = clocks[core][0]
        try:
            rows.append(measure(M, N, steps, clock, repeats, notes.append) if core == "fgm" else
                        scaling_dgp.measure(M, N, steps, HOLD, clock, repeats, TARGET_GAP, notes.append))
        except NoLoop as e:
            rows.append({"core": core, "M": M, "N": N, "n": M * N, "P": 0, "note": f"no closed loop: {e}"})
    return rows, notes


def notes_md(rows: list[dict]) -> list[str]:
    """The whole note of every instance without a core (the tables cut it): why it does not fit or was refused"""
    out = [f"- M = {r['M']}, N = {r['N']} (n = {r['n']}): {r['note']}" for r in rows
           if "core_us_median" not in r and r.get("note")]
    return ["The instances without a core:", "", *out, ""] if out else []


def report_lines(rows: list[dict], notes: list[str], clocks: dict, quick: bool, level: int, origin: str) -> list[str]:
    """The sweep's part of a report: a title at heading `level`, the FGM and DGP tables and verdicts, the choices"""
    from mpc_bench import scaling_dgp

    h = "#" * level
    steps = STEPS_QUICK if quick else STEPS_FULL
    fgm = [r for r in rows if r["core"] == "fgm"]
    dgp = [r for r in rows if r["core"] == "dgp"]
    return [f"{h} FGM and DGP cores against DAQP as the problem grows ({'QUICK' if quick else 'full'})", "",
            f"{origin}; {steps} closed-loop steps per instance, references held {HOLD} steps. The FGM rows "
            f"{clocks['fgm'][1]}; the DGP rows {clocks['dgp'][1]}.", "",
            f"{h}# Input box: the FGM core", "",
            f"Design: TARGET=ecp5, b = 15, l_A = 1, l_M = 5, the exit test, Imax and EXIT_TOL from the design check "
            f"at {TARGET_GAP:g} %, P the largest power of two whose MULT18X18D and DP16KD estimates fit the "
            "LFE5U-85F.", "",
            *table(fgm), "", *notes_md(fgm),
            "Core us: overhead + I L_F cycles (core.json's contract) per loop step, I the iterations the golden "
            "model ran. DAQP and OSQP: their own solve timers (C level), hot-started / warm-started on the same "
            "QPs, one pinned CPU. DAQP / core: above 1x the core is ahead. Error: max over the loop of |u0 - u0*|, "
            "u0* from OSQP at eps 1e-9.", "", *_verdict(fgm), "",
            f"{h}# Input box and hard position limits: the DGP core", "",
            f"The same chains with |p_i| <= {scaling_dgp.POSITION_LIMIT} at stages 1..N (examples/masses_state.yaml "
            f"generalised). Design: TARGET=ecp5, accelerated, b = 15, P = 2 row units, `lanes: fit` (the most "
            f"multipliers per unit that fit the LFE5U-85F), Imax from the design check at {TARGET_GAP:g} %, the "
            "stopping test (32c) at eps_g = eps_V = 1e-3.", "",
            *scaling_dgp.table(dgp), "", *notes_md(dgp),
            "Core us: overhead + I x cycles per iteration (core.json's contract), I the iterations the golden model "
            "ran (warm start), less the zero start's saving where the starting dual was all zero. DAQP: every row a "
            "general constraint, hot start; OSQP: warm start; their own timers on the same QPs.", "",
            *_verdict(dgp), "",
            "Design choices: " + "; ".join(notes) + ".", "", "Plot: scaling.png."]


class Section(BenchSection):
    """The sweep as the last part of a full `make bench`: after the kinds' sections, at their placed clocks."""
    name, label = "scaling", "scaling"
    appendix = True
    plot_files = ("scaling.png",)

    def __init__(self, run, sources: list):
        self.sources = {s.name: s for s in sources}
        self.notes: list[str] = []
        self.clocks: dict = {}
        super().__init__(run)

    def log_text(self) -> str:
        return "scaling sweep (chains of M masses over horizons N, FGM and DGP, at their sections' placed Fmax)"

    def configure(self, a) -> None:
        self.quick = bool(a.quick)

    def finish(self) -> None:
        import time

        t = time.perf_counter()
        src = {k: self.sources[k].rows if k in self.sources else [] for k in ("fgm", "dgp")}
        self.clocks = clock_texts(placed_clocks(src["fgm"], src["dgp"]), None)
        self.rows, self.notes = sweep(self.quick, self.clocks, 2, self.log)
        self.log(f"scaling sweep done in {(time.perf_counter() - t) / 60:.1f} min")

    def appendix_md(self) -> list[str]:
        if not self.rows:
            return []
        return report_lines(self.rows, self.notes, self.clocks, self.quick, 2, "The bench's scaling part")

    def plots(self, plt, out: Path) -> list[Path]:
        if not self.rows:
            return []
        plot(self.rows, out / "scaling.png", self.clocks)
        return [out / "scaling.png"]


def main(argv=None) -> None:
    from mpc_bench.report import write_csv

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="M in {2, 4}, N in {5, 10}, 60 loop steps")
    ap.add_argument("--out", default="build/bench")
    ap.add_argument("--clock-mhz", type=float, default=None,
                    help="the clock of both kinds' rows (default: their sections' placed Fmax in --out's CSVs)")
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--docs", default=None, help="folder for a dated copy of scaling.md (e.g. docs/bench)")
    a = ap.parse_args(argv)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    clocks = clock_texts(placed_clocks(csv_rows(out / "fgm.csv"), csv_rows(out / "dgp.csv")), a.clock_mhz)
    rows, notes = sweep(a.quick, clocks, a.repeats, lambda msg: None)
    write_csv(out / "scaling.csv", rows)       # as make bench writes it
    plot(rows, out / "scaling.png", clocks)
    when = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    lines = report_lines(rows, notes, clocks, a.quick, 1,
                         f"{when}; `python -m mpc_bench.scaling{' --quick' if a.quick else ''}`")
    (out / "scaling.md").write_text("\n".join(lines) + "\n")
    if a.docs:
        dest = Path(a.docs) / f"{datetime.date.today().isoformat()}-scaling{'-quick' if a.quick else ''}.md"
        dest.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
