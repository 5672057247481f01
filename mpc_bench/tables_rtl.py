"""The RTL subset of the cost tables (`make table2` without --no-rtl): masses FGM cores (b in RTL_BITS, Imax =
RTL_IMAX) and masses_rate_soft ADMM cores (P = ADMM_RTL_P, b in ADMM_RTL_BITS, IMAX = ADMM_RTL_IMAX) generated
and run in the closed loop in Verilator (mpc_cores.closedloop_tb); the words they return and the cost must equal
the golden model's exactly."""
from __future__ import annotations

import json
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from mpc_bench.tables_sweep import SweepResult, _problem, admm_design, admm_golden_loop, golden_loop
from mpc_cores.fgm.design import design_fgm

RTL_BITS = (12, 16)
RTL_IMAX = 15
# ADMM cells run on the RTL in `make table2`: the example at P = 4, two b, one Imax row
ADMM_RTL_BITS = (12, 18)
ADMM_RTL_IMAX = 20
ADMM_RTL_P = 4


def _rtl_closed_loop(out: str, spec: str, steps: int, hold: int, seed: int, imax: int | None = None) -> tuple[int, int]:
    from mpc_cores.sim import run_cocotb

    out_p = Path(out)
    core = json.loads((out_p / "core" / "core.json").read_text())
    result = out_p / "closed_loop_rtl.json"
    result.unlink(missing_ok=True)
    env = {"CORE_OUT": str((out_p / "core").resolve()), "CL_SPEC": spec, "CL_STEPS": str(steps),
           "CL_HOLD": str(hold), "CL_SEED": str(seed), "CL_RESULT": str(result.resolve())}
    if imax is not None:
        env["CL_IMAX"] = str(imax)
    return run_cocotb(out_p / "core" / core["sv"], core["module"], "mpc_cores.closedloop_tb", out_p / "sim", env)


def _rtl_rows(res: SweepResult, runs: dict, dirs: dict, imax: int, golden) -> list[dict]:
    """Compare each RTL closed loop with the golden model's: words and cost identical."""
    sw = res.sweep
    rows = []
    for b, (tests, failed) in runs.items():
        result = dirs[b] / "closed_loop_rtl.json"
        if tests != 1 or failed or not result.exists():
            raise RuntimeError(f"RTL closed loop b={b} failed: see {dirs[b] / 'sim' / 'sim.log'}")
        rtl = json.loads(result.read_text())
        traj, ctrl = golden(sw, b, imax)
        pct = lambda c: 100.0 * (c - res.opt.cost) / res.opt.cost  # noqa: E731
        rows.append({"b": b, "imax": imax, "steps": sw.steps, "golden_pct": pct(traj.cost),
                     "rtl_pct": pct(rtl["cost"]), "same_words": rtl["words"] == ctrl.words,
                     "same_cost": rtl["cost"] == traj.cost and traj.cost == res.cells[(imax, b)]["cost"],
                     "dir": str(dirs[b])})
    return rows


def _run_rtl_loops(res: SweepResult, dirs: dict, workers: int, imax: int | None) -> dict:
    sw = res.sweep
    sys.stderr.write("RTL closed loops in Verilator\n")
    with ProcessPoolExecutor(max_workers=max(1, min(workers, len(dirs)))) as ex:
        futs = {b: ex.submit(_rtl_closed_loop, str(d), str(sw.spec), sw.steps, sw.hold, sw.seed, imax)
                for b, d in dirs.items()}
        return {b: f.result() for b, f in futs.items()}


def rtl_subset(res: SweepResult, root: Path, workers: int = 2) -> list[dict]:
    """Masses cores for b in RTL_BITS at Imax = RTL_IMAX elaborated in one generator call, each run in the closed
    loop in Verilator; the returned words and the cost must equal the golden model's exactly."""
    from mpc_cores.flow import generate

    sw = res.sweep
    p = _problem(str(sw.spec))
    designs = {b: design_fgm(p, frac_bits=b, iterations=RTL_IMAX) for b in RTL_BITS}
    dirs = {b: root / f"{sw.key}_b{b}_i{RTL_IMAX}" for b in designs}
    sys.stderr.write(f"elaborating {len(designs)} cores into {root}\n")
    generate("fgm", [(d, dirs[b] / "core") for b, d in designs.items()])
    return _rtl_rows(res, _run_rtl_loops(res, dirs, workers, None), dirs, RTL_IMAX, golden_loop)


def admm_rtl_subset(res: SweepResult, root: Path, workers: int = 2) -> list[dict]:
    """ADMM cores (P = ADMM_RTL_P) for b in ADMM_RTL_BITS, designed as the sweep's cells (widths for the largest
    Imax), run in the closed loop in Verilator with IMAX = ADMM_RTL_IMAX; words and cost must equal the golden
    model's (P changes the schedule, not one bit of the result)."""
    from mpc_cores.flow import generate

    sw = res.sweep
    designs = {b: admm_design(str(sw.spec), b, sw.rounding, max(sw.imaxes), sw.overrides + (("P", ADMM_RTL_P),))
               for b in ADMM_RTL_BITS}
    dirs = {b: root / f"{sw.key}_b{b}_p{ADMM_RTL_P}" for b in designs}
    sys.stderr.write(f"elaborating {len(designs)} ADMM cores into {root}\n")
    generate("admm", [(d, dirs[b] / "core") for b, d in designs.items()])
    return _rtl_rows(res, _run_rtl_loops(res, dirs, workers, ADMM_RTL_IMAX), dirs, ADMM_RTL_IMAX, admm_golden_loop)
