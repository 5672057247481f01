"""The certified design flow (mpc_cores/fgm/certify.py): each bound against brute force on small problems, the
choices it makes, and its refusals."""
from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
import yaml

from conftest import random_problem
from mpc_cores.cli import main as cli_main
from mpc_cores.fgm.certify import (certify, cold_start, design_for_tolerance, initial_gap_bound, iterations_for,
                               kappa_eff, rate_eq7)
from mpc_cores.fgm.design import DesignError, design_fgm
from mpc_cores.fgm.model import FgmFixed, fgm_float
from mpc_cores.flow import REPO
from mpc_cores.problem import load_spec
from mpc_cores.reference import solve_qp_exact


def _qp(d):
    """The quantised QP the core solves, in reals."""
    one = float(1 << d.b)
    return d.Hn_hat, d.F / one, d.lo / one, d.hi / one


class _QP:
    def __init__(self, H, q, lb, ub):
        self.H, self.Phi, self.lb, self.ub = H, np.eye(len(q)), lb, ub
        self.n = self.nw = len(q)
        self._q = q


def _opt(d, w):
    H, F, lo, hi = _qp(d)
    q = F @ w
    qp = _QP(H, q, lo, hi)
    z = solve_qp_exact(qp, q)
    return z, 0.5 * z @ H @ z + z @ q


def _f(d, z, w):
    H, F, _, _ = _qp(d)
    return 0.5 * z @ H @ z + z @ (F @ w)


SMALL = [random_problem("s1", 2, 1, 3, 1, 7), random_problem("s2", 3, 1, 4, 0, 8), random_problem("s3", 2, 2, 2, 1, 9)]


@pytest.mark.parametrize("p", SMALL, ids=lambda p: p.name)
def test_eq7_rate_bounds_exact_fgm(p):
    """f(z_i) - f* <= rate_eq7(kappa, i) (f(z_0) - f*) along exact-arithmetic FGM on the quantised data."""
    d = design_fgm(p, frac_bits=18)
    rng = np.random.default_rng(1)
    one = float(1 << d.b)
    G, F, lo, hi = np.eye(d.n) - d.Hn_hat, d.F / one, d.lo / one, d.hi / one
    kap = kappa_eff(d)
    for _ in range(10):
        w = rng.uniform(d.xlo, d.xhi) / one
        _, fstar = _opt(d, w)
        its = fgm_float(G, F, d.beta / one, lo, hi, w, 60)
        gap0 = _f(d, its[0], w) - fstar
        for i, z in enumerate(its):
            assert _f(d, z, w) - fstar <= rate_eq7(kap, i) * gap0 + 1e-10, (i, _f(d, z, w) - fstar)


@pytest.mark.parametrize("p", SMALL, ids=lambda p: p.name)
def test_initial_gap_bound_covers_every_corner(p):
    """initial_gap_bound >= max over the vertices of the box of f(z_0; w) - f*(w) (a convex function of w, so its
    maximum over the box is at a vertex)."""
    d = design_fgm(p, frac_bits=18)
    one = float(1 << d.b)
    z0 = cold_start(d)
    worst = 0.0
    for corner in itertools.product(*zip(d.xlo / one, d.xhi / one)):
        w = np.array(corner)
        _, fstar = _opt(d, w)
        worst = max(worst, _f(d, z0, w) - fstar)
    bound = initial_gap_bound(d)
    assert worst <= bound + 1e-12
    assert bound < 100 * max(worst, 1e-12), f"gap bound {bound:.3g} vs brute force {worst:.3g}: uselessly loose"


def test_iterations_for_is_minimal():
    d = design_fgm(load_spec(REPO / "examples/masses.yaml"), frac_bits=16)
    kap, gap = kappa_eff(d), initial_gap_bound(d)
    for eps in (1e-1, 1e-4, 1e-8):
        i = iterations_for(d, eps)
        assert rate_eq7(kap, i) * gap <= eps
        assert i == 1 or rate_eq7(kap, i - 1) * gap > eps


@pytest.mark.parametrize("tol", [1e-1, 1e-2])
def test_certificate_holds_on_golden_model(tol):
    """The designed core's error to z* stays under the certified bound <= TOL over random states and corners."""
    p = load_spec(REPO / "examples/masses.yaml")
    d, cert, _ = design_for_tolerance(p, tol)
    assert cert.total <= tol and cert.conv_error <= tol / 2 and cert.roundoff_error <= tol / 2
    one = float(1 << d.b)
    m = FgmFixed(d)
    rng = np.random.default_rng(5)
    states = [d.xlo, d.xhi] + [np.where(rng.random(d.nw) < 0.5, d.xlo, d.xhi) for _ in range(10)]
    states += [rng.integers(d.xlo, d.xhi + 1) for _ in range(10)]
    for w in states:
        z = m.solve(w, warm=False).z / one
        zs, _ = _opt(d, w / one)
        assert np.linalg.norm(z - zs) <= cert.total


def test_design_choices_for_masses_at_1e3():
    d, cert, log = design_for_tolerance(load_spec(REPO / "examples/masses.yaml"), 1e-3)
    # eq. (20) scales with 2^-b: one bit less must miss the round-off half of the target
    d_less = design_fgm(d.problem, frac_bits=d.b - 1, iterations=d.iterations)
    assert certify(d_less).roundoff_error > 1e-3 / 2
    assert cert.imax == iterations_for(d, d.mu * (1e-3 / 2) ** 2 / 2)
    assert log[-1].startswith(f"b={d.b}:")


def test_impossible_targets_are_refused():
    p = load_spec(REPO / "examples/masses.yaml")
    with pytest.raises(DesignError, match=r"no frac_bits in \[8, 30\] meets TOL=1e-09.*relax TOL"):
        design_for_tolerance(p, 1e-9)
    with pytest.raises(DesignError, match="TOL must be > 0"):
        design_for_tolerance(p, 0.0)


def test_design_command_writes_a_spec_make_verilog_takes(tmp_path, capsys):
    out = tmp_path / "spec.yaml"
    cli_main(["design", "--problem", str(REPO / "examples/masses.yaml"), "--tol", "1e-2", "--out", str(out)])
    printed = capsys.readouterr().out
    assert "eq. (7)" in printed and "eq. (20)" in printed and "Prop. 1" in printed and "[proven]" in printed
    spec = yaml.safe_load(out.read_text())
    d0, cert, _ = design_for_tolerance(load_spec(REPO / "examples/masses.yaml"), 1e-2)
    assert spec["solver"]["frac_bits"] == d0.b and spec["solver"]["iterations"] == d0.iterations
    d = design_fgm(load_spec(out))
    assert (d.b, d.iterations) == (d0.b, d0.iterations)
    assert math.isclose(certify(d, 1e-2).total, cert.total)
