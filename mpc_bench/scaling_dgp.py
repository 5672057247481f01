"""The state-constrained rows of the scaling sweep (mpc_bench.scaling): the DGP core on the chain of M masses with hard
position limits, against DAQP and OSQP on the same state-constrained QPs.

For every (M, N) of the grid:

  design      the DGP core for TARGET=ecp5 as the DGP section's row-unit core (accelerated, 15 fraction bits) with
              P = 2 row units and `lanes: fit` (the most multipliers per unit whose products and matrix memories fit
              the LFE5U-85F); the design check at a 1 % target chooses Imax (mpc_cores.check); no lanes that fit: the
              instance does not fit
  latency     one closed loop of the plant under the core's golden controller (mpc_bench.dgp.closed_loop: warm
              start, references held `HOLD` steps): iterations per step to the stopping test (32c) or Imax, cycles
              (core.json's overhead + I x cycles_per_iteration, less zero_start_saving_cycles on a zero start) and
              us at the clock the sweep states
  software    DAQP (hot start, every row a general constraint) and OSQP (warm start) on the same QPs by their own
              timers (mpc_bench.dgp's StateQp solvers), one pinned CPU: median, p99 and max; the error of u0 against
              the QP's optimum (OSQP at eps 1e-9)
"""
from __future__ import annotations

import numpy as np

from mpc_bench.chains import POSITION_LIMIT, chain_state, references_held

Q3 = ("median", "p99", "max")
DGP_DESIGN = dict(accelerated=True, P=2, lanes="fit", frac_bits=15, target="ecp5")
def fitting_design(problem, target_gap: float, log):
    """(design, check result) of the checked DGP design, or (None, why)"""
    from mpc_cores import registry
    from mpc_cores.check import CheckFailed, checked_design
    from mpc_cores.errors import DesignError

    kind = registry.get("dgp")
    try:
        d, res = checked_design(kind, problem, dict(DGP_DESIGN), target=target_gap)
    except DesignError as e:
        return None, f"refused: {e}"
    except CheckFailed as e:
        return None, f"check: {e}"
    log(f"{problem.name} (DGP): P = {d.P}, lanes = {d.lanes}, Imax = {d.iterations}")
    return d, res


def measure(M: int, N: int, steps: int, hold: int, clock: float, repeats: int, target_gap: float, log) -> dict:
    """One row of the DGP section: the design, the loop's iterations, cycles and us at `clock`, DAQP and OSQP"""
    from mpc_bench.baselines import _time_solver, pinned
    from mpc_bench.dgp import DaqpState, OsqpState, StateQp, closed_loop
    from mpc_bench.dgp_report import stats as quantiles
    from mpc_cores import registry
    from mpc_cores.quiet import c_output_silenced

    p = chain_state(M, N)
    r = {"core": "dgp", "M": M, "N": N, "nx": p.nx, "nu": p.nu, "n": p.N * p.nu}
    d, res = fitting_design(p, target_gap, log)
    if d is None:
        r["P"], r["note"] = 0, res
        return r
    f = registry.get("dgp").facts(d)
    r.update(P=d.P, lanes=d.lanes, mc=d.mc, imax=d.iterations, b=d.b, cycles_per_iteration=d.cycles_per_iteration,
             overhead=d.solve_overhead, mult18x18d=f["dsp_ecp5"], dp16kd_est=f["bram_ecp5"], check_gap_pct=res.gap,
             note="")
    with references_held():
        loop = closed_loop({"units": d}, steps, hold, seed=1, states=1)   # one cold start: the loop needs none
    its = loop.iters["units"]
    cyc = d.cycles_to_output(its, loop.zero["units"])
    for q, v in zip(Q3, quantiles(its)):
        r[f"core_iter_{q}"] = v
    for q, v in zip(Q3, quantiles(cyc)):
        r[f"core_cycles_{q}"] = v
        r[f"core_us_{q}"] = v / clock
    r["core_met_fraction"] = float(np.mean(loop.met["units"]))
    r["active_input_fraction"], r["active_state_fraction"] = active_fractions(d.qp, loop.W)
    r["core_error_max"] = loop.core_err["units"][0]
    sq = StateQp(d.qp)
    with pinned(), c_output_silenced():
        for key, cls in (("daqp", DaqpState), ("osqp", OsqpState)):
            try:
                sw = _time_solver(lambda cls=cls: cls(sq), loop.W, p.nu, loop.u_opt, repeats)
            except (ImportError, RuntimeError) as e:
                r[f"{key}_note"] = str(e)
                continue
            own = sw.own_us if sw.own_us is not None else sw.times_us
            for q, v in zip(Q3, quantiles(own)):
                r[f"{key}_own_{q}_us"] = v
                r[f"{key}_own_{q}_over_core"] = v / r[f"core_us_{q}"]
            r[f"{key}_error_max"] = sw.u_err
    return r


def active_fractions(qp, W: np.ndarray, tol: float = 1e-6) -> tuple[float, float]:
    """The fractions of the loop's QPs whose optimum (OSQP at eps 1e-9) has an input row, and a hard state row, at
    a bound (within tol of the row's range): how often the constraints shape the answer"""
    from mpc_cores.dgp.problem import solve_osqp

    hits = np.zeros((len(W), 2), dtype=bool)
    for k, w in enumerate(W):
        z = solve_osqp(qp, w, eps=1e-9)[0]
        lo, hi = qp.bounds(w)
        at = np.minimum(qp.G @ z - lo, hi - qp.G @ z) <= tol * (hi - lo)
        hits[k] = at[: qp.n_input_rows].any(), at[qp.n_input_rows:].any()
    return float(hits[:, 0].mean()), float(hits[:, 1].mean())


def table(rows: list[dict]) -> list[str]:
    from mpc_bench.report import _table, loop_cells

    body = []
    for r in rows:
        if "core_us_median" not in r:
            body.append([str(r["M"]), str(r["N"]), str(r["n"]), "-", r.get("note", "")[:90]] + ["-"] * 7)
            continue
        body.append([str(r["M"]), str(r["N"]), str(r["n"]), f"{r['P']} x {r['lanes']}",
                     f"{r['mult18x18d']} / {r['dp16kd_est']}, {r['mc']} rows, Imax {r['imax']}, "
                     f"{r['cycles_per_iteration']} cycles / iteration",
                     f"{100 * r['active_input_fraction']:.0f} % / {100 * r['active_state_fraction']:.0f} %",
                     *loop_cells(r, "osqp", "{:.2f}x")])
    return _table(["M", "N", "n", "P x lanes", "MULT18X18D / DP16KD (est.), rows, Imax, L",
                   "QPs with an input / state row active", "core iterations med / p99 / max", "core us med / p99 / max",
                   "DAQP own us med / p99 / max",
                   "DAQP / core med / p99 / max", "OSQP own us med / p99 / max", "error max core / DAQP"], body)
