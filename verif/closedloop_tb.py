"""cocotb test: the generated core in a closed loop (plant in Python, controller = the Verilator model through its
AXI interfaces). Environment: FGM_OUT (generator output), CL_SPEC (problem spec path), CL_STEPS, CL_HOLD, CL_SEED,
CL_RESULT (JSON written with the trajectory and the words the core returned)."""
from __future__ import annotations

import json
import os

import cocotb
import numpy as np

from verif.closedloop import RtlController, closed_loop, reference_schedule
from verif.tb import TB, TIMEOUT_MS
from verif.problem import load_spec


@cocotb.test(timeout_time=10 * TIMEOUT_MS, timeout_unit="ms")
async def closed_loop_rtl(dut):
    tb = TB(dut, seed=21)
    await tb.reset()
    problem = load_spec(os.environ["CL_SPEC"])
    steps, hold = int(os.environ.get("CL_STEPS", "60")), int(os.environ.get("CL_HOLD", "20"))
    refs = reference_schedule(problem, steps, hold, int(os.environ.get("CL_SEED", "0")))
    ctrl = RtlController(tb, tb.core["frac_bits"])
    traj = await closed_loop(problem, ctrl, np.zeros(problem.nx), refs)
    st = await tb.status()
    out = traj.to_dict()
    out.update(words=ctrl.words, status=st, cycles_per_solve=tb.core["cycles_per_solve"])
    with open(os.environ["CL_RESULT"], "w") as f:
        json.dump(out, f)
    assert not st["OVERFLOW"], "a datapath word saturated in closed loop"
