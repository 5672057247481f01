"""cocotb test: a generated core in a closed loop (plant in Python, controller = the Verilator model through its
AXI interfaces). Environment: CORE_OUT (generator output), CL_SPEC (problem spec path), CL_STEPS, CL_HOLD,
CL_SEED, CL_HOLDABLE (reference_schedule's holdable; default 0.9 for FGM, 0 for ADMM as in
mpc_cores.admm.control.admm_references), CL_IMAX (optional IMAX for every solve), CL_RESULT (JSON written with the
trajectory and the words the core returned)."""
from __future__ import annotations

import json
import os

import cocotb
import numpy as np

from mpc_cores.closedloop import RtlController, closed_loop, reference_schedule
from mpc_cores.problem import load_spec
from mpc_cores.driver import TB, TIMEOUT_MS


@cocotb.test(timeout_time=20 * TIMEOUT_MS, timeout_unit="ms")
async def closed_loop_rtl(dut):
    tb = TB(dut, seed=21)
    await tb.reset()
    if os.environ.get("CL_IMAX"):
        await tb.set_imax(int(os.environ["CL_IMAX"]))
    problem = load_spec(os.environ["CL_SPEC"])
    admm = tb.core["core"] == "admm"
    steps, hold = int(os.environ.get("CL_STEPS", "60")), int(os.environ.get("CL_HOLD", "20"))
    holdable = float(os.environ.get("CL_HOLDABLE", "0" if admm else "0.9"))
    refs = reference_schedule(problem, steps, hold, int(os.environ.get("CL_SEED", "0")), holdable=holdable)
    if admm:
        from mpc_cores.admm.control import AdmmRtlController
        ctrl = AdmmRtlController(tb, problem)
    else:
        ctrl = RtlController(tb, tb.core["frac_bits"])
    traj = await closed_loop(problem, ctrl, np.zeros(problem.nx), refs)
    st = await tb.status()
    out = traj.to_dict()
    out.update(words=ctrl.words, status=st, cycles_per_solve=tb.core["cycles_per_solve"])
    with open(os.environ["CL_RESULT"], "w") as f:
        json.dump(out, f)
    assert not st["OVERFLOW"], "a datapath word saturated in closed loop"
