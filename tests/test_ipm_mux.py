"""Parallel multiplexed MPC (Algorithm 2 of 001) on the interior-point core (`ipm_multiplexed`, MULTIPLEXED=1): the
design's constant banks and MINRES tables, the golden model in the closed loop against conventional MPC, the
refusals. The RTL against the model: tests/test_ipm_rtl.py (n2_m2_t3_p2_mux) and tests/test_minres_rtl.py
(n2_m1_t3_tables)."""
from __future__ import annotations

import asyncio

import numpy as np
import pytest

from conftest import random_problem
from mpc_cores.closedloop import Controller, OsqpController, reference_schedule, run_closed_loop
from mpc_cores.errors import DesignError
from mpc_cores.ipm.core_model import IpmCoreModel
from mpc_cores.ipm.design import design_ipm
from mpc_cores.ipm.multiplexed import channel_problem
from mpc_cores.ipm.mux_loop import CoreMux, model_solver, run_step
from mpc_cores.minres.kkt import kkt_matrix, problem_matrices
from mpc_cores.problem import load_spec


@pytest.fixture(scope="module")
def masses():
    return load_spec("examples/masses.yaml")


@pytest.fixture(scope="module")
def mux(masses):
    d = design_ipm(masses, multiplexed=True)
    return d, d.config()


def test_banks_and_tables(masses, mux):
    """One Stage 1 constant bank and one MINRES coefficient table per input: table i multiplies by the KKT matrix of
    input i's single-input problem (B_i, R_ii), bank i holds its constants; the programs and the layout are one. A
    conventional design has neither banks nor tables."""
    d, cfg = mux
    m = masses.nu
    assert (cfg["m"], cfg["ny"], cfg["inputs"], cfg["multiplexed"]) == (1, 0, m, True)
    assert d.P >= m, "every input's copy in one MINRES batch"
    st1, mr = cfg["stage1"], cfg["minres"]
    assert st1["const_banks"] == m and len(st1["const"]) == m * len(d.st1.const_words)
    assert len(mr["band_tables"]) == len(mr["roms"]) == m and mr["band_tables"][0] == mr["band_coefs"]
    model = IpmCoreModel(cfg, d.P)
    diag = np.ones(len(model.mr.primal))
    for i in range(m):
        K = kkt_matrix(*problem_matrices(channel_problem(masses, i)))
        K[model.mr.primal, model.mr.primal] = 1.0      # the variable diagonal
        assert np.allclose(model.mr.matrix(diag, table=i), K, rtol=1e-6, atol=1e-7), i
    # channel c (id c to MINRES, Stage 1 slot c) solves input c mod m in both stages
    assert [model.mr.table_of(c) for c in range(2 * d.P)] == [c % m for c in range(2 * d.P)]
    assert model.machine.const_banks == m
    assert all(b.programs == d.st1.programs and b.slot == d.st1.slot for b in d.banks)
    assert len({b.const_words.tobytes() for b in d.banks}) == m                   # B_i, R_ii differ
    assert len({str(t) for t in mr["band_tables"]}) == m
    conv = design_ipm(masses).config()
    assert "const_banks" not in conv["stage1"] and "band_tables" not in conv["minres"] and "multiplexed" not in conv


def _gap(p, ctrl_step, x0, refs) -> float:
    class C(Controller):
        async def step(self, x, r):
            return ctrl_step(x, r)
    J0 = run_closed_loop(p, OsqpController(p), x0, refs).cost
    return run_closed_loop(p, C(), x0, refs).cost / J0 - 1


def test_closed_loop_against_conventional(masses, mux):
    """The golden model of the multiplexed core (binary32, the default I_NW and I_MR) in Algorithm 2's closed loop
    on masses against conventional MPC (OSQP to optimality): within 1 % in regulation from a displaced state and
    within 5 % when tracking the closed loop's reference changes (the issue's criteria); one round per sample
    without a reference change."""
    d, cfg = mux
    model = IpmCoreModel(cfg, d.P)
    solve = model_solver(model)
    reg = CoreMux(masses, solve)
    x0 = np.array([1.0, -0.5, 0.8, 0.2, 0, 0, 0, 0])
    gap_reg = _gap(masses, reg.step, x0, np.zeros((40, masses.ny)))
    assert 0 <= gap_reg < 1e-2, gap_reg
    assert reg.rounds_run == reg.first_rounds + 39
    model.reset()
    trk = CoreMux(masses, solve)
    refs = reference_schedule(masses, 60, 20, 0, 0.9)
    gap_trk = _gap(masses, trk.step, np.zeros(masses.nx), refs)
    assert 0 <= gap_trk < 5e-2, gap_trk
    print(f"multiplexed against conventional MPC: regulation {100 * gap_reg:+.2f} %, tracking {100 * gap_trk:+.2f} %")


def test_round_driver_equals_step(masses, mux):
    """run_step (a round's copies solved together, as the RTL controller does) gives the u0 of step (one by one),
    bit for bit, over reference changes."""
    d, cfg = mux
    refs = reference_schedule(masses, 8, 3, 1, 0.9)
    a, b = IpmCoreModel(cfg, d.P), IpmCoreModel(cfg, d.P)
    one, batch = CoreMux(masses, model_solver(a)), CoreMux(masses, None)
    sb = model_solver(b)

    async def rounds(frames):
        return [sb(*f) for f in frames]
    x = np.array([0.3, 0, -0.2, 0, 0, 0.1, 0, 0])
    for r in refs:
        u1 = one.step(x, r)
        u2 = asyncio.run(run_step(batch, x, r, rounds))
        assert np.array_equal(u1, u2)
        x = masses.A @ x + masses.B @ u1


def test_refusals(masses):
    """One input: nothing to multiplex; a Stage 1 accumulation of lat_add terms or fewer (one input, T = 2, lat_add
    4): one-line refusals."""
    one = random_problem("mx1", 2, 1, 3, 0, 3)
    with pytest.raises(DesignError, match="multiplexed MPC needs at least two inputs .* got m=1"):
        design_ipm(one, multiplexed=True)
    short = random_problem("mx2", 1, 1, 2, 0, 4)
    with pytest.raises(DesignError, match="ACC needs more than lat_add=4 terms") as e:
        design_ipm(short, lat_add=4)
    assert "\n" not in str(e.value)
