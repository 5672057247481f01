"""Formulas, records and report assembly of the interior-point benchmark section (mpc_bench.ipm) on canned data, and
its software solvers on a small QP: no sbt, no Verilator, no Yosys."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from conftest import random_problem
from mpc_bench import ipm, ipm_report
from mpc_bench.baselines import SwResult


def test_table1_and_eq18_of_001():
    # masses: N = 216, M = 20; default design P = 3, I_NW = 8, I_MR = 17
    assert ipm_report.eq18_cycles(3, 216, 8, 17) == 177072
    t = ipm_report.table1_001(20)
    assert t == {"stage1": 3, "dot": 77, "other": 27, "total": 107}
    assert ipm_report.table1_001(20, i=2)["total"] == 4 * 20 + 24 + 6


def _core_json(P: int = 1) -> dict:
    return {"P": P, "N": 19, "M": 5, "n": 2, "m": 1, "T": 3, "P_eq15": 10, "problems_in_flight": 2 * P,
            "i_nw": 8, "iterations": 25, "format": "binary32", "slot_cycles": 178,
            "stage1_cycles": {"sample": 32, "cold": 91, "warm": 14, "linearise": 279, "receive": 20, "update": 195,
                              "output": 20},
            "stage1_hidden": True, "stage1_note": "", "latency_cycles": 75223, "latency_cycles_cold": 75300,
            "latency_per_channel": [70000, 75223], "cycles_per_solve": 40000, "eq18_cycles": 8000,
            "storage_words": {"minres": 118, "stage1_slots": 606, "stage1_const": 61}, "multipliers_minres": 28,
            "stage1_module": "Stage1Engine_d_s2", "minres_module": "MinresCore_d_warm", "module": "IpmCore_d",
            "sv": "IpmCore_d.sv"}


def _core(role: str, measured: dict | None = None, pnr: dict | None = None) -> ipm.IpmCore:
    c = ipm.IpmCore("dint", Path("/nonexistent"), None, role, core=_core_json(), measured=measured, pnr=pnr)
    c.units = {"total": {"FMul": 29, "FAdd": 29, "FDiv": 5, "FSqrt": 3},
               "stage1": {"FMul": 1, "FAdd": 5, "FDiv": 1, "FSqrt": 1},
               "minres": {"FMul": 28, "FAdd": 24, "FDiv": 4, "FSqrt": 2}}
    c.compares = 2
    return c


MEASURED = {"test": "latency", "rounds": {"0": {"latency": {"0": 70100, "1": 75300}},
                                          "1": {"latency": {"0": 70000, "1": 75223}}}}


def test_measured_latency_and_rows():
    assert ipm_report.measured_latency(MEASURED) == {"cold": 75300, "warm": 75223, "per_channel": [70000, 75223]}
    pnr = {"fmax_mhz": 50.0, "target_mhz": 150.0}
    placed, masses = _core("small_p1", MEASURED, pnr), _core("masses")
    rows = ipm_report.ipm_rows([masses, placed], None)
    m, s = rows
    assert s["measured_equals_corejson"] is True and m["measured_equals_corejson"] is None
    assert s["eq18_cycles"] == 2 * 8 * (19 + 1) * 25 and s["latency_over_eq18"] == pytest.approx(75223 / 8000)
    assert s["fp_units_stage1"] == 8 and s["fp_units_minres"] == 58 and s["fp_units_total"] == 66
    assert s["fp_units_001"] == 4 * 5 + 27
    # the placed core at its Fmax, the other at the estimate (the lowest placed Fmax) and both at 150 MHz
    assert s["latency_us"] == pytest.approx(75223 / 50.0) and s["per_problem_us"] == pytest.approx(75223 / 100.0)
    assert m["latency_us"] is None and m["fmax_est_mhz"] == 50.0
    assert m["latency_us_est"] == pytest.approx(75223 / 50.0)
    assert m["latency_us_150"] == pytest.approx(75223 / 150.0)
    bad = _core("small_p1", {"rounds": {"0": MEASURED["rounds"]["0"], "1": {"latency": {"0": 1, "1": 75223}}}})
    assert ipm_report.ipm_rows([bad], None)[0]["measured_equals_corejson"] is False


def test_report_with_software():
    sw = {"solvers": [SwResult("OSQP tuned", "rho = 0.3", np.full((2, 5), 20.0), 1e-4, [5] * 5),
                      SwResult("PIQP dense", "defaults", np.full((2, 5), 50.0), 1e-9, [6] * 5)],
          "repeats": 2, "load": [0.5, 1.0], "core_err": (3e-4, 2e-5), "steps": 20, "hold": 20, "cost_rel": 2e-6}
    cores = [_core("masses"), _core("small_p1", MEASURED, {"fmax_mhz": 50.0, "target_mhz": 150.0})]
    rows = ipm_report.ipm_rows(cores, sw)
    assert rows[0]["sw_osqp_tuned_over_latency"] == pytest.approx(20.0 / (75223 / 50.0))
    text = "\n".join(ipm_report.ipm_section(cores, rows, sw, {"errors": ["x failed"], "runtime_s": 60}))
    for want in ("## Interior-point core", "### Cycles", "Table I", "### Software on this CPU", "PIQP dense",
                 "x failed", "eq. (18)"):
        assert want in text, want
    table = ipm_report.summary_table(rows)
    assert len(table) == 2 + len(rows) and "75223 (8000, x9.40)" in table[2]


SV = """
module Top_FMul_e8_m23_l3(
);
endmodule

module Top_FAdd_e8_m23_l4(
);
endmodule

module Top_FCompare_e8_m23_l1(
);
endmodule

module Top_Stage1Engine_d_s2(
);
  Top_FMul_e8_m23_l3 mul (
  );
  Top_FAdd_e8_m23_l4 add (
  );
  Top_FCompare_e8_m23_l1 cmp (
  );
endmodule

module Top_MinresCore_d_warm(
);
  Top_FMul_e8_m23_l3 mul (
  );
  Top_FMul_e8_m23_l3 mul_1 (
  );
endmodule

module Top(
);
  Top_Stage1Engine_d_s2 stage1 (
  );
  Top_MinresCore_d_warm minres (
  );
endmodule
"""


def test_count_units_by_part(tmp_path):
    (tmp_path / "Top.sv").write_text(SV)
    c = ipm.IpmCore("t", tmp_path, None, "small", core={"sv": "Top.sv", "module": "Top", "stage1_module":
                                                          "Stage1Engine_d_s2", "minres_module": "MinresCore_d_warm"})
    ipm.count_units(c)
    assert c.units["stage1"] == {"FMul": 1, "FAdd": 1, "FDiv": 0, "FSqrt": 0}
    assert c.units["minres"]["FMul"] == 2 and c.units["total"]["FMul"] == 3
    assert c.compares == 1


@pytest.mark.parametrize("solver", ["PiqpDense", "ClarabelQp"])
def test_software_solvers_reach_the_optimum(solver):
    pytest.importorskip({"PiqpDense": "piqp", "ClarabelQp": "clarabel"}[solver])
    from mpc_cores.problem import condense
    from mpc_cores.reference import solve_qp_osqp

    p = random_problem("sw", 3, 2, 5, 1, 7)
    qp = condense(p)
    s = getattr(ipm, solver)(qp)
    rng = np.random.default_rng(0)
    for _ in range(3):
        w = np.concatenate([rng.uniform(-1, 1, p.nx), rng.uniform(-0.5, 0.5, p.ny)])
        assert np.abs(s.solve(w) - solve_qp_osqp(qp, w)).max() < 1e-5
    assert len(s.iters) == 3 and min(s.iters) > 0


def test_is_cached_follows_the_systemverilog(tmp_path):
    """QUICK takes Yosys and nextpnr results from the cache only when they were made from the same SystemVerilog."""
    from mpc_bench import tools

    sv = SV.replace("module Top(\n);", "module Top(\n  input clock,\n        reset,\n  input [3:0] a,\n  output y\n);")
    (tmp_path / "Top.sv").write_text(sv)
    c = ipm.IpmCore("t", tmp_path, None, "small_p1", core={"sv": "Top.sv", "module": "Top"})
    assert not tools.is_cached(c, "ecp5") and not tools.is_cached(c, "nextpnr")
    d, _, outputs, key = tools._yosys_step(c, "ecp5")
    d.mkdir()
    for f in outputs:
        f.write_text("")
    (d / "yosys.key").write_text(key)
    assert tools.is_cached(c, "ecp5") and not tools.is_cached(c, "nextpnr")
    d, _, key = tools._pnr_step(c)
    for f in ("nextpnr_report.json", "nextpnr.log"):
        (d / f).write_text("")
    (d / "nextpnr.key").write_text(key)
    assert tools.is_cached(c, "nextpnr")
    (tmp_path / "Top.sv").write_text(sv + "\n// changed\n")
    assert not tools.is_cached(c, "ecp5") and not tools.is_cached(c, "nextpnr")
