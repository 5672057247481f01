"""Closed loop with the generated core in the loop (short form): the RTL controller returns exactly the golden
model's words at every step, and the golden loop stays close to the optimal one."""
from __future__ import annotations

import json

import numpy as np

from mpc_cores.closedloop import OsqpController, reference_schedule, run_closed_loop
from mpc_cores.fgm.control import FixedController
from mpc_cores.fgm.design import design_fgm
from mpc_cores.flow import REPO
from mpc_cores.problem import load_spec
from mpc_cores.sim import run_cocotb

STEPS, HOLD = 8, 4


def test_rtl_in_the_loop_equals_golden(cores):
    out = cores["masses_p1_b16"]
    core = json.loads((out / "core.json").read_text())
    spec = REPO / "examples/masses.yaml"
    p = load_spec(spec)
    d = design_fgm(p, P=1, frac_bits=16)
    refs = reference_schedule(p, STEPS, HOLD, seed=3)
    golden = FixedController(d)
    t_fix = run_closed_loop(p, golden, np.zeros(p.nx), refs)
    result = out / "closed_loop.json"
    result.unlink(missing_ok=True)
    tests, failed = run_cocotb(out / core["sv"], core["module"], "mpc_cores.closedloop_tb", out / "sim",
                               {"CORE_OUT": str(out), "CL_SPEC": str(spec), "CL_STEPS": str(STEPS),
                                "CL_HOLD": str(HOLD), "CL_SEED": "3", "CL_RESULT": str(result)})
    assert (tests, failed) == (1, 0)
    rtl = json.loads(result.read_text())
    assert rtl["words"] == golden.words
    assert np.array_equal(np.array(rtl["x"]), t_fix.x)


def test_golden_loop_close_to_optimal():
    p = load_spec(REPO / "examples/masses.yaml")
    refs = reference_schedule(p, 30, 10, seed=1)
    t_opt = run_closed_loop(p, OsqpController(p), np.zeros(p.nx), refs)
    t_fix = run_closed_loop(p, FixedController(design_fgm(p, frac_bits=16, iterations=15)), np.zeros(p.nx), refs)
    # Table II(a) of 002: b = 16, Imax = 15 is within 0.05 % of double precision
    assert abs(t_fix.cost - t_opt.cost) / t_opt.cost < 5e-3
    assert np.all(t_fix.u <= p.umax + 1e-12) and np.all(t_fix.u >= p.umin - 1e-12)
