"""Parsers and arithmetic of the benchmark report (mpc_bench/bench.py) on canned tool output; no synthesis."""
from __future__ import annotations

import math

import numpy as np
import pytest

from mpc_bench import admm, admm_report, baselines, bench, fgm, parsers, qp, report

ECP5_STAT = """
3. Printing statistics.

=== FgmCore_masses_n40_p1_b16 ===

        +----------Local Count, excluding submodules.
        | 
    16262 wires
    29214 wire bits
       29 ports
      176 port bits
    18038 cells
        7   $scopeinfo
     1321   CCU2C
       21   DP16KD
      332   L6MUX21
     9437   LUT4
       42   MULT18X18D
     1204   PFUMX
       10   TRELLIS_DPR16X4
     5664   TRELLIS_FF
"""

# Hierarchical layout: per-module lists first, the design totals last, then the submodule list.
XC7_STAT_HIER = """
=== FgmCore_x_mat0 ===

        +----------Local Count, excluding submodules.
        | 
       50 cells
       40   LUT2
       10   RAMB36E1

=== design hierarchy ===

        +----------Count including submodules.
        | 
    11314 FgmCore_x
       50 FgmCore_x_mat0

        +----------Count including submodules.
        | 
     8268 wires
    11314 cells
        1   BUFG
      264   CARRY4
       42   DSP48E1
     3957   FDRE
      743   FDSE
       40   LUT1
     1316   LUT2
     1073   LUT3
      755   LUT4
     2044   LUT5
      838   LUT6
        8   RAM32M
       12   RAM64M
       10   RAMB36E1
        2   RAMB18E1
        1   SRL16E
        1 submodules
        1   FgmCore_x_mat0
"""

OLD_STAT = """
=== top ===

   Number of wires:                 12
   Number of cells:                  5
     LUT4                            3
     TRELLIS_FF                      2
"""


def test_yosys_stat_recent_layout():
    cells = parsers.parse_yosys_stat(ECP5_STAT)
    assert "$scopeinfo" not in cells
    assert parsers.ecp5_resources(cells) == {"MULT18X18D": 42, "LUT4": 9437, "CCU2C": 1321, "FF": 5664,
                                           "DP16KD": 21, "LUTRAM": 10}


def test_yosys_stat_hierarchy_takes_totals():
    res = parsers.xc7_resources(parsers.parse_yosys_stat(XC7_STAT_HIER))
    assert res["DSP48E1"] == 42
    assert res["LUT"] == 40 + 1316 + 1073 + 755 + 2044 + 838
    assert res["FF"] == 3957 + 743
    assert res["RAMB36E1"] == 10 and res["RAMB18E1"] == 2 and res["RAMB"] == 11.0
    assert res["LUTRAM"] == 8 + 12 + 1


def test_yosys_stat_old_layout_and_empty():
    assert parsers.parse_yosys_stat(OLD_STAT) == {"LUT4": 3, "TRELLIS_FF": 2}
    with pytest.raises(ValueError):
        parsers.parse_yosys_stat("nothing here\n")


def test_memory_mapping():
    log = """
2.28. Executing MEMORY_LIBMAP pass (mapping memories to cells).
using FF mapping for memory top.betaRam.mem
mapping memory top.xboxRam.mem via $__TRELLIS_DPR16X4_
mapping memory top.matRam_0.mem via $__PDPW16KD_
"""
    assert parsers.parse_memory_mapping(log) == {"top.betaRam.mem": "FF", "top.xboxRam.mem": "TRELLIS_DPR16X4",
                                               "top.matRam_0.mem": "PDPW16KD"}
    assert qp._mem_name("top.matRam_0.mem", "top") == "matRam_0"
    assert qp._mem_name("top_mat0.mem", "top") == "mat0"


def _step(kind, delay, cell, port="F", net=None):
    s = {"type": kind, "delay": delay, "from": {"cell": cell, "port": port}, "to": {"cell": cell, "port": port}}
    if net:
        s["net"] = net
    return s


CLK = "posedge $glbnet$clock$TRELLIS_IO_IN"
REPORT = {
    "fmax": {"$glbnet$clock$TRELLIS_IO_IN": {"achieved": 69.5, "constraint": 200}},
    "utilization": {"MULT18X18D": {"available": 156, "used": 42}, "DCUA": {"available": 2, "used": 0}},
    "critical_paths": [
        {"from": "<async>", "to": CLK, "path": [_step("source", 0.0, "io")]},
        {"from": CLK, "to": CLK, "path": [
            _step("clk-to-q", 4.1, "bndRam_0.mem.0.0", "DOA13"),
            _step("routing", 1.0, "bndRam_0.mem.0.0", "DOA13", net="n1"),
            _step("logic", 0.18, "lut_a"),
            _step("routing", 2.8, "lut_a", net="n2"),
            _step("logic", 0.13, "mux_b"),
            _step("routing", 0.1, "mux_b", net="n3"),
            _step("setup", 0.0, "yReg_26_TRELLIS_FF_Q", "DI"),
        ]},
    ],
}


def test_nextpnr_report():
    r = parsers.parse_nextpnr_report(REPORT)
    assert r["fmax_mhz"] == 69.5 and r["target_mhz"] == 200
    assert r["utilisation"] == {"MULT18X18D": 42}
    cp = r["critical_path"]
    assert cp["from"] == "bndRam_0.mem.0.0.DOA13" and cp["to"] == "yReg_26_TRELLIS_FF_Q.DI"
    assert cp["logic_levels"] == 2 and cp["cells"] == ["lut_a", "mux_b"]
    assert cp["nets"] == ["n1", "n2", "n3"]
    assert math.isclose(cp["total_ns"], 4.1 + 1.0 + 0.18 + 2.8 + 0.13 + 0.1)
    assert math.isclose(cp["routing_ns"], 3.9) and math.isclose(cp["logic_ns"], 0.31)
    assert cp["max_net"] == (2.8, "n2")
    with pytest.raises(ValueError):
        parsers.parse_nextpnr_report({"fmax": {}})


def test_nextpnr_log_takes_last_fmax():
    log = """Info: Max frequency for clock '$glbnet$clk': 61.43 MHz (FAIL at 200.00 MHz)
Info: Routing complete.
ERROR: Max frequency for clock '$glbnet$clk': 69.57 MHz (FAIL at 200.00 MHz)
"""
    assert parsers.parse_nextpnr_log(log) == {"clock": "$glbnet$clk", "fmax_mhz": 69.57, "target_mhz": 200.0,
                                            "pass": False}
    assert parsers.parse_nextpnr_log("Info: Max frequency for clock 'c': 250.1 MHz (PASS at 200.00 MHz)")["pass"]
    assert parsers.parse_nextpnr_log("no timing here") is None


def test_lpf_frequency():
    assert parsers.lpf_frequency('# one clock\nFREQUENCY PORT "clock" 200 MHZ;\n') == 200.0
    assert parsers.lpf_frequency('FREQUENCY PORT clock 87.5 MHz;') == 87.5
    assert parsers.lpf_frequency('LOCATE COMP "clock" SITE "P3";') is None


def test_ecp5_fit():
    res = {"MULT18X18D": 168, "DP16KD": 40, "LUT4": 30000, "CCU2C": 4000, "FF": 20000, "LUTRAM": 10}
    assert parsers.ecp5_fit(res) == ["168 MULT18X18D needed, 156 on the LFE5U-85F"]
    assert parsers.ecp5_fit(dict(res, MULT18X18D=156)) == []


def test_cycle_formulas_match_table3():
    # masses, n = 40, l_A = l_M = 1, Imax = 15: eq. (23) and Table III of 002 at 400 and 230 MHz
    for P, (mult, v6, s6) in fgm.PAPER_TABLE3.items():
        cycles = 15 * fgm.eq23(40, P, 1, 1)
        assert fgm.paper_multipliers(40, P) == mult
        assert round(report.latency_us(cycles, qp.F_V6_MHZ), 2) == pytest.approx(v6, abs=0.011)
        assert round(report.latency_us(cycles, qp.F_S6_MHZ), 2) == pytest.approx(s6, abs=0.011)
    assert fgm.eq23(40, 1, 1, 1) == 52


def test_latency_and_ratio():
    assert report.latency_us(822, 69.57) == pytest.approx(11.815, abs=1e-3)
    assert report.latency_us(822, None) is None
    assert report.ratio(90.0, 11.8) == pytest.approx(7.627, abs=1e-3)
    assert report.ratio(None, 1.0) is None and report.ratio(1.0, None) is None


def test_mac_utilisation():
    assert fgm.useful_macs(40) == 1680
    assert fgm.mac_utilisation(40, 42, 52) == pytest.approx(1680 / 2184)
    assert fgm.mac_utilisation(40, 336, 18) == pytest.approx(1680 / 6048)
    assert fgm.mac_utilisation(1, 3, 1) == 1.0


def test_rtl_names_from_netlist_names():
    names = ["bndRam_0.mem.0.0", "bndRam_0.mem.0.0_DOA13[1]", "proj.io_out_r_TRELLIS_FF_Q_13_DI_PFUMX_Z_ALUT",
             "tokY_h_LUT4_D_1_Z[3]", "warmL_LUT4_C_Z[4]", "yReg_26_TRELLIS_FF_Q_DI", "yReg_26_TRELLIS_FF_Q"]
    assert parsers.rtl_names(names) == ["bndRam_0", "proj.io_out_r", "tokY_h", "warmL", "yReg_26"]
    assert parsers.parse_nextpnr_report(REPORT)["critical_path"]["signals"] == ["bndRam_0", "n1", "n2", "n3",
                                                                               "yReg_26"]


def test_paper_memory_blocks():
    assert fgm.paper_memory_blocks(40, 8, 1) == (52, 40)
    assert fgm.paper_memory_blocks(40, 8, 3) == (156, 14)


def test_step_kinds():
    def st(kind, cell, fp, tp):
        return {"type": kind, "delay": 0.1, "from": {"cell": cell, "port": fp}, "to": {"cell": cell, "port": tp}}

    assert parsers.step_kind(st("clk-to-q", "matRam_0.mem.0.4", "DOA8", "DOA8")) == "DP16KD read"
    assert parsers.step_kind(st("clk-to-q", "tokY_r_9_k_TRELLIS_FF_Q_1", "Q", "Q")) == "FF"
    assert parsers.step_kind(st("logic", "pb_DI_MULT18X18D_P26", "B15", "P22")) == "MULT18X18D"
    assert parsers.step_kind(st("logic", "x_CCU2C_S0$CCU2_COMB1", "FCI", "FCO")) == "CCU2C"
    assert parsers.step_kind(st("logic", "x_PFUMX_Z_BLUT_LUT4_Z", "M", "OFX")) == "PFUMX/L6MUX21"
    assert parsers.step_kind(st("logic", "x_LUT4_Z", "C", "F")) == "LUT4"
    cp = parsers.parse_nextpnr_report(REPORT)["critical_path"]
    assert cp["source_kind"] == "DP16KD read"
    assert cp["kinds"] == {"LUT4": 2}


def test_software_sessions_merge_and_best_median():
    def session(times, load):
        r = baselines.SwResult("OSQP tuned", "s", np.array(times, dtype=float), 1e-3, [5] * np.size(times))
        return {"solvers": [r], "repeats": len(times), "load": load}

    m = baselines.merge_software(session([[30, 31, 90]], 2.5), session([[25, 26, 27], [40, 41, 42]], 0.1))
    r = m["solvers"][0]
    assert r.times_us.shape == (3, 3) and m["repeats"] == 3 and m["load"] == [2.5, 0.1]
    assert r.median_us == 26.0
    assert len(r.iters) == 9
    assert baselines.merge_software(None, m) is m


# ----------------------------------------------------------------------------------------- ADMM

def test_eq24_and_table3b():
    # masses_rate_soft, n_A = 216, l_A = l_M = 1, Imax = 40: Table III(b) of 002 is Imax (eq. (24) + 1) cycles
    assert admm_report.eq24(216, 1, 1, 1) == 216 + 8 + 1 + 6 + 2 == 233
    assert admm_report.eq24(216, 4, 1, 1) == 71 and admm_report.eq24(216, 8, 1, 1) == 44
    assert admm_report.eq24(19, 2, 2, 3) == 10 + 2 * 5 + 3 + 12 + 2
    for P, (mult, v6, s6) in admm_report.PAPER_TABLE3_ADMM.items():
        cycles = admm_report.table3b_cycles(216, P, 1, 1, 40)
        assert cycles == 40 * (admm_report.eq24(216, P, 1, 1) + 1)
        assert admm_report.paper_multipliers_admm(216, P) == mult
        assert report.latency_us(cycles, qp.F_V6_MHZ) == pytest.approx(v6, abs=0.006)
        assert report.latency_us(cycles, qp.F_S6_MHZ) == pytest.approx(s6, abs=0.006)
    # Imax eq. (24) alone misses the table by one cycle per iteration
    assert report.latency_us(40 * admm_report.eq24(216, 1, 1, 1), qp.F_V6_MHZ) == pytest.approx(23.30)


def test_admm_memory_blocks():
    assert admm_report.paper_memory_blocks_admm(216, 1) == (224, 216)
    assert admm_report.paper_memory_blocks_admm(216, 8) == (1792, 27)
    assert admm_report.paper_memory_blocks_admm(19, 2) == (54, 10)


def test_admm_mac_utilisation():
    assert admm_report.admm_useful_macs(216) == 46656
    # P = 1: 216 multipliers, L_A = 232
    assert admm_report.admm_mac_utilisation(216, 216, 232) == pytest.approx(216 / 232)
    assert admm_report.admm_mac_utilisation(216, 1728, 43) == pytest.approx(46656 / (1728 * 43))
    assert admm_report.admm_mac_utilisation(1, 1, 1) == 1.0


def test_solve_cycles_from_a_short_simulation():
    # the cycle contract 2 + (Imax + 1) L_A, measured at Imax = 5 and carried to Imax = 40
    L = 232
    simulated = 2 + 6 * L
    over = admm_report.solve_overhead(simulated, 5, L)
    assert over == 2 + L
    assert admm_report.cycles_at(over, 40, L) == 2 + 41 * L == 9514
    assert admm_report.cycles_at(admm_report.solve_overhead(822, 15, 52), 15, 52) == 822


def test_soft_projection_closed_form():
    from mpc_cores.admm.problem import project_soft

    rng = np.random.default_rng(3)
    x, d = 2 * rng.standard_normal(2000), rng.standard_normal(2000)
    c, r = 0.3 * rng.standard_normal(2000), rng.uniform(0.05, 1.0, 2000)
    # every case of Fig. 3b: inside, below the flat edge, beyond the corner, onto the slanted edge, and the borders
    x[:4], d[:4], c[:4], r[:4] = [0.2, 0.9, 3.0, 1.5], [0.5, -0.3, -4.0, 0.1], 0.0, 0.5
    x[4:6], d[4:6], c[4:6], r[4:6] = [0.5, -0.7], [0.0, 0.2], 0.0, 0.5
    xo, do = baselines.soft_projection(x, d, c, r)
    xe, de = project_soft(x, d, c, r)
    assert np.allclose(xo, xe, rtol=0, atol=1e-12) and np.allclose(do, de, rtol=0, atol=1e-12)
    assert np.all(do >= 0) and np.all(np.abs(xo - c) <= r + do + 1e-12)


@pytest.fixture(scope="module")
def small_admm():
    from mpc_cores.admm.design import design_admm

    return design_admm(admm.small_admm_problem(), sizing_solves=8)


def test_small_admm_problem(small_admm):
    d = small_admm
    assert (d.n, d.nw, d.qp.ns, d.b, d.iterations) == (19, 4, 1, 18, 40)


def test_numpy_admm_is_admmfloat(small_admm):
    from mpc_cores.admm.model import AdmmFloat

    d = small_admm
    rng = np.random.default_rng(5)
    a, f = baselines.NumpyAdmm(d), AdmmFloat(d)
    lo, hi = d.qp.wlo, d.qp.whi
    for _ in range(8):           # warm-started sequence: the shift of (z, nu) included
        w = rng.uniform(lo, hi)
        assert np.allclose(a.solve(w), f.solve(w)[0], rtol=0, atol=1e-12)


def _admm_core(P, role="sweep", problem="masses_rate_soft", n=216, pnr=None, mult=None):
    from types import SimpleNamespace

    L = admm_report.eq24(n, P, 1, 1) - 1
    c = admm.Core("admm", problem, P, 18, None, SimpleNamespace(
        qp=SimpleNamespace(problem=SimpleNamespace(nx=2), nu=1, N=3, ns=1), multipliers=P * n), 40, role=role)
    c.core = {"n": n, "nw": 17, "ns": 4, "N": 10, "lat_add": 1, "lat_mul": 1, "cycles_per_iteration": L,
              "cycles_eq24": L + 1, "solve_overhead_cycles": 2 + L, "multipliers": P * n, "module": "AdmmCore_x",
              "signals": {"coef": {"width": 20}, "v": {"width": 29}, "w": {"width": 21}}}
    c.measured = {"cycles_per_iteration": L, "cycles_per_solve": 2 + 6 * L, "iterations": 5}
    c.ecp5 = {"MULT18X18D": mult or 4 * P * n, "LUT4": 1000, "CCU2C": 10, "FF": 900, "DP16KD": 2, "LUTRAM": 0}
    c.pnr = pnr
    c.pnr_note = "" if pnr else "does not fit: " + "; ".join(parsers.ecp5_fit(c.ecp5))
    return c


def test_admm_rows_and_report():
    pnr = parsers.parse_nextpnr_report(REPORT)
    cores = [_admm_core(1), _admm_core(4), _admm_core(1, "fmax", "small_rate_soft", 19, pnr, 76)]
    est, tag = admm_report.admm_fmax_estimate(cores)
    assert est == 69.5 and "small_rate_soft" in tag
    sw = {"solvers": [baselines.SwResult(name, "s", np.array([[400.0, 500.0]]), 1e-2, None, 1e-3)
                      for name in ("OSQP default", "OSQP tuned", baselines.NumpyAdmm.name)]}
    recs = admm_report.admm_rows(cores, sw, est)
    r1, r4, rs = recs
    assert r1["cycles_per_solve_measured"] == 2 + 41 * 232 and r1["cycles_per_solve_table3b"] == 40 * 234
    assert r1["latency_us_v6_paper"] == 23.40 and r4["latency_us_s6_paper"] == 12.52
    assert r1["latency_us_ecp5_est"] == pytest.approx(9514 / 69.5) and rs["latency_us_ecp5_est"] is None
    assert rs["latency_us_ecp5"] == pytest.approx((2 + 41 * (admm_report.eq24(19, 1, 1, 1) - 1)) / 69.5)
    assert r1["osqp_tuned_over_core"] == pytest.approx(450.0 / (9514 / 69.5))
    assert r1["numpy_admm_over_core_v6"] == pytest.approx(450.0 / (9514 / 400))
    assert rs["osqp_tuned_us"] is None
    assert r4["mac_utilisation"] == pytest.approx(216 * 216 / (864 * 70))
    table = "\n".join(admm_report.admm_summary_table([r1, r4]))
    assert "232 (233)" in table and "no: 864 MULT18X18D" in table and "23.79 (23.40)" in table
    info = {"machine": {"cpu": "cpu", "cores": 2, "logical": 2, "system": "Linux", "python": "3"}, "date": "d",
            "quick": True, "Ps": (), "bs": (), "admm_Ps": (1, 4), "admm_bs": (18,), "admm_small_Ps": (1,),
            "xilinx": False, "jobs": 1, "errors": [], "runtime_s": 60.0, "revision": "abc"}
    sw_admm = dict(sw, repeats=1, load=[0.5, 0.6], core_err={18: (0.1, 1e-3, 1)}, steps=2, hold=1, imax=40,
                   u_box=(-0.1, 0.1), ref_iters=(400.0, 900), numpy_vs_admmfloat=0.0,
                   active={"soft": 0.2, "box": 0.5, "rate": 0.4})
    md = bench.report_md(cores, [], recs, {"admm": sw_admm}, info)
    assert "## ADMM core: masses_rate_soft" in md and "Table III(b)" in md
    assert "small_rate_soft" in md and "69.5" in md and "no ECP5 holds" in md
    assert "synthesised hierarchically" in md
    assert [c.placeable for c in cores] == [False, False, True] and cores[0].hierarchical


def test_memory_list_counts_unnamed():
    mems = {"top.mat0.mem": "PDPW16KD", "cc:155:do_switch$11153": "FF", "cc:155:do_switch$11157": "FF",
            "top_w_box.mem": "TRELLIS_DPR16X4"}
    assert qp._mem_list(mems, "top") == "mat0 -> PDPW16KD, w_box -> TRELLIS_DPR16X4, 2 unnamed -> FF"


def test_admm_estimate_moves_cycles_to_the_small_cores_latencies():
    pnr = parsers.parse_nextpnr_report(REPORT)
    small = _admm_core(1, "fmax", "small_rate_soft", 19, pnr, 76)
    small.core.update(lat_add=2, lat_mul=3)
    big = _admm_core(4)
    recs = admm_report.admm_rows([big, small], None, 69.5)
    # eq. (24) at l_A = 2, l_M = 3 against 1, 1 for n_A = 216: 2 more cycles of multiplier, 8 + 6 of adders
    delta = admm_report.eq24(216, 4, 2, 3) - admm_report.eq24(216, 4, 1, 1)
    assert delta == 2 + 8 + 6
    assert recs[0]["cycles_per_solve_est"] == recs[0]["cycles_per_solve_measured"] + 41 * delta
    assert recs[0]["latency_us_ecp5_est"] == pytest.approx(recs[0]["cycles_per_solve_est"] / 69.5)
    assert recs[0]["est_lat"] == (2, 3) and recs[1]["cycles_per_solve_est"] is None
    assert "l_A = 2, l_M = 3" in admm_report._est_lat_text(recs)


def test_fmax_table_names_kind_latencies_and_formula():
    pnr = parsers.parse_nextpnr_report(REPORT)
    small = _admm_core(1, "fmax", "small_rate_soft", 19, pnr, 76)
    small.core.update(lat_add=2, lat_mul=3)
    r = admm_report.admm_rows([small], None, None)[0]
    table = "\n".join(admm_report.fmax_summary_table([r]))
    assert "| ADMM | small_rate_soft | 19 | 1 | 18 | 2, 3 |" in table and "eq. (24)" in table and "69.5" in table


def test_fgm_rows_of_an_interleaving_core():
    """An Fmax core with K_p problems: the ratios use its worst latency and its measured solves per second, and the
    interleaving table shows the latency's range, the period and the MAC use."""
    from types import SimpleNamespace

    pnr = parsers.parse_nextpnr_report(REPORT)
    c = fgm.Core("fgm", "masses", 3, 15, None, SimpleNamespace(multipliers=126), 15, role="fmax")
    c.core = {"n": 40, "nw": 12, "nx": 8, "iterations": 15, "lat_add": 1, "lat_mul": 5, "cycles_per_iteration": 34,
              "cycles_eq23": 34, "cycles_per_solve": 669, "solve_overhead_cycles": 39, "multipliers": 126,
              "problems": 3, "latency_cycles": {"min": 669, "max": 710}, "module": "FgmCore_x"}
    c.measured = {"cycles_per_iteration": 34, "cycles_per_solve": 669, "latency_max": 710, "solve_period": 672}
    c.pnr = pnr
    sw = {"solvers": [baselines.SwResult("DAQP (hot start)", "s", np.array([[4.0, 5.0, 30.0]]), 1e-9)]}
    r = fgm.fgm_rows([c], sw)[0]
    f = pnr["fmax_mhz"]
    assert r["latency_us_ecp5_max"] == pytest.approx(710 / f) and r["core_latency_us"] == pytest.approx(710 / f)
    assert r["core_solves_per_s"] == pytest.approx(3 / 672 * f * 1e6)
    assert r["mac_utilisation"] == pytest.approx((40 * 40 + 80) / (126 * 14))
    med = sw["solvers"][0].median_us
    assert r["daqp_hot_start_throughput_ratio"] == pytest.approx(3 / 672 * f * 1e6 / (1e6 / med))
    table = "\n".join(fgm.interleave_table([r], sw))
    assert "| 3 | 3 | 1 |" in table and "669 to 710" in table and "672" in table and "95.2 %" in table
    # two copies placed together: twice the solves per second of the device, the same latency
    c.copies = 2
    r2 = fgm.fgm_rows([c], sw)[0]
    assert r2["core_solves_per_s"] == pytest.approx(2 * 3 / 672 * f * 1e6) and r2["copies"] == 2
    assert r2["latency_us_ecp5_max"] == r["latency_us_ecp5_max"]
    assert r2["daqp_hot_start_throughput_ratio"] == pytest.approx(2 * r["daqp_hot_start_throughput_ratio"])
    assert "| 3 | 3 | 2 |" in "\n".join(fgm.interleave_table([r2], sw)) and "x2 cores" in c.tag
    assert not c.placeable                                           # 2 x 126 multipliers > 156


def test_median_of_placement_seeds():
    """The Fmax cores of a full run are placed with three seeds: the median run's Fmax and path, every Fmax beside."""
    from mpc_bench.tools import median_run
    from mpc_bench.report import pnr_cells
    from types import SimpleNamespace

    runs = [{"fmax_mhz": f, "target_mhz": 200.0, "seed": s, "critical_path": None}
            for s, f in ((1, 150.6), (2, 146.4), (3, 159.7))]
    m = median_run(runs)
    assert m["fmax_mhz"] == 150.6 and m["seed"] == 1 and m["fmax_seeds"] == [146.4, 150.6, 159.7]
    assert pnr_cells(SimpleNamespace(pnr=m, pnr_note=""), "1")[0] == "150.6 (146.4, 150.6, 159.7)"
    assert median_run(runs[:1])["fmax_seeds"] == [150.6]


def test_fgm_fmax_core_list():
    """--fgm-fmax: P, P x K_p or P x K_p x copies items; the defaults place one problem and two interleaved at
    P = 1, and one problem at P = 3 (copies only when asked)."""
    assert fgm.fmax_cores("1,1x2,3x3,1x2x3", None) == ((1, 1, 1), (1, 2, 1), (3, 3, 1), (1, 2, 3))
    assert fgm.fmax_cores(None, fgm.FMAX_FULL) == ((1, 1, 1), (1, 2, 1), (3, 1, 1))
    assert fgm.FMAX_QUICK == ((1, 1, 1),)
    for bad in ("1x2x3x4", "0x2", "1xx2"):
        with pytest.raises(ValueError):
            fgm.fmax_cores(bad, None)


def test_scaling_sweep_parts(tmp_path):
    """mpc_bench.scaling: the chain of 4 masses at N = 10 is examples/masses.yaml's plant and QP, and with the hard
    position limits examples/masses_state.yaml's state-constrained QP; the report's tables, verdicts and plot from
    canned rows (an instance that does not fit says so); each kind's clock from its placed core (records or CSV
    rows), given, or the constraint."""
    from mpc_bench import scaling, scaling_dgp
    from mpc_cores.dgp.problem import dgp_qp
    from mpc_cores.problem import condense, load_spec

    from mpc_cores.flow import REPO

    a, b = condense(scaling.chain(4, 10)), condense(load_spec(REPO / "examples/masses.yaml"))
    assert np.allclose(a.H, b.H) and np.allclose(a.Phi, b.Phi) and np.allclose(a.lb, b.lb)
    s, t = dgp_qp(scaling_dgp.chain_state(4, 10)), dgp_qp(load_spec(REPO / "examples/masses_state.yaml"))
    for f in ("Q", "Phi", "G", "lo0", "hi0", "Lw"):
        assert np.allclose(getattr(s, f), getattr(t, f)), f
    row = {"core": "fgm", "M": 2, "N": 5, "n": 10, "P": 8, "mult18x18d": 96, "dp16kd_est": 96, "imax": 4,
           "cycles_per_iteration": 20, "core_error_max": 0.03, "daqp_error_max": 1e-10}
    for q, v in (("median", 1), ("p99", 3), ("max", 4)):
        row.update({f"core_iter_{q}": v, f"core_us_{q}": 0.1 * v, f"daqp_own_{q}_us": 0.2 * v,
                    f"daqp_own_{q}_over_core": 2.0, f"osqp_tuned_own_{q}_us": 2.0 * v})
    far = {"M": 8, "N": 30, "n": 240, "P": 0, "note": "does not fit at P = 1: 484 MULT18X18D, 300 DP16KD"}
    text = "\n".join(scaling.table([row, far]))
    assert "| 2 | 5 | 10 | 8 | 96 / 96, Imax 4, L_F 20 | 1 / 3 / 4 | 0.10 / 0.30 / 0.40 |" in text
    assert "does not fit at P = 1" in text
    clocks = scaling.clock_texts({"fgm": 217.7, "dgp": 130.3}, None)
    scaling.plot([row, far], tmp_path / "s.png", clocks)
    assert (tmp_path / "s.png").stat().st_size > 1000
    drow = dict(row, core="dgp", P=2, lanes=29, mc=80, imax=1, cycles_per_iteration=178, active_input_fraction=0.25,
                active_state_fraction=0.0)
    for q, v in (("median", 0.5), ("p99", 2.0), ("max", 0.5)):
        drow[f"daqp_own_{q}_over_core"] = v
    text = "\n".join(scaling_dgp.table([drow, dict(far, core="dgp")]))
    assert "| 2 | 5 | 10 | 2 x 29 | 96 / 96, 80 rows, Imax 1, 178 cycles / iteration | 25 % / 0 % | 1 / 3 / 4 |" in text
    assert scaling._verdict([drow])[0].endswith("none.") and scaling._verdict([row])[0].endswith("(n = 10).")
    assert scaling._verdict([drow, far])[1] == "Largest instance of the grid that fits the LFE5U-85F: n = 10."
    scaling.plot([row, far, drow], tmp_path / "s2.png", clocks)
    assert (tmp_path / "s2.png").stat().st_size > (tmp_path / "s.png").stat().st_size
    (tmp_path / "fgm.csv").write_text("role,early_exit,fmax_mhz\nsweep,False,90.5\nfmax,True,217.7\n")
    (tmp_path / "dgp.csv").write_text("role,fmax_mhz\naccelerated,\nunits,130.259\n")
    fgm_rows, dgp_rows = scaling.csv_rows(tmp_path / "fgm.csv"), scaling.csv_rows(tmp_path / "dgp.csv")
    assert scaling.placed_clocks(fgm_rows, dgp_rows) == {"fgm": 217.7, "dgp": 130.259}
    assert scaling.placed_clocks([{"role": "fmax", "early_exit": True, "fmax_mhz": 201.5}], []) == {"fgm": 201.5}
    assert scaling.csv_rows(tmp_path / "none.csv") == [] and scaling.placed_clocks([], []) == {}
    assert clocks["fgm"][0] == 217.7 and "exit-test" in clocks["fgm"][1] and "an estimate" in clocks["fgm"][1]
    assert clocks["dgp"][0] == 130.3 and "row-unit" in clocks["dgp"][1]
    given = scaling.clock_texts({"fgm": 217.7}, 150.0)
    assert given["fgm"] == given["dgp"] == (150.0, "at 150.0 MHz (given)")
    alone = scaling.clock_texts({"fgm": 217.7}, None)["dgp"]
    assert alone[0] == 200.0 and "no placed core" in alone[1]
    long = dict(far, core="fgm", note="check: the closed-loop cost stays 1.8 % from the optimal MPC's at every Imax " + "x" * 80)
    assert scaling.notes_md([row]) == [] and scaling.notes_md([row, long])[2].endswith("x" * 80)
    md = "\n".join(scaling.report_lines([row, drow, long], ["x"], clocks, False, 2, "origin"))
    assert "- M = 8, N = 30 (n = 240): check: the closed-loop cost stays 1.8 %" in md
    assert md.startswith("## FGM and DGP cores") and "### Input box: the FGM core" in md
    assert "The FGM rows at 217.7 MHz" in md and "the DGP rows at 130.3 MHz" in md
    sec = scaling.Section(None, [])
    assert sec.appendix and sec.appendix_md() == [] and sec.plots(None, tmp_path) == []
    sec.rows, sec.notes, sec.clocks, sec.quick = [row, drow], ["x"], clocks, False
    assert sec.appendix_md()[0] == "## FGM and DGP cores against DAQP as the problem grows (full)"
    assert sec.plots(None, tmp_path) == [tmp_path / "scaling.png"] and sec.csv_name == "scaling.csv"
    from mpc_bench.bench import wants_scaling
    assert wants_scaling("auto", False, {"fgm", "dgp", "ipm"}) and not wants_scaling("auto", True, {"fgm", "dgp"})
    assert not wants_scaling("auto", False, {"dgp"}) and wants_scaling("on", True, {"dgp"})
    assert not wants_scaling("off", False, {"fgm", "dgp"})


def test_scaling_instance_without_a_holdable_reference():
    """A chain whose references cannot be held inside the input box (8 masses: the steady-state forces outgrow it)
    is a row with a note (chains.NoLoop), not a crash of the sweep; other errors pass through."""
    from mpc_bench import chains
    from mpc_cores.closedloop import reference_schedule

    with pytest.raises(chains.NoLoop, match="can be held within 90% of the input box"):
        with chains.references_held():
            reference_schedule(chains.chain(8, 5), 200, 30, 0)
    with pytest.raises(ValueError, match="other") as e:
        with chains.references_held():
            raise ValueError("other")
    assert not isinstance(e.value, chains.NoLoop)


def test_scaling_is_the_last_part_of_a_full_run(tmp_path, monkeypatch):
    """The driver's scaling section runs after the kinds' sections (in finish), takes each kind's clock from that
    kind's section records, and lands in report.md (after the shared tables), scaling.csv and scaling.png."""
    import argparse

    from mpc_bench import scaling
    from mpc_bench.section import Run, Section, run_sections

    class Stub(Section):
        def __init__(self, name, rows, run):
            self.name, self.stub_rows = name, rows
            super().__init__(run)

        def finish(self):
            self.rows = self.stub_rows

    seen = {}

    def sweep(quick, clocks, repeats, log):
        seen["clocks"] = {k: v[0] for k, v in clocks.items()}
        row = {"core": "fgm", "M": 2, "N": 5, "n": 10, "P": 0, "note": "does not fit at P = 1: canned"}
        return [row, dict(row, core="dgp")], ["canned"]

    monkeypatch.setattr(scaling, "sweep", sweep)
    info = {"machine": {"cpu": "cpu", "cores": 2, "logical": 2, "system": "Linux", "python": "3"}, "date": "d",
            "quick": False, "xilinx": False, "jobs": 1, "errors": [], "sw_seconds": {}, "runtime_s": 1.0}
    run = Run(argparse.Namespace(quick=False, jobs=1), tmp_path, lambda m: None, info)
    kinds = [Stub("fgm", [{"role": "fmax", "early_exit": True, "fmax_mhz": 210.0}], run),
             Stub("dgp", [{"role": "units", "fmax_mhz": 131.0}], run)]
    sections = kinds + [scaling.Section(run, kinds)]
    run_sections(sections, run)
    assert seen["clocks"] == {"fgm": 210.0, "dgp": 131.0}
    path = report.write_outputs(tmp_path, sections, info, lambda m: None)
    md = path.read_text()
    assert md.index("## Step times") < md.index("## FGM and DGP cores against DAQP as the problem grows (full)")
    assert "The FGM rows at 210.0 MHz" in md and "the DGP rows at 131.0 MHz" in md
    assert "- M = 2, N = 5 (n = 10): does not fit at P = 1: canned" in md
    assert (tmp_path / "scaling.csv").read_text().startswith("core,M,N,n,P")
    assert (tmp_path / "scaling.png").exists()


def test_publish_names_the_run_and_latest_is_the_full_run(tmp_path):
    """latest.md, the report the docs quote, is only ever a full run of every kind; a QUICK run and a section run
    get dated copies of their own names."""
    src = tmp_path / "report.md"
    docs = tmp_path / "docs"
    base = {"date": "2026-12-01 01:49 UTC", "quick": False, "kinds": ["admm", "dgp", "fgm"], "complete": True}
    src.write_text("full run")
    assert report.publish(src, docs, base).name == "2026-12-01-full.md"
    assert (docs / "latest.md").read_text() == "full run"
    src.write_text("quick run")
    assert report.publish(src, docs, dict(base, quick=True)).name == "2026-12-01-quick.md"
    src.write_text("section run")
    assert report.publish(src, docs, dict(base, kinds=["dgp", "ipm"], complete=False)).name == "2026-12-01-dgp-ipm.md"
    assert (docs / "latest.md").read_text() == "full run"
