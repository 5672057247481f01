"""The ADMM family on specs without an `input_rate` section: the plain sparse form (8) of 002 (decision inputs u_k,
states not augmented, w = (x, r), u_0 out; mpc_cores/admm/problem.py) for examples/masses.yaml (input box only)
and examples/masses_state.yaml (hard position limits): layout, cost and dynamics, the condensed FGM problem it
reduces to, the warm-start shift, the designs of ADMM, AMA and Vu-Condat, the du_scale refusal, the report, and
the golden model against OSQP, per solve and in closed loop."""
import functools
from pathlib import Path

import numpy as np
import pytest
import yaml

from mpc_cores.admm.control import (AdmmFixedController, AdmmFloatController, AdmmOsqpController, admm_references,
                                    parameters, rate_and_box_ok)
from mpc_cores.admm.design import DesignError, design_admm, design_ama, design_vucondat
from mpc_cores.admm.model import AdmmFixed, AdmmFloat, applied_input, shift_stages
from mpc_cores.admm.problem import BOX, FREE, build_admm_qp, solve_soft_qp_osqp
from mpc_cores.admm.report import design_report
from mpc_cores.closedloop import run_closed_loop
from mpc_cores.fixed import quantize
from mpc_cores.problem import condense, load_spec, problem_from_dict, steady_state_maps
from mpc_cores.reference import solve_qp_osqp

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


@functools.lru_cache(maxsize=None)
def masses():
    return load_spec(EXAMPLES / "masses.yaml")


@functools.lru_cache(maxsize=None)
def masses_state():
    """examples/masses_state.yaml (inputs and hard_states, no input_rate) without its solver section, which is
    the DGP core's (iterations, lanes, eps_g, eps_V, accelerated)."""
    d = yaml.safe_load((EXAMPLES / "masses_state.yaml").read_text())
    d.pop("solver")
    return problem_from_dict(d)


@functools.lru_cache(maxsize=None)
def masses_design(iterations=40):
    """masses.yaml's own solver settings (b = 16, P = 1), Imax 40 (the widths sized for it)."""
    return design_admm(masses(), iterations=iterations)


def rollout(q, w, us):
    """z of the plain form from w = (x, r) and the inputs u_0..u_{N-1} (no slacks)."""
    p = q.problem
    z = np.zeros(q.n)
    x = np.asarray(w[: p.nx], dtype=float)
    for k in range(q.N + 1):
        z[q.x_index(k)] = x
        if k < q.N:
            z[q.du_index(k)] = us[k]
            x = p.A @ x + p.B @ us[k]
    return z


# ---------------------------------------------------------------------------
# the plain sparse form


def test_plain_form_layout_cost_and_dynamics():
    p = masses()
    q = build_admm_qp(p)
    assert p.input_rate is None and not q.rate
    # n_A = N (nu + nx + |S|) + nx + |S| with nx = 8 (not augmented); w = (x, r)
    assert (q.nx, q.ns, q.nw) == (8, 0, 12)
    assert q.n == 10 * (4 + 8) + 8 == 128 and q.F.shape == (11 * 8, 128)
    assert np.array_equal(q.wlo, np.concatenate([p.xmin, p.rmin]))
    assert np.array_equal(q.whi, np.concatenate([p.xmax, p.rmax]))
    # the decision inputs u_k carry the input box; every state is free (no hard_states)
    assert np.all(q.kind[:40] == BOX) and np.all(q.kind[40:] == FREE)
    assert np.array_equal(q.lo[:40], np.tile(p.umin, 10)) and np.array_equal(q.hi[:40], np.tile(p.umax, 10))
    # R on the u_k: the Hessian is positive definite on Ker F without any rate weight
    assert np.linalg.eigvalsh(q.H)[0] > -1e-12
    rng = np.random.default_rng(0)
    Mx, Mu = steady_state_maps(p)
    for _ in range(4):
        w = rng.uniform(q.wlo, q.whi)
        us = rng.uniform(-0.5, 0.5, (q.N, q.nu))
        z = rollout(q, w, us)
        assert np.abs(q.F @ z - q.b(w)).max() < 1e-12
        x, r = w[:8], w[8:]
        xs, uss = Mx @ r, Mu @ r
        J = 0.0
        for k in range(q.N):
            xk = z[q.x_index(k)]
            J += (xk - xs) @ p.Q @ (xk - xs) + (us[k] - uss) @ p.R @ (us[k] - uss)
        xN = z[q.x_index(q.N)]
        J += (xN - xs) @ p.QN @ (xN - xs)
        assert abs(q.objective(z, w) - J) < 1e-9 * max(1.0, abs(J))
        assert np.array_equal(q.inputs(z), us)
        assert np.array_equal(q.w(x, np.full(4, 9.0), r), w)       # u_prev is not part of this form's w


def test_plain_form_is_the_condensed_fgm_problem():
    """Without state constraints the plain sparse form has the optimum of the condensed QP of the FGM core."""
    p = masses()
    q = build_admm_qp(p)
    cq = condense(p)
    rng = np.random.default_rng(1)
    for _ in range(4):
        w = np.concatenate([rng.uniform(-2, 2, 8), rng.uniform(-1, 1, 4)])
        z = solve_soft_qp_osqp(q, w)
        u_ref = solve_qp_osqp(cq, w).reshape(p.N, p.nu)
        assert np.abs(q.inputs(z) - u_ref).max() < 1e-6


def test_plain_form_hard_states():
    p = masses_state()
    q = build_admm_qp(p)
    assert not q.rate and q.n == 128 and q.nw == 12
    for k in range(q.N + 1):
        assert (q.kind[q.x_index(k)][:4] == (BOX if k else FREE)).all()      # stage 0 is pinned by x_0 = x
        assert (q.kind[q.x_index(k)][4:] == FREE).all()
    # a state the position limits can be met from, references beyond them
    w = np.concatenate([[0.3, -0.3, 0.3, -0.3], [0.2, -0.2, 0.2, -0.2], [0.45, -0.45, 0.45, -0.45]])
    z = solve_soft_qp_osqp(q, w)
    pos = np.concatenate([z[q.x_index(k)][:4] for k in range(1, q.N + 1)])
    assert np.abs(pos).max() <= 0.5 + 1e-7 and np.abs(q.inputs(z)).max() <= 0.5 + 1e-7
    assert np.abs(q.F @ z - q.b(w)).max() < 1e-7


@pytest.mark.parametrize("spec", ["masses.yaml", "masses_rate_soft.yaml"])
def test_warm_start_shift_keeps_the_dynamics(spec):
    """The shift by one stage (shift_stages, the C's WARM_SRC and the RTL's warmSource) moves the decision inputs
    with the states in both forms: the shifted optimum meets x~_{k+1} = A~ x~_k + B~ v_k at every stage but the
    repeated last one, from the state it predicted for the next step."""
    q = build_admm_qp(load_spec(EXAMPLES / spec))
    rng = np.random.default_rng(2)
    w = rng.uniform(q.wlo, q.whi) * 0.5
    z = solve_soft_qp_osqp(q, w)
    zs = shift_stages(z, q.N, q.nu)
    w1 = np.concatenate([z[q.x_index(1)], w[q.nx:]])          # x~_1 of the optimum (with u_0 in the rate form)
    res = q.F @ zs - q.b(w1)
    assert np.abs(res[: q.N * q.nx]).max() < 1e-6
    assert np.array_equal(zs[q.du_index(q.N - 1)], z[q.du_index(q.N - 1)])
    assert np.array_equal(q.inputs(zs)[: q.N - 1], q.inputs(z)[1:])


# ---------------------------------------------------------------------------
# designs


@pytest.mark.parametrize("method", [design_admm, design_ama, design_vucondat])
@pytest.mark.parametrize("prob", [masses, masses_state])
def test_designs_accept_specs_without_input_rate(method, prob):
    d = method(prob(), sizing_solves=8)
    assert not d.rate and (d.n, d.nw) == (128, 12)
    cfg = d.config()
    assert cfg["rate"] is False and not AdmmFixed(cfg).rate
    # one penalty for every component: no du to scale and no soft pairs here
    assert len(set(d.shift.tolist())) == 1
    if d.method == "ama":
        # H_A positive definite on Ker F: the u_k carry 2 R = 2 I, so mu >= 2
        assert d.mu > 2 - 1e-9 and d.rho_vec.max() < 2 * d.mu
    if d.method == "admm":
        assert d.assumption2["ok_i"] and d.assumption2["ok_ii"]


def test_rate_configs_unchanged():
    """A rate-augmented design's config.json has no `rate` key (read as true), so its cores stay as they were."""
    d = design_admm(load_spec(EXAMPLES / "masses_rate_soft.yaml"), sizing_solves=2)
    assert d.rate and "rate" not in d.config() and AdmmFixed(d.config()).rate


def test_du_scale_refused_without_input_rate():
    with pytest.raises(DesignError, match=r"^du_scale: the spec has no input_rate section"):
        design_admm(masses(), du_scale=4)
    d = yaml.safe_load((EXAMPLES / "masses.yaml").read_text())
    d["solver"]["du_scale"] = 2
    with pytest.raises(DesignError, match=r"^du_scale: the spec has no input_rate section"):
        design_ama(problem_from_dict(d))
    # the other penalty options keep their meaning
    assert design_admm(masses(), rho=4, soft_scale=8, sizing_solves=2).rho == 4


def test_report_states_the_form():
    plain = design_report(masses_design())
    assert "nw = 12" in plain and "Form: w = (x, r), u_0 out" in plain and "du scaled" not in plain
    rate = design_report(design_admm(load_spec(EXAMPLES / "masses_rate_soft.yaml"), sizing_solves=2))
    assert "nw = 16" in rate and "Form: w = (x, u_prev, r), du_0 out" in rate


def test_applied_input_is_u0():
    d = masses_design()
    z = np.zeros(d.n)
    z[:4] = [0.7, -0.2, 0.1, -0.9]
    assert np.array_equal(applied_input(d, z, None), [0.5, -0.2, 0.1, -0.5])
    assert np.array_equal(applied_input(d, z, np.ones(4)), [0.5, -0.2, 0.1, -0.5])   # u_prev plays no part


# ---------------------------------------------------------------------------
# the golden model against the float64 references


@functools.lru_cache(maxsize=None)
def optimal_loop(seed=0, steps=30, hold=10):
    p = masses()
    return run_closed_loop(p, AdmmOsqpController(p), np.zeros(p.nx), admm_references(p, steps, hold, seed))


def test_golden_model_converges_to_osqp(record_property):
    """Warm-started along the optimal loop's parameters w = (x, r), the bit-exact model's u_0 approaches the OSQP
    optimum's with Imax until the round-off of b = 16 (measured max |u_0 - u_0*|: 0.020 at Imax = 15, 0.0017 at
    40, 2.2e-4 at 100 and at 300); AdmmFloat on the same data reaches it (2.6e-13 at 300)."""
    d = masses_design()
    W = parameters(optimal_loop(), rate=False)
    Z = [solve_soft_qp_osqp(d.qp, w) for w in W]
    err = {}
    for imax in (15, 40, 100):
        m = AdmmFixed(d)
        err[imax] = max(float(np.abs(applied_input(d, m.solve(quantize(w, d.b), imax=imax).z / float(1 << d.b), None)
                                     - applied_input(d, z, None)).max()) for w, z in zip(W, Z))
    f = AdmmFloat(d)
    err_float = max(float(np.abs(f.solve(w, imax=300)[0] - z).max()) for w, z in zip(W, Z))
    record_property("u0_err", err)
    record_property("float64_z_err_300", err_float)
    print(f"\nmax |u_0 - u_0*|: {err}; float64 max |z - z*| at Imax = 300: {err_float:.3g}")
    # the fixed-point bounds about 4x above the measured values (err[15] / err[40] measured 12); float64 converges
    # to OSQP's own accuracy, 1e-9 as in the float C variant's test
    assert err[15] < 0.08 and err[40] < err[15] / 5 and err[100] < 1e-3
    assert err_float < 1e-9


def test_closed_loop_plain_masses(record_property):
    """30 steps on masses.yaml, references over 80 % of their box changing every 10 steps (the input box active):
    the golden model (b = 16) within the input box, without saturation, close to the OSQP loop's cost. Measured
    gaps (percent above the optimal cost, reference seeds 0, 1, 2): Imax = 15: +0.030, -0.011, +0.001; Imax = 40:
    +0.0044, +0.0047, -0.0021; float64 at Imax = 40: +0.0021 on seed 0. The bounds are about 3x and 4x the largest
    of them: 0.1 % at Imax = 15, 0.02 % at Imax = 40."""
    p = masses()
    opt = optimal_loop()
    assert rate_and_box_ok(p, opt)
    d = masses_design()
    gap = {}
    for imax in (15, 40):
        ctrl = AdmmFixedController(d, imax=imax)
        t = run_closed_loop(p, ctrl, np.zeros(p.nx), opt.r)
        assert ctrl.overflow_steps == 0 and ctrl.sat_steps == 0
        assert rate_and_box_ok(p, t)
        assert np.abs(t.u).max() == pytest.approx(0.5)           # the input box is active
        assert len(ctrl.words) == len(opt.r) and all(len(wd) == p.nu for wd in ctrl.words)
        gap[imax] = 100 * (t.cost / opt.cost - 1)
    t = run_closed_loop(p, AdmmFloatController(d), np.zeros(p.nx), opt.r)
    gap["float64"] = 100 * (t.cost / opt.cost - 1)
    record_property("closed_loop_gap_percent", gap)
    print(f"\nclosed-loop cost above OSQP (J* = {opt.cost:.4g}): "
          + ", ".join(f"{k}: {v:+.4f} %" for k, v in gap.items()))
    assert abs(gap[15]) < 0.1 and abs(gap[40]) < 0.02 and abs(gap["float64"]) < 0.02
