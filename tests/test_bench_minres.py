"""Formulas, parsing and report assembly of the MINRES benchmark (mpc_bench/bench_minres.py) on canned data: no sbt,
no Verilator, no Yosys."""
from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from mpc_bench import baselines_minres, minres, minres_report
from mpc_cores.minres.kkt import sizes

SV = """
// generated
module Top_FMul_e8_m23_l3(
  input clock
);
endmodule

module Top_FAdd_e8_m23_l4(
  input clock
);
  // an FAdd holds no further operators, whatever it instantiates
  Top_Helper h (
    .clock(clock)
  );
endmodule

module Top_Helper(
  input clock
);
endmodule

module Top_FDotProduct_k3(
  input clock
);
  Top_FMul_e8_m23_l3 level_mul (
    .clock(clock)
  );
  Top_FMul_e8_m23_l3 level_mul_1 (
    .clock(clock)
  );
  Top_FMul_e8_m23_l3 level_mul_2 (
    .clock(clock)
  );
  Top_FAdd_e8_m23_l4 tree_add (
    .clock(clock)
  );
  Top_FAdd_e8_m23_l4 tree_add_1 (
    .clock(clock)
  );
endmodule

module Top_FDiv_e8_m23_l16(
  input clock
);
endmodule

module Top_FSqrt_e8_m23_l16 #(parameter W = 1) (
  input clock
);
endmodule

module Top(
  input clock
);
  wire unused;
  Top_FDotProduct_k3 dot (
    .clock(clock)
  );
  Top_FDotProduct_k3 dot_1 (
    .clock(clock)
  );
  Top_FDiv_e8_m23_l16 div (
    .clock(clock)
  );
  Top_FSqrt_e8_m23_l16 #(.W(2)) sqrt (
    .clock(clock)
  );
  Top_FMul_e8_m23_l3 scalar_mul (
    .clock(clock)
  );
endmodule
"""


def test_float_units_counts_through_the_hierarchy():
    assert minres_report.float_units(SV, "Top") == {"FMul": 7, "FAdd": 4, "FDiv": 1, "FSqrt": 1}
    assert minres_report.float_units(SV, "Top_FDotProduct_k3") == {"FMul": 3, "FAdd": 2, "FDiv": 0, "FSqrt": 0}


def test_float_units_unknown_top():
    with pytest.raises(ValueError, match="Nope"):
        minres_report.float_units(SV, "Nope")


def test_eq15_001_masses():
    """masses: N = 216, M = 20: P = ceil((3 N + 24 ceil(log2 39) + 154) / N) = ceil(946 / 216) = 5."""
    N, M = sizes(8, 4, 10)
    assert minres_report.eq15_001(N, M) == 5
    # the kkt module's own form of the same equation
    from mpc_cores.minres.kkt import eq15_paper
    for n, m, T in ((2, 1, 3), (8, 4, 10), (40, 3, 20), (1, 1, 1)):
        N, M = sizes(n, m, T)
        assert minres_report.eq15_001(N, M) == eq15_paper(N, M)


def test_cycles_and_overhead():
    assert minres_report.cycles_001(216, 4, 216) == (4 * 216 + 4) * 216
    assert minres_report.batch_cycles(1473, 216, 864) == 1473 + 216 * 864
    # JSON turns the Imax keys into strings
    assert minres_report.measured_overhead({"3": 1473 + 3 * 864, "4": 1473 + 4 * 864}, 864) == 1473
    with pytest.raises(ValueError, match="not affine"):
        minres_report.measured_overhead({"3": 4065, "4": 4930}, 864)


def test_flop_counts_agree_on_a_full_band():
    """On a matrix whose whole band is nonzero, what the core issues exceeds the useful flops by the products
    and adds of the band's corners outside the matrix only: M (M - 1) of each."""
    for n, m, T in ((2, 1, 3), (8, 4, 10), (3, 2, 7)):
        N, M = sizes(n, m, T)
        nnz_band = N * (2 * M - 1) - M * (M - 1)
        assert minres_report.band_flops(N, 2 * M - 1) - minres_report.useful_flops(nnz_band, N) == 2 * M * (M - 1)


def test_useful_flops_counts_the_minres_iteration():
    """Count the operations of one iteration of mpc_cores.minres.model.minres64 with an instrumented float type on a
    tiny system and compare (the first iteration: v_0 = w_0 = w_-1 = 0 are still multiplied, as in the core)."""
    count = [0]

    class F(float):
        def _op(self, o, f):
            count[0] += 1
            return F(f(float(self), float(o)))

        __add__ = lambda s, o: s._op(o, float.__add__)  # noqa: E731
        __radd__ = lambda s, o: s._op(o, lambda a, b: b + a)  # noqa: E731
        __sub__ = lambda s, o: s._op(o, float.__sub__)  # noqa: E731
        __rsub__ = lambda s, o: s._op(o, lambda a, b: b - a)  # noqa: E731
        __mul__ = lambda s, o: s._op(o, float.__mul__)  # noqa: E731
        __rmul__ = lambda s, o: s._op(o, lambda a, b: b * a)  # noqa: E731
        __truediv__ = lambda s, o: s._op(o, float.__truediv__)  # noqa: E731
        __neg__ = lambda s: F(-float(s))  # noqa: E731

    rng = np.random.default_rng(3)
    N = 5
    K = np.triu(rng.standard_normal((N, N)))
    K[0, 3:] = 0.0
    K[1, 4] = 0.0
    K = K + np.triu(K, 1).T
    nnz = int(np.count_nonzero(K))
    v = [F(x) for x in rng.standard_normal(N)]
    vprev = [F(x) for x in rng.standard_normal(N)]
    w, wprev, x = ([F(t) for t in rng.standard_normal(N)] for _ in range(3))
    c, cp, s, sp, g, eta = (F(t) for t in rng.uniform(0.1, 1.0, 6))
    sqrt = lambda a: (count.__setitem__(0, count[0] + 1), F(math.sqrt(a)))[1]  # noqa: E731

    def dot(a, b):
        acc = a[0] * b[0]
        for i in range(1, len(a)):
            acc = acc + a[i] * b[i]
        return acc

    y = []
    for i in range(N):
        terms = [F(K[i, j]) * v[j] for j in range(N) if K[i, j] != 0]
        acc = terms[0]
        for t in terms[1:]:
            acc = acc + t
        y.append(acc)
    delta = dot(v, y)
    u = [(y[i] - delta * v[i]) - g * vprev[i] for i in range(N)]
    nrm2 = dot(u, u)
    g1 = sqrt(nrm2)
    a0 = c * delta - (cp * s) * g
    a1 = sqrt(a0 * a0 + nrm2)
    a2 = s * delta + (cp * c) * g
    a3 = sp * g
    c1, s1 = a0 / a1, g1 / a1
    ceta = c1 * eta
    eta = -(s1 * eta)
    vnew = [u[i] / g1 for i in range(N)]
    wnew = [((v[i] - a3 * wprev[i]) - a2 * w[i]) / a1 for i in range(N)]
    x = [x[i] + ceta * wnew[i] for i in range(N)]
    assert vnew and x
    assert count[0] == minres_report.useful_flops(nnz, N)


def test_utilisation():
    # one problem: 100 flops in a slot of 10 cycles on 20 operators
    assert minres_report.utilisation(100, 20, 10) == pytest.approx(0.5)
    # a stretched slot lowers it
    assert minres_report.utilisation(100, 20, 25) < minres_report.utilisation(100, 20, 10)


def test_logic_fit():
    ok = {"MULT18X18D": 150, "DP16KD": 0, "LUT4": 50000, "CCU2C": 1000, "FF": 60000, "LUTRAM": 100}
    assert minres.logic_fit(ok) == []
    over = minres.logic_fit(dict(ok, MULT18X18D=224, FF=90000))
    assert len(over) == 2 and "224 MULT18X18D" in over[0] and "90000 FF" in over[1]
    # carry cells and distributed RAM count against the LUT4
    assert any("LUT4" in o for o in minres.logic_fit(dict(ok, LUT4=70000, CCU2C=8000)))
    assert any("LUT4" in o for o in minres.logic_fit(dict(ok, LUT4=70000, LUTRAM=5000)))


def test_median_and_merge_times():
    a = {"scipy": {"name": "s", "times_us": np.array([[10.0, 30.0, 20.0]]), "iterations": [1]}}
    b = {"scipy": {"name": "s", "times_us": np.array([[5.0, 6.0, 50.0]]), "iterations": [1]}}
    m = baselines_minres.merge_times(a, b)
    assert m["scipy"]["times_us"].shape == (2, 3)
    assert baselines_minres.median_us(m["scipy"]["times_us"]) == 6.0
    assert baselines_minres.merge_times(None, b) is b


def _core(problem, P, N, M, S, imax, cpi, over, pnr=None, role="sweep", measured=True, ecp5=None):
    cj = {"N": N, "M": M, "K": 13, "P": P, "n": 8, "m": 4, "T": 10, "lat_add": 4, "lat_mul": 3, "lat_div": 16,
          "lat_sqrt": 16, "P_eq15": 3, "slot_cycles": S, "cycles_per_iteration": cpi, "batch_cycles_imax0": over,
          "multipliers": 56, "storage_words": 1, "storage_bound_001": 2, "storage_dense_cds": 3, "module": "Top",
          "sv": "Top.sv"}
    c = minres.MinresCore(problem, P, Path("/nonexistent"), SimpleNamespace(iterations=imax), role=role)
    c.core = cj
    c.units = {"FMul": 56, "FAdd": 54, "FDiv": 4, "FSqrt": 2}
    if measured:
        c.measured = {"cycles_per_iteration": cpi, "batch_cycles": {"3": over + 3 * cpi, "4": over + 4 * cpi},
                      "PN_plus_P": P * N + P}
    c.ecp5 = ecp5
    if pnr:
        c.pnr = {"fmax_mhz": pnr, "target_mhz": 150.0, "utilisation": {}, "critical_path": None}
    return c


def _sw(us_scipy, us_numpy):
    return {"masses": {"systems": 2, "repeats": 2, "load": [1.0, 2.0], "accuracy": {},
                       "solvers": {"scipy": {"name": "scipy", "times_us": np.array([[us_scipy, us_scipy]]),
                                             "iterations": [216, 216], "residual_median": 1e-4, "residual_max": 2e-4},
                                   "numpy": {"name": "numpy", "times_us": np.array([[us_numpy, us_numpy]]),
                                             "iterations": [216, 216], "residual_median": 1e-4,
                                             "residual_max": 2e-4}}}}


def test_rows_cycles_latency_and_ratios():
    big = _core("masses", 4, 216, 20, 216, 216, 864, 1473,
                ecp5={"MULT18X18D": 224, "LUT4": 1, "CCU2C": 0, "FF": 1, "DP16KD": 0, "LUTRAM": 0})
    big.pnr_note = "does not fit: 224 MULT18X18D needed, 156 on the LFE5U-85F"
    small = _core("dint", 1, 19, 5, 179, 19, 179, 300, pnr=80.0, role="fmax")
    rows = minres_report.minres_rows([big, small], _sw(10000.0, 5000.0), {"masses": 2280, "dint": 100})
    r, s = rows
    cyc = 1473 + 216 * 864
    assert r["batch_cycles_measured"] == r["batch_cycles_corejson"] == cyc
    assert r["cycles_PN_plus_P"] == 868 and r["cycles_001_eq15"] == (5 * 216 + 5) * 216
    # unplaced: quoted at the small core's Fmax, marked as an estimate
    assert r["fmax_mhz"] is None and r["fmax_est_mhz"] == 80.0
    assert r["latency_batch_us_est"] == pytest.approx(cyc / 80.0)
    assert r["latency_per_problem_us_est"] == pytest.approx(cyc / 80.0 / 4)
    assert r["scipy_over_core_per_problem"] == pytest.approx(10000.0 / (cyc / 80.0 / 4))
    assert r["numpy_over_core_batch"] == pytest.approx(5000.0 / (cyc / 80.0))
    assert r["scipy_us_per_iteration"] == pytest.approx(10000.0 / 216)
    assert r["latency_001_us_150"] == pytest.approx((5 * 216 + 5) * 216 / 150.0)
    assert r["utilisation"] == pytest.approx(minres_report.useful_flops(2280, 216) / (116 * 216))
    assert r["fp_units"] == 116 and r["fp_units_001"] == 4 * 20 + 24
    # placed: its own Fmax, no estimate; no software on its problem
    assert s["latency_batch_us"] == pytest.approx((300 + 19 * 179) / 80.0) and s["fmax_est_mhz"] is None
    assert s["scipy_us"] is None


def test_rows_without_measurement_use_the_contract():
    c = _core("masses", 2, 216, 20, 296, 216, 592, 1121, measured=False)
    r = minres_report.minres_rows([c], None, {"masses": 2280})[0]
    assert r["cycles_per_iteration_measured"] is None and r["batch_cycles_measured"] is None
    assert r["latency_batch_us"] is None and r["latency_batch_us_est"] is None
    assert r["latency_batch_us_150"] == pytest.approx((1121 + 216 * 592) / 150.0)
    assert r["scipy_us"] is None and r["scipy_over_core_batch"] is None


def test_summary_and_section():
    big = _core("masses", 4, 216, 20, 216, 216, 864, 1473,
                ecp5={"MULT18X18D": 224, "LUT4": 1, "CCU2C": 0, "FF": 1, "DP16KD": 0, "LUTRAM": 0})
    big.pnr_note = "does not fit: 224 MULT18X18D needed, 156 on the LFE5U-85F"
    small = _core("dint", 1, 19, 5, 179, 19, 179, 300, pnr=80.0, role="fmax")
    sw = _sw(10000.0, 5000.0)
    rows = minres_report.minres_rows([big, small], sw, {"masses": 2280, "dint": 100})
    table = minres_report.summary_table(rows[:1])
    assert len(table) == 3
    cells = [len(line.strip("|").split("|")) for line in table]
    assert cells[0] == cells[2]
    assert "no fit, est. 80.0" in table[2] and "(est.)" in table[2] and "864 (868)" in table[2]
    sec = minres_report.minres_section([big, small], rows, sw, {"runtime_s": 60.0, "sw_seconds": {"timing": 1.0},
                                                     "errors": ["x failed"]})
    text = "\n".join(sec)
    assert sec[0] == "## MINRES core"
    assert "does not fit: 224 MULT18X18D" in text and "- x failed" in text
    assert "### Software on this CPU" in text
    # every markdown table keeps its column count
    for block in text.split("\n\n"):
        lines = [ln for ln in block.splitlines() if ln.startswith("|")]
        if lines:
            assert len({ln.count("|") for ln in lines}) == 1, block


def test_software_solvers_on_the_small_problem():
    """scipy's MINRES and the float64 model iteration on the small problem's KKT systems: the same iterations
    (Imax = N = 19) give the same residuals; the core's binary32 model is near them."""
    from mpc_cores.minres.design import design_minres

    d = design_minres(minres.small_problem(), P=1)
    s = baselines_minres.make_systems(d, 3)
    assert len(s.b) == 3 and s.K[0].shape == (19, 19) and s.imax == 19
    assert np.array_equal(s.K[0], s.K[0].T)
    t = baselines_minres.time_software(s, 1)
    for key, _ in baselines_minres.SOLVERS:
        assert t[key]["times_us"].shape == (1, 3)
        assert max(t[key]["iterations"]) <= 19
    assert t["scipy"]["residual_max"] == pytest.approx(t["numpy"]["residual_max"], rel=1e-3)
    acc = baselines_minres.model_accuracy(s, 2)
    assert acc["systems"] == 2 and acc["direct_max"] < 1e-12
    # N iterations do not converge this indefinite system in finite precision, but both reduce the residual
    assert 0 < acc["f64_max"] < 0.5 and 0 < acc["core_max"] < 0.5


def test_mem_list():
    mems = {"Top.vmem_ext.Memory": "FF", "Top.wmem_ext.Memory": "TRELLIS_DPR16X4",
            "Top.$auto$proc_rom.cc:155:do_switch$1644": "FF", "Top.$auto$proc_rom.cc:155:do_switch$1640": "FF",
            "Top.bndRam_0.mem": "PDPW16KD"}
    assert minres_report.mem_list(mems) == ("bndRam_0 -> PDPW16KD, vmem -> FF, wmem -> TRELLIS_DPR16X4, "
                                 "2 ROM/unnamed -> FF")
    assert minres_report.mem_list({}) == ""


def test_summary_falls_back_to_150_mhz():
    c = _core("masses", 1, 216, 20, 592, 216, 592, 825)
    r = minres_report.minres_rows([c], _sw(6000.0, 3000.0), {"masses": 2280})[0]
    lat = (825 + 216 * 592) / 150.0
    assert r["numpy_over_core_per_problem_150"] == pytest.approx(3000.0 / lat)
    row = minres_report.summary_table([r])[2]
    assert f"{lat:.0f} (150 MHz)" in row and f"{3000.0 / lat:.1f}x" in row
