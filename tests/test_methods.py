"""The splitting family (ADMM, AMA, Vu-Condat) and the DGP of mpc_cores.methods in float64: convergence to OSQP's
solution on small random problems (input rate, soft and hard state constraints), acceleration with restart, the
power-of-two preconditioner (factors, unchanged solution, its equivalence with other steps), the closed-loop
controllers and the table of `make methods` on small data."""
import functools
import json

import numpy as np
import pytest
from conftest import random_problem

from mpc_cores.admm.design import design_admm, kkt_blocks
from mpc_cores.admm.problem import build_admm_qp, solve_soft_qp_osqp
from mpc_cores.admm.control import AdmmOsqpController
from mpc_cores.closedloop import reference_schedule, run_closed_loop
from mpc_cores.dgp.control import DgpOsqpController
from mpc_cores.dgp.model import dgp_float
from mpc_cores.dgp.problem import dgp_qp, solve_osqp
from mpc_cores.methods import (SPLITTING, DgpFloatController, SplitController, SplitSetup, Tracker,
                               dgp_precondition, dgp_run, pow2_below, reduced_curvature, ruiz_pow2, scale_qp,
                               split_run, split_setup, splitting_problem)
from mpc_cores.methods_table import Config, markdown, run, write

STATES = 6


@functools.lru_cache(maxsize=None)
def soft_problem():
    """Input rate, a soft state pair and a hard state box (the ADMM family only)."""
    return random_problem("mt_soft", 3, 2, 5, 1, 11, states={"min": -0.8, "max": 0.8},
                          input_rate={"min": -0.3, "max": 0.3, "weight": 0.05},
                          soft_states={"indices": [0], "min": -0.4, "max": 0.4, "sigma1": 8.0, "sigma2": 1.0},
                          hard_states={"indices": [1], "min": -1.5, "max": 1.5})


@functools.lru_cache(maxsize=None)
def hard_problem():
    """Input box and hard state limits only: every method, DGP included."""
    return random_problem("mt_hard", 3, 2, 5, 1, 12, states={"min": -1.0, "max": 1.0},
                          inputs={"min": -0.3, "max": 0.3}, hard_states={"indices": [0, 1], "min": -1.2, "max": 1.2})


@functools.lru_cache(maxsize=None)
def admm_case(which: str):
    """(qp, the design's rho_j, parameters, OSQP solutions) of the splitting family's QP."""
    p = splitting_problem(soft_problem() if which == "soft" else hard_problem())
    qp = build_admm_qp(p)
    rho = design_admm(p, sizing_solves=2).rho_vec
    rng = np.random.default_rng(3)
    W = rng.uniform(qp.wlo, qp.whi, size=(STATES, qp.nw))
    Z = np.array([solve_soft_qp_osqp(qp, w, eps=1e-10) for w in W])
    return qp, rho, W, Z


@functools.lru_cache(maxsize=None)
def dgp_case():
    p = hard_problem()
    q = dgp_qp(p)
    rng = np.random.default_rng(4)
    W = rng.uniform(np.concatenate([p.xmin, p.rmin]), np.concatenate([p.xmax, p.rmax]), size=(STATES, q.nw))
    Z = np.array([solve_osqp(q, w, eps=1e-10)[0] for w in W])
    return q, W, Z


def rel_err(z, Z):
    return np.linalg.norm(z - Z, axis=1) / np.maximum(np.linalg.norm(Z, axis=1), 1e-9)


# --------------------------------------------------------------------------
# convergence to OSQP


@pytest.mark.parametrize("which", ["soft", "hard"])
@pytest.mark.parametrize("method", SPLITTING)
@pytest.mark.parametrize("accelerated", [False, True])
@pytest.mark.parametrize("pre", [False, True])
def test_splitting_converges_to_osqp(which, method, accelerated, pre):
    qp, rho, W, Z = admm_case(which)
    st = split_setup(qp, method, rho, precondition=pre)
    # plain AMA (a dual gradient method, sublinear where the dual is not strongly concave) gets more iterations
    res = split_run(st, W, 20000 if method == "ama" and not accelerated else 4000, accelerated)
    z = st.unscale(res.z)
    err = rel_err(z, Z)
    assert err.max() < 1e-6, f"{method}: relative errors {err}"
    # the returned z lies in K (boxes of the original QP)
    box = qp.kind == 1
    assert np.all(z[:, box] >= qp.lo[box] - 1e-12) and np.all(z[:, box] <= qp.hi[box] + 1e-12)


@pytest.mark.parametrize("accelerated", [False, True])
@pytest.mark.parametrize("pre", [False, True])
def test_dgp_converges_to_osqp(accelerated, pre):
    q, W, Z = dgp_case()
    if pre:
        q = dgp_precondition(q)[0]
    z, _ = dgp_run(q, W, 20000 if not accelerated else 3000, accelerated)
    err = rel_err(z, Z)
    # the plain form returns the averaged primal, which converges as O(1/k)
    assert err.max() < (1e-2 if not accelerated else 1e-6), err


@pytest.mark.parametrize("accelerated", [False, True])
def test_dgp_run_is_dgp_float(accelerated):
    """The batch iteration is mpc_cores.dgp.model.dgp_float with its stopping tests disabled, row by row."""
    q, W, _ = dgp_case()
    z, y = dgp_run(q, W, 37, accelerated)
    for i, w in enumerate(W):
        zf, it, met, yf = dgp_float(q, w, 37, accelerated, -np.inf, -np.inf)
        assert it == 37 and not met
        np.testing.assert_allclose(z[i], zf, rtol=0, atol=1e-12)
        np.testing.assert_allclose(y[i], yf, rtol=0, atol=1e-12)


@pytest.mark.parametrize("method", SPLITTING)
def test_plain_iterations_are_the_cores_float_model(method):
    """The plain iterations here are those of the ADMM core's float model (mpc_cores.admm.model.AdmmFloat) with
    the same `method` and the design's steps (Vu-Condat: the design keeps sigma_j = rho_j / 2), cold start."""
    from mpc_cores.admm.model import AdmmFloat

    p = splitting_problem(soft_problem())
    base = design_admm(p, sizing_solves=2)
    d = design_admm(p, sizing_solves=2, method=method)
    _, _, W, _ = admm_case("soft")
    st = split_setup(base.qp, method, base.rho_vec)
    res = split_run(st, W, 25, False)
    model = AdmmFloat(d)
    for i, w in enumerate(W):
        z, nu, _ = model.solve(w, imax=25, warm=False)
        np.testing.assert_allclose(res.z[i], z, rtol=0, atol=1e-9)
        np.testing.assert_allclose(res.nu[i], nu, rtol=0, atol=1e-9)


def test_ama_step_below_twice_mu():
    qp, rho, _, _ = admm_case("soft")
    st = split_setup(qp, "ama", rho)
    mu = reduced_curvature(qp)
    assert st.mu == pytest.approx(mu)
    r = float(st.rho[0])
    assert np.all(st.rho == r) and r < 2 * mu <= 2 * r
    assert np.frexp(r)[0] == 0.5
    assert pow2_below(4.0) == 2.0 and pow2_below(4.5) == 4.0


def test_splitting_problem_keeps_the_inputs():
    """A spec without input_rate gets a rate box that cannot bind and no rate weight: same inputs as the DGP's QP."""
    qp, _, W, Z = admm_case("hard")
    q, _, _ = dgp_case()
    p = hard_problem()
    for w, z in zip(W[:3], Z[:3]):
        wd = np.concatenate([w[: p.nx], w[p.nx + p.nu:]])
        zd = solve_osqp(q, wd, eps=1e-10)[0]
        np.testing.assert_allclose(qp.inputs(z).reshape(-1), zd, atol=1e-6)


def test_tracker_counts_from_where_the_error_stays_below():
    Z = np.array([[1.0, 0.0], [0.0, 2.0]])
    tr = Tracker(Z, (1e-3,))
    for e0, e1 in [(1.0, 0.5), (1e-4, 0.5), (1e-2, 1e-4), (1e-4, np.nan), (1e-5, 1e-5)]:
        tr(Z + np.array([[e0, 0.0], [0.0, 2.0 * e1]]))
    # row 0 dips below at 2, rises at 3, stays below from 4; row 1 is nan at 4 (diverged) and below only at 5
    assert tr.iterations(1e-3) == [4, 5]
    tr(np.full((2, 2), np.inf))
    assert tr.iterations(1e-3) == [None, None]


# --------------------------------------------------------------------------
# acceleration with restart


def _iterations(st_or_q, W, Z, cap, accelerated, dgp=False, tol=1e-6):
    tr = Tracker(Z, (tol,))
    if dgp:
        dgp_run(st_or_q, W, cap, accelerated, track=tr)
    else:
        split_run(st_or_q, W, cap, accelerated, track=tr)
    its = tr.iterations(tol)
    assert all(i is not None for i in its), f"not converged to {tol} in {cap} iterations: {its}"
    return np.array(its)


@pytest.mark.parametrize("which", ["soft", "hard"])
def test_fast_ama_with_restart_needs_fewer_iterations(which):
    """AMA is a proximal gradient method on the dual: Nesterov's momentum with the gradient restart must beat it
    (on the parameters with an active constraint; the others are solved by the first y-step)."""
    qp, rho, W, Z = admm_case(which)
    st = split_setup(qp, "ama", rho)
    plain = _iterations(st, W, Z, 20000, False)
    fast = _iterations(st, W, Z, 4000, True)
    act = plain > 1
    assert act.sum() >= 4, plain
    assert np.all(fast[act] < plain[act]), (fast, plain)
    assert np.median(fast[act]) * 1.5 < np.median(plain[act]), (fast, plain)


def test_accelerated_dgp_needs_fewer_iterations():
    q, W, Z = dgp_case()
    plain = _iterations(q, W, Z, 50000, False, dgp=True, tol=1e-3)
    fast = _iterations(q, W, Z, 50000, True, dgp=True, tol=1e-3)
    act = plain > 1
    assert act.sum() >= 4, plain
    assert np.all(fast[act] * 3 < plain[act]), (fast, plain)


def test_restart_keeps_momentum_stable():
    """Without restart Nesterov's momentum on Vu-Condat does not settle on these problems; with the residual
    restart it converges (the claim behind the choice of the table's restart scheme)."""
    qp, rho, W, Z = admm_case("soft")
    st = split_setup(qp, "vucondat", rho)
    good = split_run(st, W, 3000, True, restart="residual")
    assert rel_err(st.unscale(good.z), Z).max() < 1e-6
    with np.errstate(all="ignore"):
        free = split_run(st, W, 3000, True, restart="none")
        e = rel_err(st.unscale(free.z), Z)
    assert not np.all(e < 1e-6), e


# --------------------------------------------------------------------------
# preconditioner


def _is_pow2(a):
    m, _ = np.frexp(np.asarray(a, dtype=float))
    return np.all(m == 0.5)


@pytest.mark.parametrize("which", ["soft", "hard"])
def test_ruiz_factors_are_powers_of_two(which):
    qp, _, _, _ = admm_case(which)
    sc = ruiz_pow2(qp)
    assert _is_pow2(sc.D) and _is_pow2(sc.E) and _is_pow2(sc.cost)
    np.testing.assert_array_equal(sc.D[qp.soft_x], sc.D[qp.soft_d])   # a soft pair shares its factor


def test_ruiz_equilibrates_a_badly_scaled_problem():
    """On a problem with weights spread over 1e-2 .. 1e2 the rounded Ruiz factors bring every row of the KKT matrix
    to an infinity norm within a factor 4 of 1 (rounding to powers of two costs at most 2 per row)."""
    p = random_problem("mt_bad", 3, 2, 4, 1, 13, cost={"Q": [100.0, 1.0, 0.01], "R": [0.01, 50.0]},
                       input_rate={"min": -0.3, "max": 0.3, "weight": 0.05})
    qp = build_admm_qp(p)
    sc = ruiz_pow2(qp)
    K = np.abs(np.block([[qp.H, qp.F.T], [qp.F, np.zeros((qp.F.shape[0],) * 2)]]))
    s = np.concatenate([sc.D, sc.E])
    before = K.max(axis=1)
    after = (s[:, None] * K * s[None, :]).max(axis=1)
    assert before.max() / before.min() > 100
    assert after.max() <= 4 and after.min() >= 0.25


@pytest.mark.parametrize("which", ["soft", "hard"])
def test_preconditioned_qp_has_the_same_solution(which):
    qp, _, W, Z = admm_case(which)
    sc = ruiz_pow2(qp)
    q2 = scale_qp(qp, sc)
    for w, z in zip(W[:3], Z[:3]):
        z2 = solve_soft_qp_osqp(q2, w, eps=1e-10)
        np.testing.assert_allclose(sc.D * z2, z, atol=1e-7)


def test_preconditioning_is_a_change_of_steps():
    """ADMM on the scaled QP with rho_j gives, unscaled, the iterates of ADMM on the original QP with
    rho_j / (c D_j^2): the same datapath with other shifts."""
    qp, rho, W, _ = admm_case("soft")
    pre = split_setup(qp, "admm", rho, precondition=True)
    r2 = pre.effective_rho
    assert _is_pow2(r2)
    M11, G = kkt_blocks(qp, r2)
    same = SplitSetup(method="admm", base=qp, qp=qp, scaling=None, rho=r2, M11=M11, G=G)
    a = split_run(pre, W, 60, False)
    b = split_run(same, W, 60, False)
    np.testing.assert_allclose(pre.unscale(a.z), b.z, atol=1e-8)


@pytest.mark.parametrize("method", SPLITTING)
def test_design_precondition_option(method):
    """`precondition: true` in the design flow: the core's steps are the study's preconditioned steps
    rho_j / (c D_j^2) (D != 1 on this problem), the report names D, and the bit-exact golden model of that core
    follows the float iteration up to round-off: after 800 iterations from cold the gap is below 1e-3 at b = 22 and
    shrinks at least 8-fold from b = 18 to b = 22 (ADMM and Vu-Condat at b = 22: also within 1e-3 of OSQP)."""
    from mpc_cores.admm.model import AdmmFixed
    from mpc_cores.admm.report import design_report
    from mpc_cores.fixed import quantize

    p = splitting_problem(soft_problem())
    qp = build_admm_qp(p)
    d0 = design_admm(p, method=method, sizing_solves=4)
    st = split_setup(qp, method, d0.rho_vec, precondition=True)
    assert np.any(st.scaling.d != 0)
    W = np.random.default_rng(5).uniform(qp.wlo, qp.whi, size=(3, qp.nw))
    gap = {}
    for b in (18, 22):
        d = design_admm(p, method=method, sizing_solves=4, precondition=True, iterations=800, frac_bits=b)
        np.testing.assert_array_equal(d.rho_vec, st.effective_rho)
        m = AdmmFixed(d)
        gap[b] = 0.0
        for w in W:
            wq = quantize(w, b)
            z = m.solve(wq, warm=False).z / float(1 << b)
            f = st.unscale(split_run(st, (wq / float(1 << b))[None], 800, False).z[0])
            gap[b] = max(gap[b], np.abs(z - f).max())
            if b == 22 and method != "ama":
                assert np.abs(z - solve_soft_qp_osqp(qp, wq / float(1 << b), eps=1e-10)).max() < 1e-3
    assert "Preconditioned (power-of-two Ruiz)" in design_report(d)
    assert gap[22] < 1e-3 and gap[22] < gap[18] / 8, gap


def test_dgp_preconditioner_rows_and_solution():
    q, W, Z = dgp_case()
    q2, e = dgp_precondition(q)
    t = None
    for i in range(q.mc):                  # row i scaled by t 2^e_i
        nz = np.abs(q.G[i]) > 1e-12
        r = q2.G[i, nz] / q.G[i, nz]
        np.testing.assert_allclose(r, r[0], rtol=1e-12)
        t = r[0] / 2.0 ** e[i] if t is None else t
        assert r[0] / 2.0 ** e[i] == pytest.approx(t, rel=1e-12)
    # unit Lipschitz constant of the dual gradient, as in mpc_cores.dgp.problem
    L = 2.0 * np.linalg.eigvalsh(q2.G @ np.linalg.solve(q2.Q, q2.G.T))[-1]
    assert L == pytest.approx(1.0)
    for w, z in zip(W[:3], Z[:3]):
        np.testing.assert_allclose(solve_osqp(q2, w, eps=1e-10)[0], z, atol=1e-7)


# --------------------------------------------------------------------------
# closed loop


@pytest.mark.parametrize("method", SPLITTING)
def test_split_controller_with_many_iterations_is_the_osqp_loop(method):
    """Warm-started, preconditioned and accelerated, with enough iterations the loop is OSQP's."""
    p = soft_problem()
    qp, rho, _, _ = admm_case("soft")
    st = split_setup(qp, method, rho, precondition=True)
    refs = reference_schedule(p, 6, 3, 0, holdable=0.0)
    x0 = np.full(p.nx, 0.3)
    opt = run_closed_loop(p, AdmmOsqpController(qp), x0, refs)
    got = run_closed_loop(p, SplitController(st, 3000, True), x0, refs)
    np.testing.assert_allclose(got.u, opt.u, atol=1e-6)


def test_dgp_controller_with_many_iterations_is_the_osqp_loop():
    p = hard_problem()
    q, _, _ = dgp_case()
    refs = reference_schedule(p, 6, 3, 0, holdable=0.9)
    x0 = np.full(p.nx, 0.2)
    opt = run_closed_loop(p, DgpOsqpController(q), x0, refs)
    got = run_closed_loop(p, DgpFloatController(dgp_precondition(q)[0], 3000, True), x0, refs)
    np.testing.assert_allclose(got.u, opt.u, atol=1e-6)


# --------------------------------------------------------------------------
# the table


def test_table_has_every_variant(tmp_path):
    cfg = Config(states=2, cap=60, imax=(8, 3), steps=4, hold=2, design_sizing=2)
    res = run([soft_problem(), hard_problem()], cfg, log=None)
    soft, hard = res["examples"]
    key = lambda r: (r["method"], r["accelerated"], r["preconditioned"])  # noqa: E731
    want = {(m, a, pre) for m in SPLITTING for a in (False, True) for pre in (False, True)}
    assert {key(r) for r in soft["rows"]} == want and len(soft["rows"]) == len(want)
    want_h = want | {("dgp", a, pre) for a in (False, True) for pre in (False, True)}
    assert {key(r) for r in hard["rows"]} == want_h and len(hard["rows"]) == len(want_h)
    for r in soft["rows"] + hard["rows"]:
        assert set(r["loop_cost_pct"]) == set(r["loop_violation"]) == {"8", "3"}
        if r["method"] != "dgp":       # u = clip(u_prev + du_0): the input box always holds
            assert all(v == 0.0 for v in r["loop_violation"].values())
        # every variant is on a core with the default restart schemes (accelerated splitting: accelerated: true)
        assert r["cycles_per_iteration"] is not None and r["hardware"] != "float only"
        if r["method"] != "dgp" and r["accelerated"]:
            assert "accelerated: true" in r["hardware"]
        for tol in ("0.001", "0.0001"):
            s = r["iterations"][tol]
            assert s["of"] == 2 and s["cap"] == 60
    md, js = write(res, tmp_path)
    text = md.read_text()
    assert text.startswith(f"# Splitting methods and dual gradient projection ({res['date']})")
    table_rows = [ln for ln in text.splitlines() if ln.startswith("| ") and not ln.startswith("| method")]
    assert len(table_rows) == len(soft["rows"]) + len(hard["rows"])
    assert text == markdown(res)
    back = json.loads(js.read_text())
    assert len(back["examples"]) == 2 and back["examples"][1]["rows"][0]["example"] == "mt_hard"


def test_fast_ama_on_the_core():
    """`accelerated: true` (method ama): the core's bit-exact model runs fast AMA with the gradient restart. From
    cold starts it restarts now and then, and after 40 iterations it is at least 10 times closer to OSQP's solution
    than plain AMA on every state (hard_problem). Interleaving is refused."""
    from mpc_cores.admm.model import AdmmFixed
    from mpc_cores.errors import DesignError
    from mpc_cores.fixed import quantize

    p = splitting_problem(hard_problem())
    qp = build_admm_qp(p)
    fast = design_admm(p, method="ama", accelerated=True, sizing_solves=4, iterations=40)
    plain = design_admm(p, method="ama", sizing_solves=4, iterations=40)
    assert fast.cycles_per_iteration == plain.cycles_per_iteration + 1 + fast.lat_mul
    W = quantize(np.random.default_rng(7).uniform(qp.wlo, qp.whi, size=(4, qp.nw)), fast.b)
    Zs = np.array([solve_soft_qp_osqp(qp, w / float(1 << fast.b), eps=1e-10) for w in W])
    rf, rp = AdmmFixed(fast).solve_batch(W), AdmmFixed(plain).solve_batch(W)
    ef = np.abs(rf.z / float(1 << fast.b) - Zs).max(axis=1)
    ep = np.abs(rp.z / float(1 << plain.b) - Zs).max(axis=1)
    assert rf.restarts.sum() > 0 and rp.restarts is None
    assert np.all(ef < ep / 10), (ef, ep)
    for bad, rule in ((dict(method="ama", problems=2), "accelerated needs problems = 1"),):
        with pytest.raises(DesignError, match=rule):
            design_admm(p, accelerated=True, sizing_solves=2, **bad)


@pytest.mark.parametrize("method", ["admm", "vucondat"])
def test_fast_admm_and_vucondat_on_the_core(method):
    """`accelerated: true` for ADMM and Vu-Condat: the core's bit-exact model runs the study's accelerated variant
    with the residual restart (the same rule in words: eta = 1 - 2^-10). On soft_problem (b = 22, 150 iterations
    from cold) it restarts, and its worst state ends several times closer to OSQP's solution than the plain method's
    worst (about 12 times for ADMM, 7 for Vu-Condat); its cycles and multipliers include the momentum lanes."""
    from mpc_cores.admm.model import AdmmFixed
    from mpc_cores.fixed import quantize

    p = splitting_problem(soft_problem())
    qp = build_admm_qp(p)
    fast = design_admm(p, method=method, accelerated=True, sizing_solves=4, iterations=150, frac_bits=22)
    plain = design_admm(p, method=method, sizing_solves=4, iterations=150, frac_bits=22)
    assert fast.cycles_per_iteration == plain.cycles_per_iteration + 1 + fast.lat_mul
    assert fast.multipliers == plain.multipliers + 2 * (2 if method == "admm" else 3) * fast.P * 2   # soft pairs
    W = quantize(np.random.default_rng(5).uniform(qp.wlo, qp.whi, size=(4, qp.nw)), fast.b)
    Zs = np.array([solve_soft_qp_osqp(qp, w / float(1 << fast.b), eps=1e-10) for w in W])
    rf, rp = AdmmFixed(fast).solve_batch(W), AdmmFixed(plain).solve_batch(W)
    ef = np.abs(rf.z / float(1 << fast.b) - Zs).max(axis=1)
    ep = np.abs(rp.z / float(1 << plain.b) - Zs).max(axis=1)
    assert rf.restarts.min() > 0 and ef.max() < ep.max() / 4, (ef, ep)
