"""Cycles per iteration over P, measured in Verilator against the papers' formulas (slow: one Verilator build per
core): the FGM core of the masses against eq. (23) of 002, the ADMM core of masses_rate_soft against eq. (24)."""
from __future__ import annotations

import json

import pytest

from conftest import ADMM_BUILD, BUILD, MASSES_SOFT
from mpc_cores.admm.design import design_admm
from mpc_cores.fgm.design import design_fgm
from mpc_cores.flow import REPO, generate_admm, generate_fgm
from mpc_cores.problem import load_spec
from mpc_cores.sim import run_cocotb

FGM_PS = (1, 2, 4, 8, 40)
ADMM_PS = (1, 2, 4, 8)


@pytest.fixture(scope="module")
def sweep_cores():
    p = load_spec(REPO / "examples/masses.yaml")
    fgm = [(design_fgm(p, P=P), BUILD / f"sweep_masses_p{P}") for P in FGM_PS]
    generate_fgm(fgm)
    ps = load_spec(MASSES_SOFT)
    admm = [(design_admm(ps, P=P, iterations=5), ADMM_BUILD / f"sweep_masses_soft_p{P}") for P in ADMM_PS]
    generate_admm(admm)
    return {**{("fgm", P): j[1] for P, j in zip(FGM_PS, fgm)}, **{("admm", P): j[1] for P, j in zip(ADMM_PS, admm)}}


@pytest.mark.slow
@pytest.mark.parametrize("core_p", [("fgm", P) for P in FGM_PS] + [("admm", P) for P in ADMM_PS],
                         ids=lambda c: f"{c[0]}_p{c[1]}")
def test_cycles_per_iteration(core_p, sweep_cores):
    kind, P = core_p
    out = sweep_cores[core_p]
    core = json.loads((out / "core.json").read_text())
    measure = out / "measured.jsonl"
    measure.unlink(missing_ok=True)
    tests, failed = run_cocotb(out / core["sv"], core["module"], f"verif.{kind}.tb", out / "sim",
                               {"CORE_OUT": str(out), "CORE_MEASURE": str(measure)}, testcase="cycle_contract")
    assert (tests, failed) == (1, 0)
    rec = json.loads(measure.read_text().splitlines()[-1])
    paper = core["cycles_eq23"] if kind == "fgm" else core["cycles_eq24"]
    assert rec["cycles_per_iteration"] == core["cycles_per_iteration"]
    if kind == "fgm":
        assert rec["cycles_per_iteration"] == paper
    else:
        assert rec["cycles_per_iteration"] <= paper
    print(f"{kind} {core['name']} P={P}: measured L = {rec['cycles_per_iteration']}, paper = {paper}, "
          f"solve = {rec['cycles_per_solve']} cycles at Imax = {rec['iterations']}")
