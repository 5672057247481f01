"""`make demo CORE=ipm` in short form (slow: a Verilator build of the masses core and a closed loop of about 120k
cycles per step at P = 1): the RTL in the loop, driven through its AXI interfaces on channel 0, returns exactly the
golden model's words (u0, mu, ||r_0||, status) at every step, and its closed-loop cost is within 0.1 % of OSQP's."""
from __future__ import annotations

import json

import numpy as np
import pytest

from mpc_cores import registry
from mpc_cores.closedloop import reference_schedule, run_closed_loop
from mpc_cores.demo import run_demo
from mpc_cores.flow import REPO
from mpc_cores.problem import load_spec

BUILD = REPO / "build" / "tests" / "ipm_demo"
SPEC = REPO / "examples/masses.yaml"
STEPS, HOLD, SEED = 8, 4, 0


@pytest.mark.slow
@pytest.mark.parametrize("P", [1, None], ids=["p1", "p_eq15"])
def test_ipm_demo_rtl_equals_golden(P):
    kind = registry.get("ipm")
    p = load_spec(SPEC)
    d = kind.design(p, P=P)
    out = BUILD / (f"p{P}" if P else "p_eq15")
    table = run_demo(kind, d, SPEC, out, STEPS, HOLD, SEED)  # DemoError when the words differ
    assert f"RTL words equal the golden model's in all {STEPS} steps: yes" in table
    rtl = json.loads((out / "closed_loop_rtl.json").read_text())
    optimal, golden, holdable = kind.controllers(d)
    refs = reference_schedule(p, STEPS, HOLD, SEED, holdable=holdable)
    t_opt = run_closed_loop(p, optimal, np.zeros(p.nx), refs)
    t_gold = run_closed_loop(p, golden, np.zeros(p.nx), refs)
    assert len(rtl["words"]) == STEPS and rtl["words"] == golden.words
    assert np.array_equal(np.array(rtl["x"]), t_gold.x)
    assert abs(rtl["cost"] - t_opt.cost) / t_opt.cost < 1e-3, (rtl["cost"], t_opt.cost)


@pytest.mark.slow
def test_ipm_demo_multiplexed():
    """`make demo CORE=ipm MULTIPLEXED=1` in short form: the multiplexed core's RTL in Algorithm 2's closed loop (the
    round's copies sent together on channels 0 .. m - 1) returns the golden model's words at every step, and the
    report puts the conventional core's model beside it on the same references, with both latencies per sample."""
    kind = registry.get("ipm")
    p = load_spec(SPEC)
    d = kind.design(p, multiplexed=True)
    out = BUILD / "mux"
    table = run_demo(kind, d, SPEC, out, STEPS, HOLD, SEED)  # DemoError when the words differ
    assert f"RTL words equal the golden model's in all {STEPS} steps: yes" in table
    assert "| conventional MPC: golden model," in table and "latency per sample:" in table
    rtl = json.loads((out / "closed_loop_rtl.json").read_text())
    # every step: the answers of its rounds, m per round (u0, mu, the T moves, ||r_0||, status each)
    per_answer = 1 + 1 + p.N + 1 + 1
    assert all(len(w) % (p.nu * per_answer) == 0 and w for w in rtl["words"])
