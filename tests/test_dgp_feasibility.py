"""Feasibility of the DGP QP decided by an LP, not by OSQP's status: the LP on a hand-made case, a linearised
cart-pole (unstable, |F| <= 2 N, hard limit |p| <= 0.5 m on the cart position) whose feasible boxes OSQP leaves
unsolved at some states ('maximum iterations reached', 'solved inaccurate') and which the design flow used to refuse
as infeasible, a box that is infeasible indeed, and the closed-loop reference controller."""
import re

import numpy as np
import pytest
import yaml

from mpc_cores.dgp import design as dgp_design
from mpc_cores.dgp import problem as dgp_problem
from mpc_cores.dgp.control import DgpOsqpController
from mpc_cores.dgp.design import design_dgp, sample_duals
from mpc_cores.dgp.problem import (DgpQP, dgp_qp, dual_active_set, feasible, kkt_residual, solve_osqp, solve_qp,
                                   violation)
from mpc_cores.errors import DesignError
from mpc_cores.problem import problem_from_dict

M, MP, LP, GRAV = 1.0, 0.1, 0.5, 9.81     # cart mass (kg), pole mass (kg), pole length (m), g (m/s^2)


def cartpole(states: dict, horizon: int = 20, **solver) -> dict:
    """The cart-pole linearised about the upright pole, x = (p, theta, v, omega), u = F (N) on the cart:
    dv/dt = (F - m g theta) / M, domega/dt = ((M + m) g theta - F) / (M l); Ts = 0.05 s (poles at +-4.65 rad/s)."""
    return {"name": "cartpole",
            "model": {"Ac": [[0, 0, 1, 0], [0, 0, 0, 1], [0, -MP * GRAV / M, 0, 0],
                             [0, (M + MP) * GRAV / (M * LP), 0, 0]],
                      "Bc": [[0], [0], [1 / M], [-1 / (M * LP)]], "Ts": 0.05},
            "cost": {"Q": [10.0, 10.0, 1.0, 1.0], "R": 0.1, "QN": "dare"},
            "horizon": horizon,
            "inputs": {"min": -2.0, "max": 2.0},
            "states": states,
            "hard_states": {"indices": [0], "min": -0.5, "max": 0.5},
            **({"solver": solver} if solver else {})}


def vertices(p) -> list[np.ndarray]:
    return [np.where([(v >> i) & 1 for i in range(p.nx)], p.xmax, p.xmin) for v in range(1 << p.nx)]


def state_in(msg: str) -> np.ndarray:
    m = re.search(r"x = (\[[^\]]*\])", msg)
    assert m, msg
    return np.array(yaml.safe_load(m.group(1)), dtype=float)


# ---------------------------------------------------------------------------
# the LP on a hand-made case


def tiny(Lw: float = 1.0) -> DgpQP:
    """z in R^2: -1 <= z_i <= 1 and z1 + z2 <= 0.5 + w (no lower bound): feasible iff w >= -2.5, with the largest
    slack t* = min(1, (2.5 + w) / 3) (z1 = z2 = -1 + t)."""
    return DgpQP(Q=np.eye(2), Phi=np.array([[1.0], [-1.0]]), G=np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]),
                 lo0=np.array([-1.0, -1.0, -np.inf]), hi0=np.array([1.0, 1.0, 0.5]),
                 Lw=np.array([[0.0], [0.0], [Lw]]), sigma=1.0, n=2, nw=1, nu=1, N=2, n_input_rows=2)


@pytest.mark.parametrize("w,ok,t", [(0.0, True, 2.5 / 3), (5.0, True, 1.0), (-2.5, True, 0.0), (-2.4, True, 0.1 / 3),
                                    (-3.0, False, -0.5 / 3), (-2.5 - 1e-6, False, -1e-6 / 3)])
def test_lp_decides_a_hand_made_case(w, ok, t):
    got, margin = feasible(tiny(), [w])
    assert got is ok
    assert margin == pytest.approx(t, abs=1e-9)


def test_solve_qp_on_the_hand_made_case():
    qp = tiny()
    a = solve_qp(qp, [-3.0])
    assert a.status == "infeasible" and a.margin == pytest.approx(-0.5 / 3, abs=1e-9)
    assert dual_active_set(qp, [-3.0]) is None
    # w = -2: q = (-2, 2), the unconstrained minimiser (2, -2) is cut by the box to (1, -1), then z1 + z2 <= 0.5 - 2
    # moves z1 down: z* = (-0.5, -1), with multipliers on row 1 (its lower bound) and row 2: z + q + G'y = 0
    for z, y in [dual_active_set(qp, [-2.0]), (lambda a: (a.z, a.yp - a.ym))(solve_qp(qp, [-2.0]))]:
        np.testing.assert_allclose(z, [-0.5, -1.0], atol=1e-7)
        np.testing.assert_allclose(y, [0.0, -3.5, 2.5], atol=1e-6)


# ---------------------------------------------------------------------------
# the cart-pole


# near the left limit, moving back at 0.64-0.65 m/s, pole tilted: the limit can be met from every state (LP), and OSQP
# stops short ('solved inaccurate', multipliers ~ 1e-12 for ~15) at two vertices and four interior points
NEAR_LIMIT = {"min": [-0.42, -0.06, 0.64, -0.36], "max": [-0.41, -0.05, 0.65, -0.35]}
# a box symmetric about 0: feasible at every vertex (LP), OSQP reaches its iteration limit at two of them
SYMMETRIC = {"min": [-0.3, -0.1, -0.3, -0.3], "max": [0.3, 0.1, 0.3, 0.3]}


def test_cartpole_near_the_limit_is_accepted():
    p = problem_from_dict(cartpole(NEAR_LIMIT, horizon=30, tol=1e-2))
    qp = dgp_qp(p)
    assert np.abs(np.linalg.eigvals(p.A)).max() > 1.2                  # open loop unstable
    for x in vertices(p):
        assert feasible(qp, x)[0], x
    stuck = [x for x in vertices(p) if solve_osqp(qp, x, eps=1e-7)[3] != "solved"]
    assert stuck                                                        # the states the flow used to refuse
    for x in stuck:
        a = solve_qp(qp, x, eps=1e-7)
        assert a.status == "solved" and a.margin > 0
        assert kkt_residual(qp, a.z, a.yp - a.ym, x) <= 1e-9
    d = design_dgp(p)
    assert d.widths["data"] <= 40 and np.all(np.isfinite(d.d))


def test_cartpole_symmetric_box_is_not_called_infeasible():
    """The LP shows every vertex feasible; the duals there reach ~1e6 (the limit held against the unstable pole), so
    the words that (36) and (37) of 003 ask exceed 40 bits: the default format has 16 fraction bits, not
    certified, and the certified one is refused for its word widths, not called infeasible."""
    p = problem_from_dict(cartpole(SYMMETRIC))
    qp = dgp_qp(p)
    assert all(feasible(qp, x)[0] for x in vertices(p))
    assert any(solve_osqp(qp, x, eps=1e-7)[3] != "solved" for x in vertices(p))
    y = sample_duals(qp, p)
    assert np.all(np.isfinite(y)) and y.max() > 1e5
    d = design_dgp(p)
    assert d.b == 16 < d.bits36
    with pytest.raises(DesignError) as e:
        design_dgp(p, frac_bits=d.bits36)
    msg = str(e.value)
    assert "infeasible" not in msg and "data words" in msg and "\n" not in msg


def test_cartpole_infeasible_box_is_refused():
    """From p = 0.4 m at 1.5 m/s towards the limit, |F| <= 2 N cannot stop the cart before p = 0.5 m."""
    p = problem_from_dict(cartpole({"min": [-0.4, -0.05, -1.5, -0.1], "max": [0.4, 0.05, 1.5, 0.1]}))
    with pytest.raises(DesignError) as e:
        design_dgp(p)
    msg = str(e.value)
    assert "infeasible" in msg and "an LP proves it" in msg and "\n" not in msg
    x = state_in(msg)
    assert x.shape == (p.nx,) and np.all(x >= p.xmin - 1e-9) and np.all(x <= p.xmax + 1e-9)
    ok, t = feasible(dgp_qp(p), x)
    assert not ok and t < 0


def test_osqp_failure_on_a_feasible_qp_is_not_called_infeasible(monkeypatch):
    """With every second attempt taken away, a state OSQP leaves unsolved is refused as OSQP's failure."""
    monkeypatch.setattr(dgp_problem, "_retries", lambda qp, w, eps: iter(()))
    monkeypatch.setattr(dgp_design, "_DUALS_CACHE", {})
    p = problem_from_dict(cartpole(NEAR_LIMIT, horizon=30, tol=1e-2))
    with pytest.raises(DesignError) as e:
        design_dgp(p)
    msg = str(e.value)
    assert "OSQP failed" in msg and "feasible" in msg and "infeasible" not in msg and "\n" not in msg
    assert feasible(dgp_qp(p), state_in(msg))[0]
    with pytest.raises(RuntimeError, match="OSQP failed") as e:
        DgpOsqpController(p).solve(state_in(msg), np.zeros(0))
    assert "infeasible" not in str(e.value)


def test_controller_solves_where_osqp_stops_short_and_names_infeasible_states():
    p = problem_from_dict(cartpole(NEAR_LIMIT, horizon=30))
    qp = dgp_qp(p)
    ctl = DgpOsqpController(p)
    x = next(x for x in vertices(p) if solve_osqp(qp, x, eps=ctl.eps)[3] != "solved")
    z = ctl.solve(x, np.zeros(0))
    z_ref, _ = dual_active_set(qp, x)
    np.testing.assert_allclose(z, z_ref, atol=1e-7)
    assert violation(qp, z, x) <= 1e-9
    bad = np.array([0.45, 0.0, 1.5, 0.0])
    with pytest.raises(RuntimeError, match="infeasible") as e:
        ctl.solve(bad, np.zeros(0))
    np.testing.assert_allclose(state_in(str(e.value)), bad)
