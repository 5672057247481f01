import copy
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg
import scipy.signal

from mpc_cores.problem import (
    SpecError,
    condense,
    horizon_cost,
    load_spec,
    problem_from_dict,
    qp_objective,
    simulate,
    stage_cost,
    steady_state_maps,
)
from mpc_cores.reference import kkt_residual, solve_qp_exact, solve_qp_osqp

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def random_spec(rng, nx, nu, N, ny=0, qn="matrix"):
    A = rng.standard_normal((nx, nx))
    A *= rng.uniform(0.7, 1.1) / max(abs(np.linalg.eigvals(A)))
    B = rng.standard_normal((nx, nu))
    G = rng.standard_normal((nx, nx - 1))  # rank-deficient: PSD, not PD
    Q = G @ G.T
    F = rng.standard_normal((nu, nu))
    R = F @ F.T + 0.1 * np.eye(nu)
    K = rng.standard_normal((nx, nx))
    d = {
        "model": {"A": A.tolist(), "B": B.tolist()},
        "cost": {"Q": Q.tolist(), "R": R.tolist(), "QN": (K @ K.T).tolist() if qn == "matrix" else qn},
        "horizon": N,
        "inputs": {"min": -1.0, "max": 1.0},
        "states": {"min": -3.0, "max": 3.0},
    }
    if ny:
        d["tracking"] = {"C": rng.standard_normal((ny, nx)).tolist(), "min": -1.0, "max": 1.0}
    return d


CASES = [(nx, nu, N, ny) for N in (1, 3, 10) for (nx, nu, ny) in ((3, 1, 0), (4, 2, 0), (4, 2, 1), (5, 2, 2))]


@pytest.mark.parametrize("nx,nu,N,ny", CASES)
def test_condensing_matches_simulation(nx, nu, N, ny):
    rng = np.random.default_rng(1000 * N + 10 * nx + ny)
    p = problem_from_dict(random_spec(rng, nx, nu, N, ny))
    qp = condense(p)
    assert qp.H.shape == (p.n, p.n) and qp.Phi.shape == (p.n, p.nw)
    assert np.allclose(qp.H, qp.H.T, rtol=0, atol=0)
    assert np.linalg.eigvalsh(qp.H).min() > 0
    for _ in range(5):
        x0 = rng.standard_normal(nx)
        r = rng.standard_normal(ny) if ny else None
        w = np.concatenate([x0, r if ny else []])

        def f(z):
            return horizon_cost(p, x0, z.reshape(N, nu), r)

        const = f(np.zeros(p.n))
        z1, z2 = rng.standard_normal(p.n), rng.standard_normal(p.n)
        for z in (z1, z2):
            J = f(z)
            assert abs(J - (qp_objective(qp, z, w) + const)) <= 1e-9 * max(1.0, abs(J))
        dJ = f(z1) - f(z2)
        dq = qp_objective(qp, z1, w) - qp_objective(qp, z2, w)
        assert abs(dJ - dq) <= 1e-9 * max(1.0, abs(f(z1)), abs(f(z2)))
        # central differences are exact for a quadratic up to rounding
        h = 1e-3
        fd = np.array([(f(z1 + h * e) - f(z1 - h * e)) / (2 * h) for e in np.eye(p.n)])
        grad = qp.H @ z1 + qp.Phi @ w
        assert np.allclose(fd, grad, rtol=1e-6, atol=1e-7 * max(1.0, np.abs(grad).max()))


def test_condensing_detects_wrong_terminal_weight():
    # The comparison above must be able to fail: perturb QN after condensing.
    rng = np.random.default_rng(7)
    d = random_spec(rng, 4, 2, 3, 1)
    p = problem_from_dict(d)
    d2 = copy.deepcopy(d)
    d2["cost"]["QN"] = (np.array(d["cost"]["QN"]) + 1e-3 * np.eye(4)).tolist()
    qp_wrong = condense(problem_from_dict(d2))
    x0, r = rng.standard_normal(4), rng.standard_normal(1)
    w = np.concatenate([x0, r])
    z1, z2 = rng.standard_normal(p.n), rng.standard_normal(p.n)
    dJ = horizon_cost(p, x0, z1, r) - horizon_cost(p, x0, z2, r)
    dq = qp_objective(qp_wrong, z1, w) - qp_objective(qp_wrong, z2, w)
    assert abs(dJ - dq) > 1e-9 * max(1.0, abs(dJ))


def test_simulate_explicit_formula():
    rng = np.random.default_rng(3)
    p = problem_from_dict(random_spec(rng, 5, 2, 10))
    x0 = rng.standard_normal(5)
    U = rng.standard_normal((10, 2))
    X = simulate(p, x0, U)
    assert X.shape == (11, 5)
    mp = np.linalg.matrix_power
    for k in range(11):
        xk = mp(p.A, k) @ x0 + sum((mp(p.A, k - 1 - j) @ p.B @ U[j] for j in range(k)), np.zeros(5))
        assert np.allclose(X[k], xk, rtol=1e-12, atol=1e-12)


def test_stage_cost_regulator_and_tracking():
    p = load_spec(EXAMPLES / "masses.yaml")
    x, u = np.arange(8.0), np.arange(4.0)
    assert stage_cost(p, x, u) == pytest.approx(x @ x + u @ u)
    Mx, Mu = steady_state_maps(p)
    r = np.array([0.5, -0.2, 0.1, 0.3])
    assert stage_cost(p, Mx @ r, Mu @ r, r) == pytest.approx(0.0, abs=1e-24)


@pytest.fixture(scope="module")
def masses():
    return load_spec(EXAMPLES / "masses.yaml")


def test_masses_zoh(masses):
    K = np.diag([-2.0] * 4) + np.diag([1.0] * 3, 1) + np.diag([1.0] * 3, -1)
    Ac = np.block([[np.zeros((4, 4)), np.eye(4)], [K, np.zeros((4, 4))]])
    Bc = np.vstack([np.zeros((4, 4)), np.eye(4)])
    Ad, Bd, *_ = scipy.signal.cont2discrete((Ac, Bc, np.eye(8), np.zeros((8, 4))), 0.5, method="zoh")
    assert np.allclose(masses.A, Ad, rtol=0, atol=1e-12)
    assert np.allclose(masses.B, Bd, rtol=0, atol=1e-12)
    assert masses.Ts == 0.5


def test_dare_terminal_weight(masses):
    A, B, Q, R, P = masses.A, masses.B, masses.Q, masses.R, masses.QN
    rhs = Q + A.T @ P @ A - A.T @ P @ B @ np.linalg.solve(R + B.T @ P @ B, B.T @ P @ A)
    assert np.allclose(P, rhs, rtol=1e-10, atol=1e-10)
    assert np.linalg.eigvalsh(P).min() > 0


def test_steady_state_masses(masses):
    Mx, Mu = steady_state_maps(masses)
    assert Mx.shape == (8, 4) and Mu.shape == (4, 4)
    rng = np.random.default_rng(5)
    for _ in range(3):
        r = rng.uniform(-1, 1, 4)
        xs, us = Mx @ r, Mu @ r
        assert np.allclose(masses.A @ xs + masses.B @ us, xs, atol=1e-12)
        assert np.allclose(masses.C @ xs, r, atol=1e-12)


def test_steady_state_regulator_and_pinv():
    rng = np.random.default_rng(11)
    p = problem_from_dict(random_spec(rng, 4, 2, 3))
    Mx, Mu = steady_state_maps(p)
    assert Mx.shape == (4, 0) and Mu.shape == (2, 0)
    # more inputs than outputs: non-square system, minimum-norm solution
    p = problem_from_dict(random_spec(rng, 4, 2, 3, ny=1))
    Mx, Mu = steady_state_maps(p)
    r = np.array([0.7])
    assert np.allclose(p.A @ Mx @ r + p.B @ Mu @ r, Mx @ r, atol=1e-12)
    assert np.allclose(p.C @ Mx @ r, r, atol=1e-12)


# --------------------------------------------------------------------------
# spec validation


def base_spec():
    return {
        "model": {"A": [[1.0, 0.1], [0.0, 1.0]], "B": [[0.0], [0.1]]},
        "cost": {"Q": 1.0, "R": 0.1},
        "horizon": 5,
        "inputs": {"min": -1.0, "max": 1.0},
        "states": {"min": [-2.0, -3.0], "max": [2.0, 3.0]},
    }


def with_change(path, value):
    d = base_spec()
    node = d
    for k in path[:-1]:
        node = node[k]
    node[path[-1]] = value
    return d


@pytest.mark.parametrize(
    "path,value,pattern",
    [
        (("model", "B"), [[0.0, 1.0]], r"model\.B: expected 2 rows to match A \(2x2\), got 1"),
        (("model", "A"), [[1.0, 0.1, 0.0], [0.0, 1.0, 0.0]], r"model\.A: expected a square matrix, got 2x3"),
        (("cost", "R"), -0.1, r"cost\.R must be positive definite: smallest eigenvalue -0\.1"),
        (("cost", "Q"), [[1.0, 0.0], [0.0, -1.0]], r"cost\.Q must be positive semidefinite: smallest eigenvalue -1"),
        (("cost", "Q"), [[1.0, 0.5], [0.0, 1.0]], r"cost\.Q: matrix must be symmetric"),
        (("cost", "Q"), [1.0, 2.0, 3.0], r"cost\.Q: expected a diagonal of 2 values, got 3"),
        (("cost", "QN"), "lqr", r"cost\.QN: unknown value 'lqr'"),
        (("cost", "R"), "identity", r"cost\.R: unknown value 'identity'"),
        (("horizon",), 0, r"horizon: expected an integer >= 1, got 0"),
        (("horizon",), 2.5, r"horizon: expected an integer >= 1, got 2\.5"),
        (("inputs", "min"), 1.0, r"inputs: min must be < max elementwise, violated at index 0: min 1 >= max 1"),
        (("states", "max"), [2.0, -4.0], r"states: min must be < max elementwise, violated at index 1: min -3 >= max -4"),
        (("states", "min"), [0.0, 0.0, 0.0], r"states\.min: expected a scalar or a list of 2 values"),
        (("model", "Ac"), [[0.0]], r"model: give either a discrete model"),
        (("tracking",), {"outputs": [2], "min": 0, "max": 1}, r"tracking\.outputs: indices \[2\] out of range"),
        (("tracking",), {"C": [[1.0, 0.0, 0.0]], "min": 0, "max": 1}, r"tracking\.C: expected ny x 2"),
        (("tracking",), {"outputs": [0], "min": 1, "max": 0}, r"tracking: min must be < max"),
        (("extra",), 1, r"spec: unknown key 'extra' \(valid keys: name, "),
        (("horizon",), "10", r"horizon: expected an integer >= 1, got '10'"),
    ],
)
def test_spec_errors(path, value, pattern):
    with pytest.raises(SpecError, match=pattern):
        problem_from_dict(with_change(path, value))


def test_continuous_model_needs_ts():
    d = base_spec()
    d["model"] = {"Ac": [[0.0, 1.0], [0.0, 0.0]], "Bc": [[0.0], [1.0]]}
    with pytest.raises(SpecError, match=r"model\.Ts: required"):
        problem_from_dict(d)
    d["model"]["Ts"] = 0.1
    p = problem_from_dict(d)
    assert np.allclose(p.A, [[1.0, 0.1], [0.0, 1.0]]) and np.allclose(p.B, [[0.005], [0.1]])


def test_base_spec_defaults():
    p = problem_from_dict(base_spec(), name="dbl")
    assert p.name == "dbl" and p.C is None and p.ny == 0 and p.nw == 2 and p.n == 5
    assert p.rmin.shape == (0,) and p.solver == {} and p.Ts is None
    assert np.allclose(p.QN, scipy.linalg.solve_discrete_are(p.A, p.B, p.Q, p.R))
    assert np.array_equal(p.umin, [-1.0]) and np.array_equal(p.xmax, [2.0, 3.0])


def test_load_json(tmp_path):
    import json

    f = tmp_path / "dbl.json"
    f.write_text(json.dumps(base_spec()))
    p = load_spec(f)
    assert p.name == "dbl" and p.nx == 2
    with pytest.raises(SpecError, match="unknown spec extension"):
        load_spec(tmp_path / "dbl.txt")


# --------------------------------------------------------------------------
# examples and reference solvers


def test_examples_load(masses):
    assert (masses.nx, masses.nu, masses.ny, masses.N) == (8, 4, 4, 10)
    assert (masses.n, masses.nw) == (40, 12)
    assert masses.solver == {"frac_bits": 16, "iterations": 15, "P": 1, "lat_add": 1, "lat_mul": 1}
    afm = load_spec(EXAMPLES / "afm_like.yaml")
    assert (afm.nx, afm.nu, afm.ny, afm.n, afm.nw) == (12, 1, 1, 16, 13)
    assert max(abs(np.linalg.eigvals(afm.A))) < 1
    ev = np.linalg.eigvalsh(condense(afm).H)
    assert ev[0] > 0 and ev[-1] / ev[0] < 1e6
    assert afm.solver["iterations"] == 20


def test_osqp_matches_exact(masses):
    qp = condense(masses)
    rng = np.random.default_rng(2)
    active = 0
    for _ in range(4):
        w = np.concatenate([rng.uniform(masses.xmin, masses.xmax), rng.uniform(masses.rmin, masses.rmax)])
        z_osqp = solve_qp_osqp(qp, w)
        z_ref = solve_qp_exact(qp, w)
        assert kkt_residual(qp, z_ref, w) < 1e-10
        assert np.abs(z_osqp - z_ref).max() < 1e-6
        active += int(np.sum((z_ref <= qp.lb + 1e-9) | (z_ref >= qp.ub - 1e-9)))
    assert active > 0


def test_exact_unconstrained_interior():
    p = load_spec(EXAMPLES / "masses.yaml")
    qp = condense(p)
    w = np.zeros(p.nw)
    w[0] = 0.01  # small disturbance: optimum strictly inside the box
    z = solve_qp_exact(qp, w)
    assert np.allclose(z, np.linalg.solve(qp.H, -qp.Phi @ w), atol=1e-12)
    assert np.all(np.abs(z) < 0.5)
