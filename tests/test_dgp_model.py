"""The DGP golden model (iteration (35) of 003) on examples/masses_state.yaml: rounding of one iteration within
(33)/(34), the fixed-point runs against float64 on the same quantised data, the returned solutions against OSQP
(eps_V, eps_g of the design), the warm-start state, the input saturation flag, the refusals of the design flow,
the closed-loop controllers, and (slow) the guarantee of the plain form over 500 random states."""
import functools
import math
import re
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import yaml

from mpc_cores.closedloop import reference_schedule, run_closed_loop
from mpc_cores.dgp.control import DgpFixedController, DgpOsqpController, controllers
from mpc_cores.dgp.design import design_dgp
from mpc_cores.dgp.model import DgpFixed, dgp_float
from mpc_cores.dgp.problem import solve_osqp
from mpc_cores.dgp.study import accuracy, dual_box_check, guarantee, random_parameters, solve_cold
from mpc_cores.errors import DesignError
from mpc_cores import registry
from mpc_cores.problem import load_spec, problem_from_dict

SPEC = Path(__file__).resolve().parent.parent / "examples" / "masses_state.yaml"
IMAX_PLAIN = 20000        # the plain form from y = 0 on the box of masses_state needs up to ~6000 iterations
STATES = 30


@functools.lru_cache(maxsize=None)
def problem():
    """masses_state with references up to +-0.45 (the example holds them to the +-0.35 its state box accepts):
    more of the random parameters put the state rows on their limits"""
    d = yaml.safe_load(SPEC.read_text())
    d["tracking"].update(min=-0.45, max=0.45)
    return problem_from_dict(d, "masses_state")


@functools.lru_cache(maxsize=None)
def design(accelerated: bool):
    return design_dgp(problem(), accelerated=accelerated)


@functools.lru_cache(maxsize=None)
def params():
    """STATES parameter words uniform in the accepted box (states) and the reference box"""
    return random_parameters(design(True), STATES, seed=7)


@functools.lru_cache(maxsize=None)
def cold(accelerated: bool, clamp: bool = True):
    """The fixed-point solves of params() from y = 0, run to the stopping test (clamp: the output words clamped to
    the input box, as the core streams them; False: the iteration's own answer)"""
    d = design(accelerated)
    return solve_cold(DgpFixed(d, clamp=clamp), params(), IMAX_PLAIN if not accelerated else d.iterations)


def quantised_qp(d):
    """The QP the words describe, in real numbers, for dgp_float: the same K, Fe, G, bounds and thresholds as the
    fixed-point model, so that the two runs differ by the rounding of the products only (and the beta words)."""
    one = float(1 << d.b)
    K, Fe, G = d.K / one, d.Fe / one, d.G / one
    Lw = d.Lb / one + G @ Fe                  # the core's bounds are relative to G e (design.bound_rows)
    lo0, hi0 = d.lo0 / one, d.hi0 / one
    return SimpleNamespace(K=K, Fe=Fe, G=G, mc=d.mc, n=d.n, sigma=d.eg / one / d.eps_g,
                           bounds=lambda w: (lo0 + Lw @ w, hi0 + Lw @ w))


def float_run(d, i: int, imax: int):
    one = float(1 << d.b)
    return dgp_float(quantised_qp(d), params()[i] / one, imax, d.accelerated, d.eps_g, d.eV / one, ud=d.ud / one)


def eps_z_xi(d) -> tuple[float, float]:
    """(33), (34) of 003 in LSB: eps_z = 2^-(p+1) m sqrt(n), eps_xi = 2^-(p+1) n sqrt(m), m = 2 mc dual rows."""
    m, n = 2 * d.mc, d.n
    return m * math.sqrt(n) / 2, n * math.sqrt(m) / 2


# ---------------------------------------------------------------------------
# rounding


def test_one_iteration_within_the_rounding_of_33_34():
    """One iteration from the same dual: the only difference between the fixed-point and the float64 run on the
    quantised data is the rounding of each product to nearest (<= 1/2 LSB), so
      |dz_i| <= (mc + nw) / 2          (z_i sums mc products K v and nw products Fe w; (33) per row)
      |dy_i| <= ||G||_inf max|dz| + n / 2 + nw / 2   (g = G z - bound: n products, the bound nw products; (34))"""
    d = design(False)
    one = float(1 << d.b)
    m = DgpFixed(d)
    rng = np.random.default_rng(3)
    W = params()[:10]
    Y0 = (rng.uniform(0, 1, (len(W), 2 * d.mc)) * d.ud / 4).astype(np.int64)
    r = m.solve_batch(W, imax=1, y0=Y0)         # plain, one iteration: the output is z itself
    qq = quantised_qp(d)
    bz = (d.mc + d.nw) / 2
    by = float(np.abs(d.G).sum(axis=1).max()) / one * bz + d.n / 2 + d.nw / 2
    dzs, dys = [], []
    for i in range(len(W)):
        z, it, _, y = dgp_float(qq, W[i] / one, 1, False, d.eps_g, d.eV / one, ud=d.ud / one, y0=Y0[i] / one)
        dzs.append(np.abs(r.zraw[i] - z * one).max())     # the iteration's z (before the output clamp)
        dys.append(np.abs(r.y[i] - y * one).max())
    assert max(dzs) <= bz + 1e-3, (max(dzs), bz)
    assert max(dys) <= by + 1e-3, (max(dys), by)
    assert max(dzs) > 0                          # the runs do round differently


@pytest.mark.parametrize("accelerated", [False, True], ids=["plain", "accelerated"])
def test_fixed_tracks_float64(accelerated):
    """Whole solves from y = 0: the same iterations and stopping decisions as float64 on the quantised data, and
    answers within one oracle error of (33): ||z_fix - z_float||_2 <= eps_z + 1 LSB (the averaged primal's own
    rounding), the final duals within the gradient error of one iteration, eps_xi + ||A||_2 eps_z ((12)-(13) of
    003). So the test checks that the roundings of many iterations do not add up (the dual map y -> [y + g(y)]+
    is nonexpansive, and contracts on the active rows): a drift of the fixed-point run away from float64, or an
    off-by-one in the stopping decision, fails it."""
    d = design(accelerated)
    r = cold(accelerated)
    ez, exi = eps_z_xi(d)
    A2 = math.sqrt(2) * float(np.linalg.norm(d.qp.G, 2))        # A = [G; -G], scaled
    one = float(1 << d.b)
    count = 6 if not accelerated else STATES
    for i in range(count):
        z, it, met, y = float_run(d, i, IMAX_PLAIN)
        assert (int(r.iterations[i]), bool(r.met[i])) == (it, met), i
        # the output words are clamped to the quantised input box, a projection (nonexpansive): clamp float64's too
        assert np.linalg.norm(r.z[i] - np.clip(z * one, d.out_lo, d.out_hi)) <= ez + 1, i
        assert np.linalg.norm(r.y[i] - y * one) <= exi + A2 * ez, i


# ---------------------------------------------------------------------------
# against OSQP


@pytest.mark.parametrize("accelerated", [False, True], ids=["plain", "accelerated"])
def test_solutions_meet_eps_V_and_eps_g(accelerated):
    """From y = 0 on STATES random parameters of the box: every solve meets its stopping test and its answer is an
    (eps_V, eps_g)-solution of the QP against OSQP (real units, the design's eps). The guarantee is the
    iteration's, on its answer before the output clamp (the clamped words: test_output_words_meet_the_input_box)."""
    d = design(accelerated)
    r = cold(accelerated, clamp=False)
    assert r.met.all(), r.iterations
    assert not r.sat.any() and not r.overflow.any()
    dV, viol, active = accuracy(d, params(), r.z)
    assert active.any(axis=1).sum() >= STATES // 3      # the states exercise the constraints
    assert dV.max() <= d.eps_V, dV.max()
    assert viol.max() <= d.eps_g, viol.max()
    assert active[:, 0].any() and active[:, 1].any()    # input rows and state rows
    # below V* by no more than weak duality allows: V* <= L(z, y*) = V(z) + y*'(A z - b) <= V(z) + y*'[A z - b]+
    one = float(1 << d.b)
    for i, (w, z) in enumerate(zip(params() / one, r.z / one)):
        _, yp, ym, _ = solve_osqp(d.qp, w)
        lo, hi = d.qp.bounds(w)
        s = d.qp.G @ z
        assert dV[i] >= -(yp @ np.maximum(s - hi, 0) + ym @ np.maximum(lo - s, 0)) - 1e-7, i


def test_output_words_meet_the_input_box():
    """examples/masses.yaml with Imax = 4: the iteration's answer leaves the input box (by up to eps_g and more
    when the test is not met), the returned words are that answer clamped to the quantised box [out_lo, out_hi]
    (ceil / floor of umin / umax), and the iteration itself is unchanged (iterations, flags, final dual)."""
    p = load_spec(Path(__file__).resolve().parent.parent / "examples" / "masses.yaml")
    d = design_dgp(p, iterations=4)
    one = 1 << d.b
    assert np.array_equal(d.out_lo, np.ceil(np.tile(p.umin, p.N) * one).astype(np.int64))
    assert np.array_equal(d.out_hi, np.floor(np.tile(p.umax, p.N) * one).astype(np.int64))
    assert d.config()["out_lo"] == d.out_lo.tolist() and d.config()["out_hi"] == d.out_hi.tolist()
    W = random_parameters(d, 40, seed=3)
    r = DgpFixed(d).solve_batch(W)
    u = DgpFixed(d, clamp=False).solve_batch(W)
    outside = np.any((u.z < d.out_lo) | (u.z > d.out_hi), axis=1)
    assert outside.sum() >= 5, outside.sum()                    # the unclamped answers do leave the box
    assert np.all((r.z >= d.out_lo) & (r.z <= d.out_hi))
    assert np.array_equal(r.z, np.clip(u.z, d.out_lo, d.out_hi)) and np.array_equal(r.zraw, u.z)
    assert np.all((r.z[:, : d.nu] / one >= p.umin) & (r.z[:, : d.nu] / one <= p.umax))    # u0 in the real box
    for f in ("iterations", "met", "sat", "overflow", "y"):
        assert np.array_equal(getattr(r, f), getattr(u, f)), f


# ---------------------------------------------------------------------------
# warm start, input saturation


@pytest.mark.parametrize("accelerated", [False, True], ids=["plain", "accelerated"])
def test_warm_start_state(accelerated):
    d = design(accelerated)
    imax = IMAX_PLAIN if not accelerated else d.iterations
    r0 = cold(accelerated)
    idx = [int(i) for i in np.argsort(r0.iterations)[-3:]]        # the slowest states of the set
    if not accelerated:
        idx = idx[:1]
    m = DgpFixed(d)
    assert m.warm_start == d.warm_start
    for i in idx:
        w = params()[i]
        m.reset()
        a = m.solve(w, imax=imax, warm=True)                      # nothing stored: cold
        assert (a.iterations[0], a.z[0].tolist()) == (r0.iterations[i], r0.z[i].tolist())
        assert np.array_equal(m.y_prev, a.y[0])
        # a zero start: the starting dual all zero (every cold start), a slow state leaves a nonzero one
        assert a.zero_start[0] and a.y[0].any()
        b = m.solve(w, imax=imax, warm=True)                      # from the stored dual
        assert not b.zero_start[0]
        assert b.met[0] and b.iterations[0] <= a.iterations[0], (a.iterations[0], b.iterations[0])
        assert np.array_equal(m.y_prev, b.y[0])
        c = m.solve(w, imax=imax, warm=False)                     # the stored dual ignored
        assert (c.iterations[0], c.z[0].tolist()) == (a.iterations[0], a.z[0].tolist())
        m.solve(w, imax=imax, warm=True)
        m.reset()
        assert m.y_prev is None
        e = m.solve(w, imax=imax, warm=True)                      # cleared: cold again
        assert (e.iterations[0], e.z[0].tolist(), e.y[0].tolist()) == (a.iterations[0], a.z[0].tolist(),
                                                                        a.y[0].tolist())


def test_shifted_warm_start():
    """warm_shift: each dual word starts from the same row a stage later (the input rows 4 on, the position rows 4
    on; the last stage's from zero), clipped to its own dual box, which the stage envelope makes at least as wide
    as its source's ((36) and (37) taken on it); the plain form is refused; a closed loop of masses_state under the shifted
    warm start meets the test in every step with (eps_V, eps_g)-answers (the gap test bounds V(z) - V* from any start
    in the dual box), and the start of a step after a first-stage-only dual is a zero start."""
    d = design_dgp(problem(), warm_shift=True)
    cfg = d.config()
    mc, src = d.mc, np.array(cfg["shift_src"])
    assert mc == 80 and design(True).config()["shift_src"] == []
    upper = np.r_[np.arange(4, 40), [-1] * 4, np.arange(44, 80), [-1] * 4]
    assert src.tolist() == upper.tolist() + np.where(upper >= 0, upper + mc, -1).tolist()
    # the dual box's stage envelope: no row's box narrower than its source's, the sampled box raised where it was
    ud0 = design(True).ud
    assert all(d.ud[i] >= d.ud[j] for i, j in enumerate(src) if j >= 0)
    assert np.all(d.ud >= ud0) and np.any(d.ud > ud0)
    with pytest.raises(DesignError, match="warm_shift needs the accelerated form"):
        design_dgp(problem(), accelerated=False, warm_shift=True)
    # the dual in block RAM: the accelerated form only; with the shift, each row's source in the same unit (4 rows per
    # stage: P = 2 and 4 pass, 3 is refused in one line naming the rule and the values)
    with pytest.raises(DesignError, match="ram_state needs the accelerated form"):
        design_dgp(problem(), accelerated=False, ram_state=True)
    for P in (2, 4):
        assert design_dgp(problem(), warm_shift=True, ram_state=True, P=P).config()["ram_state"]
    with pytest.raises(DesignError, match=r"multiple of P .*: rows per stage \[4\], P=3$"):
        design_dgp(problem(), warm_shift=True, ram_state=True, P=3)
    assert design_dgp(problem(), ram_state=True, P=3).ram_state                # no shift: any P
    m = DgpFixed(d)
    y = np.random.default_rng(3).integers(0, 2 * d.ud + 1)           # up to twice the box: the clip shows
    y0 = m.warm_dual(y)
    for i in range(2 * mc):
        assert y0[i] == (0 if src[i] < 0 else min(y[src[i]], d.ud[i])), i
    assert (y0 < y[np.maximum(src, 0)]).any()                          # some words clipped
    # a dual on the first stage's rows only: the shifted start is zero, a zero start
    y1 = np.zeros(2 * mc, dtype=np.int64)
    y1[[0, mc + 40]] = d.ud[[0, mc + 40]]
    assert not m.warm_dual(y1).any()
    m.y_prev = y1
    assert m.solve(params()[0]).zero_start[0]
    # the closed loop
    p = problem()
    _, gold, holdable = controllers(d)
    refs = reference_schedule(p, 35, 5, 3, holdable=holdable)       # rows active at steps 25 to 30
    run_closed_loop(p, gold, np.zeros(p.nx), refs)
    assert all(gold.met)
    replay = DgpFixed(d, clamp=False)
    W = np.array(gold.w)
    rs = [replay.solve(w) for w in W]
    assert [int(r.iterations[0]) for r in rs] == list(gold.iterations)
    assert sum(not r.zero_start[0] for r in rs) >= 3                # warm starts from nonzero shifted duals
    z = np.array([r.zraw[0] for r in rs])
    dV, viol, _ = accuracy(d, np.clip(W, d.xlo, d.xhi), z)
    assert dV.max() <= d.eps_V and viol.max() <= d.eps_g, (dV.max(), viol.max())


def test_input_saturation_flag():
    """A state outside the accepted box raises `sat` and is solved as the state clipped into the box."""
    d = design(True)
    m = DgpFixed(d)
    w = params()[0].copy()
    inside = m.solve_batch(w[None])
    assert not inside.sat[0]
    out = w.copy()
    out[0] = d.xhi[0] + (1 << d.b) // 5                           # p1 0.2 m beyond the box
    out[5] = d.xlo[5] - 1                                         # v2 one LSB below it
    r = m.solve_batch(out[None])
    assert r.sat[0] and not r.overflow[0]
    clipped = np.clip(out, d.xlo, d.xhi)
    c = m.solve_batch(clipped[None])
    assert not c.sat[0]
    assert (r.iterations[0], r.z[0].tolist()) == (c.iterations[0], c.z[0].tolist())


def test_dual_box_bounds_y_star_at_the_vertices():
    """(14) of 003: d_i >= y*_i for every parameter of the accepted box (Remark 1: uniform bounds); at least at
    its vertices, and y* inside the projection box [0, alpha d], without which (35) converges to the exact penalty
    problem (16) with too small weights, not to the QP's solution."""
    c = dual_box_check(design(True), run=False)
    assert c.above_box == 0, c
    assert c.above_d == 0, c


# ---------------------------------------------------------------------------
# refusals of the design flow


def spec(**changes) -> dict:
    d = yaml.safe_load(SPEC.read_text())
    d.update(changes)
    return d


@pytest.mark.parametrize("key,value", [
    ("input_rate", {"min": -0.3, "max": 0.3, "weight": 0.1}),
    ("soft_states", {"indices": [4, 5], "min": -1.0, "max": 1.0, "sigma1": 8, "sigma2": 1}),
])
def test_refuses_other_constraint_sections(key, value):
    p = problem_from_dict(spec(**{key: value}), "m")
    with pytest.raises(DesignError) as e:
        design_dgp(p)
    msg = str(e.value)
    assert key in msg and "\n" not in msg and msg.strip() == msg


def test_refuses_int_bits_below_37():
    d = design(True)
    with pytest.raises(DesignError, match=r"\(37\)") as e:
        design_dgp(problem(), int_bits=d.bits37 - 1)
    assert "\n" not in str(e.value)
    assert design_dgp(problem(), int_bits=d.bits37).widths["data"] == d.bits37 + d.b
    # wider words than the exact products of the model and the C solver allow (40 bits) are refused too; without
    # frac_bits the flow narrows p to fit, and the (eps_g, eps_V) guarantee is then not certified
    with pytest.raises(DesignError, match="at most 40") as e:
        design_dgp(problem(), int_bits=41 - d.b, frac_bits=d.b)
    assert "\n" not in str(e.value)
    narrow = design_dgp(problem(), int_bits=41 - d.b)
    assert narrow.b == min(16, d.b - 1) < narrow.bits36
    assert "NOT CERTIFIED" in registry.get("dgp").design_report(narrow)


def test_refuses_a_box_with_infeasible_states():
    """|p| <= 0.5 at stage 1 cannot be met from p = 1.5 m with |u| <= 0.5 N: the flow names such a state."""
    p = problem_from_dict(spec(states={"min": -1.5, "max": 1.5}), "m")
    with pytest.raises(DesignError) as e:
        design_dgp(p)
    msg = str(e.value)
    assert "\n" not in msg
    m = re.search(r"x = (\[[^\]]*\])", msg)
    assert m, msg
    x = np.array(yaml.safe_load(m.group(1)), dtype=float)
    assert x.shape == (p.nx,) and np.all(np.abs(x) <= 1.5 + 1e-9)
    qp = design(True).qp
    assert solve_osqp(qp, np.concatenate([x, np.zeros(p.ny)]))[3] != "solved"


# ---------------------------------------------------------------------------
# closed-loop controllers


def test_controllers_closed_loop():
    d = design(True)
    opt, gold, holdable = controllers(d)
    assert isinstance(opt, DgpOsqpController) and isinstance(gold, DgpFixedController)
    p = problem()
    steps = 20
    refs = reference_schedule(p, steps, 5, 1, holdable=holdable)
    assert np.all(np.abs(refs) <= p.hard_states.xmax[0])          # held positions inside the position limits
    t_opt = run_closed_loop(p, opt, np.zeros(p.nx), refs)
    t_fix = run_closed_loop(p, gold, np.zeros(p.nx), refs)
    assert len(gold.words) == len(gold.iterations) == len(gold.met) == steps and all(gold.met)
    assert np.array_equal(np.array(gold.words) / (1 << d.b), t_fix.u)
    assert max(gold.iterations) <= d.iterations
    assert np.all(np.abs(t_fix.u) <= p.umax + d.eps_g)
    assert abs(t_fix.cost - t_opt.cost) <= 0.02 * t_opt.cost
    gold.reset()
    assert gold.words == [] and gold.model.y_prev is None


# ---------------------------------------------------------------------------
# the guarantee (slow: ~1 min)


@pytest.mark.slow
def test_guarantee_500_states():
    """Over 500 random states of the box, the plain form from y = 0 (Corollary 1 of 003) stops at its test (32c)
    with an averaged primal that meets the eps_V and eps_g the design was made for."""
    g = guarantee(500, IMAX_PLAIN)
    assert g.met == g.states, g.iterations.max()
    assert g.dV.max() <= g.eps_V, g.dV.max()
    assert g.viol.max() <= g.eps_g, g.viol.max()
