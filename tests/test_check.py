"""The design check (mpc_cores.check) and the constraint sections each kind enforces (CoreKind.constraints): the
reference MPC problem against the condensed and ADMM forms, refusals of the sections a kind does not enforce, the
check's line in every design report, its refusals and its choice of the iteration count."""
from __future__ import annotations

import copy

import numpy as np
import pytest
import yaml

from mpc_cores import cli, registry
from mpc_cores.check import CheckFailed, _diverged, _violations, check_design, checked_design
from mpc_cores.errors import DesignError
from mpc_cores.flow import REPO
from mpc_cores.kind import SECTIONS
from mpc_cores.mpc_qp import Infeasible, MpcQP
from mpc_cores.problem import condense, horizon_cost, load_spec, problem_from_dict
from mpc_cores.reference import solve_qp_osqp

EX = REPO / "examples"
# one constraint section at a time on the masses model, horizon 5 (sizes small enough for every kind's design)
SECTION_SPECS = {
    "input_rate": {"min": -0.1, "max": 0.1, "weight": 0.01},
    "soft_states": {"indices": [0, 1], "min": -0.5, "max": 0.5, "sigma1": 16, "sigma2": 1},
    "hard_states": {"indices": [0, 1, 2, 3], "min": -0.5, "max": 0.5},
}


def _spec_with(section: str) -> dict:
    d = yaml.safe_load((EX / "masses_state.yaml").read_text())
    for k in SECTIONS:
        d.pop(k, None)
    d["horizon"] = 5
    d["solver"] = {}
    d[section] = copy.deepcopy(SECTION_SPECS[section])
    return d


def test_reference_matches_the_condensed_and_admm_forms():
    p = load_spec(EX / "masses.yaml")
    x = np.array([1, -1, 0.5, 0.2, 0, 0.3, 0, 0.1])
    r = np.array([0.3, 0.2, -0.1, 0.5])
    plan = MpcQP(p).solve(x, r)
    z = solve_qp_osqp(condense(p), np.concatenate([x, r]))
    assert np.abs(plan.u.ravel() - z).max() < 1e-6
    assert plan.cost == pytest.approx(horizon_cost(p, x, z, r), rel=1e-9)
    # a fixed u_0 away from the optimum costs more
    assert MpcQP(p).solve(x, r, u0=plan.u[0] + 0.01).cost > plan.cost

    from mpc_cores.admm.problem import build_admm_qp, solve_soft_qp_osqp
    p = load_spec(EX / "masses_rate_soft.yaml")
    aq = build_admm_qp(p)
    up = np.array([0.1, -0.1, 0.0, 0.05])
    w = np.concatenate([x / 2, up, r])
    zz = solve_soft_qp_osqp(aq, w, eps=1e-10)
    plan = MpcQP(p).solve(x / 2, r, up)
    assert plan.cost == pytest.approx(aq.objective(zz, w), rel=1e-8)
    assert np.abs(aq.inputs(zz) - plan.u).max() < 1e-6


def test_feasibility_is_an_lp():
    q = MpcQP(load_spec(EX / "masses_state.yaml"))
    assert q.feasible(np.full(8, 0.35))
    x = np.array([0.49, 0, 0, 0, 3.0, 0, 0, 0])   # 3 m/s towards the limit 1 cm away, |u| <= 0.5
    assert not q.feasible(x)
    with pytest.raises(Infeasible):
        q.solve(x, np.zeros(4))


@pytest.mark.parametrize("section", SECTIONS)
@pytest.mark.parametrize("name", registry.names())
def test_each_kind_enforces_or_refuses_each_section(name, section):
    kind = registry.get(name)
    p = problem_from_dict(_spec_with(section))
    if section in kind.constraints:
        d = kind.design(p)
        assert d is not None
    else:
        with pytest.raises(DesignError, match=f"CORE={name} enforces .* the spec has {section}, which it would not "
                                              f"enforce"):
            kind.design(p)


@pytest.mark.parametrize("name", [k for k, v in registry.kinds().items() if "soft_states" not in v.constraints])
def test_refusal_of_a_section_is_one_line_exit_2(name, tmp_path, capsys):
    spec = tmp_path / "soft.yaml"
    spec.write_text(yaml.safe_dump(_spec_with("soft_states")))
    with pytest.raises(SystemExit) as e:
        cli.main(["design", "--core", name, "--problem", str(spec)])
    assert e.value.code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "soft_states" in err and err.startswith("error: ")


@pytest.mark.parametrize("name,spec", [("fgm", "masses.yaml"), ("admm", "masses_rate_soft.yaml"),
                                       ("dgp", "masses_state.yaml"), ("ipm", "masses_state.yaml")])
def test_every_design_report_carries_the_check(name, spec, capsys):
    assert registry.get(name).has_demo
    cli.main(["design", "--core", name, "--problem", str(EX / spec)])
    lines = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("Check (")]
    assert len(lines) == 1 and lines[0].startswith("Check (passes)"), lines
    assert "sampled states: suboptimality median" in lines[0] and "cycles per solve" in lines[0]


def test_every_kind_with_a_closed_loop_is_checked():
    """A kind without a closed-loop model says so in its report; the list is the registry's."""
    assert {k for k, v in registry.kinds().items() if not v.has_demo} == {"minres"}


def test_a_design_that_misses_its_target_is_refused_with_the_numbers():
    kind = registry.get("fgm")
    p = load_spec(EX / "masses.yaml")
    with pytest.raises(CheckFailed, match=r"Imax = 1, .*closed-loop cost \+[0-9.e+]+ % against the optimal MPC's, "
                                          r"beyond the target 0.5 %"):
        checked_design(kind, p, {"iterations": 1}, target=0.5)


def test_the_flow_chooses_the_iterations_for_a_target():
    kind = registry.get("fgm")
    p = load_spec(EX / "masses.yaml")
    d, res = checked_design(kind, p, {}, target=0.5)
    assert res.ok and abs(res.gap) <= 0.5 and res.subopt_median <= 0.5
    # one iteration fewer than 15/16 of the choice misses the target (the bisection's resolution)
    below = max(1, d.iterations - max(1, d.iterations // 16))
    if below < d.iterations:
        assert not check_design(kind, kind.design(p, iterations=below), 0.5).ok


def test_the_flow_chooses_the_exit_tolerance_for_a_target():
    """FGM with the exit test and a target: Imax chosen with the test off (the worst case), then the largest EXIT_TOL
    of 2^k LSB that keeps the target, twice it missing it (docs/fgm.md quotes masses at 1 %: Imax 11, 128 LSB, one
    iteration per loop step at the median)."""
    kind = registry.get("fgm")
    p = load_spec(EX / "masses.yaml")
    d, res = checked_design(kind, p, {"early_exit": True}, target=1.0)
    assert res.ok and d.early_exit and (d.iterations, d.exit_tol) == (11, 128)
    assert np.median(res.loop_iterations) == 1 and max(res.loop_iterations) == 11
    assert "the exit test (EXIT_TOL 128 LSB)" in res.line()
    assert not check_design(kind, kind.design(p, iterations=11, exit_tol=256 / 2 ** d.b), 1.0).ok
    off = checked_design(kind, p, {"early_exit": True, "exit_tol": 0}, target=1.0)[0]
    assert off.iterations == d.iterations and off.exit_tol == 0


def test_the_flow_adds_fraction_bits_when_the_format_floors_the_loop():
    """The quadrotor's condensed Hessian (condition number 1.3e4) stalls the FGM at 16 fraction bits at any count;
    the flow moves to the smallest format that meets the target, at fewer than 100 iterations."""
    import dataclasses
    kind = registry.get("fgm")
    p = load_spec(EX / "quadrotor.yaml")
    p = dataclasses.replace(p, check=dataclasses.replace(p.check, samples=8))
    d, res = checked_design(kind, p, {}, target=1.0, budget=20000)
    assert res.ok and d.b > 16 and d.iterations <= 100
    assert not check_design(kind, kind.design(p, iterations=d.iterations, frac_bits=16), 1.0).ok


def test_the_budget_bounds_the_search():
    kind = registry.get("fgm")
    p = load_spec(EX / "masses.yaml")
    with pytest.raises(CheckFailed, match="no iteration count up to 16 meets the target within the budget of 900 "
                                          "cycles per solve"):
        checked_design(kind, p, {}, target=1e-6, budget=900)


def test_violations_and_divergence_are_measured():
    p = load_spec(EX / "masses_state.yaml")
    X = np.zeros((4, 8))
    X[2, 1] = 0.6               # hard limit 0.5: 0.1 over, a tenth of the range 1.0
    U = np.array([[0.0] * 4, [0.7, 0, 0, 0], [0.0] * 4])   # input box 0.5: 0.2 over
    v = _violations(p, X, U)
    assert v["hard states"] == pytest.approx((0.1, 0.1))
    assert v["input box"] == pytest.approx((0.2, 0.2))
    assert not _diverged(p, X)
    X[3, 0] = 10 * 0.35 + 0.01
    assert _diverged(p, X)


def test_an_answer_that_is_not_finite_fails_the_check_in_one_line(monkeypatch):
    """A float core whose iterate runs off answers NaN: the sampled states count it (suboptimality inf), the check
    fails naming the count, and nothing raises (the fixed-u0 QP is never asked to evaluate a NaN)."""
    from mpc_cores import check

    kind = registry.get("fgm")
    p = load_spec(EX / "masses.yaml")
    d = kind.design(p, iterations=20)
    golden = check._golden

    class NanEveryThird:
        def __init__(self, g):
            self.g, self.calls = g, 0

        def __getattr__(self, name):
            return getattr(self.g, name)

        async def step(self, x, r):
            u = np.asarray(await self.g.step(x, r), dtype=float)
            self.calls += 1
            return u * np.nan if self.calls % 3 == 0 else u

    def patched(kind_, d_, warm=None):
        g = golden(kind_, d_, warm)
        return NanEveryThird(g) if warm is False else g

    monkeypatch.setattr(check, "_golden", patched)
    res = check_design(kind, d, target=1.0)
    n = p.check.samples
    assert res.nonfinite_samples == n // 3
    assert len(res.subopt) == n and sum(np.isinf(res.subopt)) == n // 3
    assert f"sampled u0 not finite (NaN or infinite) in {n // 3} of {n} sampled states" in res.failures()
    assert not res.ok
    assert f"u0 not finite in {n // 3}" in res.line()
