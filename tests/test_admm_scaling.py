"""The ADMM family's cost scale for plants whose multipliers dwarf rho (mpc_cores.admm.scaling): applied on cessna
(median |nu*|_inf ~ 3e5), not on the papers' masses; the scaled QP has the same minimiser."""
from __future__ import annotations

import numpy as np

from mpc_cores import registry
from mpc_cores.admm.design import design_admm
from mpc_cores.admm.problem import FREE, build_admm_qp, solve_soft_qp_osqp
from mpc_cores.admm.scaling import FREE_DROP, GATE, multiplier_median, scaled
from mpc_cores.flow import REPO
from mpc_cores.problem import load_spec

EX = REPO / "examples"


def test_cessna_is_scaled_and_masses_is_not():
    cessna = load_spec(EX / "cessna.yaml")
    d = design_admm(cessna, iterations=10)
    assert multiplier_median(build_admm_qp(cessna)) > GATE * d.rho
    assert d.cost_log2 >= 10
    free = d.qp.kind == FREE
    assert free.any() and np.all(d.shift[free] == d.rho_log2 - FREE_DROP)
    assert np.all(d.shift[~free] >= d.rho_log2)
    assert "Cost scaled by 2^-" in registry.get("admm").design_report(d)
    masses = design_admm(load_spec(EX / "masses.yaml"), iterations=10)
    assert masses.cost_log2 == 0 and np.all(masses.shift == masses.rho_log2)


def test_scaling_keeps_the_minimiser():
    qp = build_admm_qp(load_spec(EX / "cessna.yaml"))
    w = 0.5 * (qp.wlo + qp.whi) + 0.1 * (qp.whi - qp.wlo)
    z = solve_soft_qp_osqp(qp, w, eps=1e-10)
    zs = solve_soft_qp_osqp(scaled(qp, 15), w, eps=1e-10)
    assert np.max(np.abs(z - zs)) <= 1e-5 * max(1.0, np.max(np.abs(z)))
