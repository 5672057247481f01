"""cocotb test: a generated core in a closed loop (plant in Python, controller = the Verilator model through its
AXI interfaces). A kind with `rtl_controller_fn` (mpc_cores.kind.CoreKind) brings its own testbench driver and
controller; the others (FGM) are driven through mpc_cores.driver.TB.

Environment: CORE_OUT (generator output), CL_SPEC (problem spec path), CL_STEPS, CL_HOLD, CL_SEED, CL_HOLDABLE
(reference_schedule's holdable; default the kind's, CoreKind.holdable),
CL_IMAX (optional IMAX for every solve), CL_RESULT (JSON written with the trajectory and the words the core
returned)."""
from __future__ import annotations

import json
import os
from pathlib import Path

import cocotb
import numpy as np

from mpc_cores import registry
from mpc_cores.closedloop import RtlController, closed_loop, reference_schedule
from mpc_cores.problem import load_spec
from mpc_cores.driver import TB, TIMEOUT_MS


@cocotb.test(timeout_time=20 * TIMEOUT_MS, timeout_unit="ms")
async def closed_loop_rtl(dut):
    problem = load_spec(os.environ["CL_SPEC"])
    core = json.loads((Path(os.environ["CORE_OUT"]) / "core.json").read_text())
    kind = registry.get(core["core"])
    if kind.rtl_controller_fn:
        tb, ctrl = await kind.rtl_controller(dut, problem)
    else:
        tb = TB(dut, seed=21)
        await tb.reset()
        ctrl = RtlController(tb, tb.core["frac_bits"])
    if os.environ.get("CL_IMAX"):
        await tb.set_imax(int(os.environ["CL_IMAX"]))
    steps, hold = int(os.environ.get("CL_STEPS", "60")), int(os.environ.get("CL_HOLD", "20"))
    holdable = float(os.environ.get("CL_HOLDABLE", kind.holdable))
    refs = reference_schedule(problem, steps, hold, int(os.environ.get("CL_SEED", "0")), holdable=holdable)
    traj = await closed_loop(problem, ctrl, np.zeros(problem.nx), refs)
    st = await tb.status()
    out = traj.to_dict()
    out.update(words=ctrl.words, status=st, cycles_per_solve=core.get("cycles_per_solve"))
    with open(os.environ["CL_RESULT"], "w") as f:
        json.dump(out, f)
    assert not st.get("OVERFLOW"), "a datapath word saturated in closed loop"
    assert not st.get("NONFINITE"), "a non-finite word in closed loop"
