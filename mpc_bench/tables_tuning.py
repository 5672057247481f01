"""ADMM tuning scan of the cost tables (`python -m mpc_bench.tables --admm-tuning`): the float64 ADMM in closed loop
on masses_rate_soft for every (rho, soft_scale, du_scale) of a grid, over several reference seeds, against OSQP to
optimality; writes admm_tuning.md."""
from __future__ import annotations

from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import replace

import numpy as np
from tqdm import tqdm

from mpc_bench.tables_sweep import Sweep, _problem, _refs, optimal_loop
from mpc_cores.closedloop import run_closed_loop
from mpc_cores.fgm.design import DesignError

# What 002 leaves to the designer: rho (2^k), the scaling of the matching condition on the soft pairs (soft_scale,
# III-C of 002) and on du (du_scale). Scanned with the float64 ADMM (no round-off) over several reference seeds.
TUNING_RHOS = (1, 2, 4, 8)
TUNING_SOFT = (8, 16, 32, 64)
TUNING_DU = (1, 2, 4, 8)
TUNING_SEEDS = tuple(range(6))
TUNING_IMAX = (10, 20, 40)


def _tuning_optimal(sw: Sweep) -> tuple[int, float]:
    return sw.seed, optimal_loop(sw).cost


def _tuning_setting(sw0: Sweep, seeds: tuple, rho: float, soft: float, du: float) -> dict:
    from mpc_cores.admm.control import AdmmFloatController
    from mpc_cores.admm.design import design_admm

    p = _problem(str(sw0.spec))
    row = {"rho": rho, "soft_scale": soft, "du_scale": du}
    try:
        d = design_admm(p, rho=rho, soft_scale=soft, du_scale=du, sizing_solves=2)   # widths unused in float64
    except DesignError as e:
        return row | {"refused": str(e)}
    refs = {s: _refs(replace(sw0, seed=s)) for s in seeds}
    row["cost"] = {(im, s): run_closed_loop(p, AdmmFloatController(d, imax=im), np.zeros(p.nx), refs[s]).cost
                   for im in TUNING_IMAX for s in seeds}
    return row


def admm_tuning_scan(sw0: Sweep, seeds: tuple = TUNING_SEEDS, workers: int = 2) -> tuple[dict, list[dict]]:
    """Float64 ADMM closed-loop cost for every (rho, soft_scale, du_scale) of the TUNING_* grids, Imax in
    TUNING_IMAX, one loop per reference seed (steps and hold of sw0). Returns ({seed: J_opt}, rows)."""
    grid = [(r, s, d) for r in TUNING_RHOS for s in TUNING_SOFT for d in TUNING_DU]
    with ProcessPoolExecutor(max_workers=max(1, workers)) as ex:
        opt = dict(ex.map(_tuning_optimal, [replace(sw0, seed=s) for s in seeds]))
        futs = [ex.submit(_tuning_setting, sw0, seeds, *g) for g in grid]
        rows = []
        for f in tqdm(as_completed(futs), total=len(futs), desc="tuning settings", unit="setting", disable=None):
            rows.append(f.result())
    for row in rows:
        if "cost" in row:
            row["pct"] = {k: 100.0 * (c - opt[k[1]]) / opt[k[1]] for k, c in row["cost"].items()}
    return opt, rows


def tuning_markdown(opt: dict, rows: list[dict], default: tuple) -> str:
    """Settings sorted by the mean |cost_pct| over the seeds at the largest Imax."""
    seeds, last = sorted(opt), max(TUNING_IMAX)

    def stats(row, im):
        v = [row["pct"][(im, s)] for s in seeds]
        return float(np.mean(np.abs(v))), float(max(v))

    ok = sorted((r for r in rows if "pct" in r), key=lambda r: stats(r, last)[0])
    out = ["# ADMM tuning scan: float64 ADMM in closed loop", "",
           f"masses_rate_soft, {len(seeds)} reference seeds ({', '.join(map(str, seeds))}), warm start; cost_pct against "
           "OSQP to optimality on the same loop; per Imax the mean over the seeds of |cost_pct| and the largest "
           f"cost_pct. Default (rho, soft_scale, du_scale) = {default} marked **bold**.", "",
           "| rho | soft_scale | du_scale | " + " | ".join(f"Imax {im} mean abs | Imax {im} max" for im in TUNING_IMAX)
           + " |", "|---|---|---|" + "---|---|" * len(TUNING_IMAX)]
    for r in ok:
        key = (r["rho"], r["soft_scale"], r["du_scale"])
        cells = " | ".join(f"{a:.3f} | {b:.3f}" for a, b in (stats(r, im) for im in TUNING_IMAX))
        name = " | ".join(f"{v:g}" for v in key)
        out.append(f"| {'**' + name.replace(' | ', '** | **') + '**' if key == default else name} | {cells} |")
    for r in rows:
        if "refused" in r:
            out.append(f"\n- refused: rho {r['rho']:g}, soft_scale {r['soft_scale']:g}, du_scale {r['du_scale']:g}: "
                       f"{r['refused']}")
    return "\n".join(out) + "\n"


