"""cocotb test: the guarantees of the design flow checked on the RTL. Over random states in the box X0 and states
on its corners, cold start, all of z read back: the sticky OVERFLOW bit never rises (Prop. 1 of 002), the
distance to exact arithmetic on the same data stays under eq. (20), and the distance to the optimum under the
certified total bound. Environment: CORE_OUT, GUARANTEE_CASES (states), CORE_MEASURE (ratios written there)."""
from __future__ import annotations

import json
import os

import cocotb
import numpy as np
import osqp
import scipy.sparse as sp

from mpc_cores.fgm.model import fgm_float
from mpc_cores.driver import TB, TIMEOUT_MS


def _optimum(H, q, lo, hi) -> np.ndarray:
    s = osqp.OSQP()
    s.setup(P=sp.triu(sp.csc_matrix(H), format="csc"), q=q, A=sp.identity(len(q), format="csc"), l=lo, u=hi,
            eps_abs=1e-12, eps_rel=1e-12, polishing=True, verbose=False, max_iter=500_000)
    r = s.solve()
    return np.clip(r.x, lo, hi)


@cocotb.test(timeout_time=10 * TIMEOUT_MS, timeout_unit="ms")
async def guarantees(dut):
    tb = TB(dut, seed=31)
    await tb.reset()
    await tb.set_ctrl(warm=False, out_all=True)
    cert = tb.core["certificate"]
    one = float(1 << tb.core["frac_bits"])
    m = tb.model
    G, F = m.A / one, m.F / one
    H = np.eye(tb.n) - G
    lo, hi = m.lo / one, m.hi / one
    imax = tb.core["iterations"]
    count = int(os.environ.get("GUARANTEE_CASES", "40"))
    states = [m.xlo.copy(), m.xhi.copy()]
    while len(states) < count:
        if len(states) % 2:   # a random corner of the box
            states.append(np.where([tb.rng.random() < 0.5 for _ in range(tb.nw)], m.xlo, m.xhi))
        else:
            states.append(tb.random_w())
    worst_rnd = worst_opt = 0.0
    for k, w in enumerate(states):
        z = np.array(await _solve(tb, w)) / one
        wr = np.clip(w, m.xlo, m.xhi) / one
        z_exact = fgm_float(G, F, m.beta / one, lo, hi, wr, imax)[-1]
        z_opt = _optimum(H, F @ wr, lo, hi)
        e_rnd = float(np.linalg.norm(z - z_exact))
        e_opt = float(np.linalg.norm(z - z_opt))
        assert e_rnd <= cert["roundoff_error_bound_eq20"], f"state {k}: round-off {e_rnd:.3g} > eq. (20) bound"
        assert e_opt <= cert["total_error_bound"], f"state {k}: error to z* {e_opt:.3g} > certified bound"
        worst_rnd, worst_opt = max(worst_rnd, e_rnd), max(worst_opt, e_opt)
    st = await tb.status()
    assert not st["OVERFLOW"], "OVERFLOW rose for a state in the box"
    rec = {"test": "guarantees", "module": tb.core["module"], "cases": len(states),
           "roundoff_observed": worst_rnd, "roundoff_bound": cert["roundoff_error_bound_eq20"],
           "total_observed": worst_opt, "total_bound": cert["total_error_bound"], "tol": cert["tol"]}
    path = os.environ.get("CORE_MEASURE")
    if path:
        with open(path, "a") as f:
            f.write(json.dumps(rec) + "\n")


async def _solve(tb: TB, w):
    exp, _ = tb.expect(w)
    await tb.send(w)
    got = await tb.recv()
    assert got == exp, "RTL differs from the golden model"
    return got
