"""Cycles per iteration of the masses core over P, measured in Verilator against eq. (23) of 002 (slow: one
Verilator build per P)."""
from __future__ import annotations

import json

import pytest

from conftest import BUILD
from verif.fgm.design import design_fgm
from verif.flow import REPO, generate_fgm
from verif.problem import load_spec
from verif.sim import run_cocotb

PS = (1, 2, 4, 8, 40)


@pytest.fixture(scope="module")
def masses_cores():
    p = load_spec(REPO / "examples/masses.yaml")
    jobs = [(design_fgm(p, P=P), BUILD / f"sweep_masses_p{P}") for P in PS]
    generate_fgm(jobs)
    return dict(zip(PS, (j[1] for j in jobs)))


@pytest.mark.slow
@pytest.mark.parametrize("P", PS)
def test_masses_cycles_per_iteration(P, masses_cores):
    out = masses_cores[P]
    core = json.loads((out / "core.json").read_text())
    measure = out / "measured.jsonl"
    measure.unlink(missing_ok=True)
    tests, failed = run_cocotb(out / core["sv"], core["module"], "verif.fgm.tb", out / "sim",
                               {"FGM_OUT": str(out), "FGM_MEASURE": str(measure)}, testcase="cycle_contract")
    assert (tests, failed) == (1, 0)
    rec = json.loads(measure.read_text().splitlines()[-1])
    assert rec["cycles_per_iteration"] == core["cycles_eq23"]
    print(f"masses P={P}: measured L = {rec['cycles_per_iteration']}, eq. (23) = {core['cycles_eq23']}, "
          f"solve = {rec['cycles_per_solve']} cycles at Imax = {rec['iterations']}")
