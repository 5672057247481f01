"""The DGP section of the benchmark (mpc_bench.dgp, mpc_bench.dgp_report) on fabricated tool results: its plan and
jobs, the records and report lines, the closed loop and the software solvers on a small problem. No sbt, no
Verilator, no Yosys, no nextpnr."""
from __future__ import annotations

import argparse
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from conftest import random_problem
from mpc_bench import dgp, dgp_report, tools
from mpc_bench.baselines import SwResult
from mpc_bench.parsers import ECP5_85F
from mpc_bench.report import latency_us
from mpc_bench.section import Run
from mpc_cores.flow import REPO

SV = "module Top(input clock, input reset, input [3:0] a, output y);\nendmodule\n"


def _run(tmp_path: Path, quick: bool, **kw) -> Run:
    a = argparse.Namespace(**dict(dict(quick=quick, no_xilinx=False, repeats=None, jobs=1, dgp_no_place=False), **kw))
    return Run(a, tmp_path, lambda msg: None, {"errors": [], "sw_seconds": {}, "date": "2026-11-23 10:00 UTC"})


@pytest.fixture(scope="module")
def planned():
    """The section's plan in a full and a QUICK run (the designs of masses_state, cached between the two; the
    section refuses /tmp, which the YoWASP tools do not see)."""
    out = REPO / "build" / "tests" / "bench_dgp"
    full = dgp.Section(_run(out, quick=False))
    full.plan()
    quick = dgp.Section(_run(out, quick=True))
    quick.plan()
    return full, quick


def test_plan_five_cores_for_the_ecp5(planned):
    full, quick = planned
    assert not full.errors and not quick.errors
    assert [c.role for c in full.cores] == list(dgp.ROLES)
    acc, plain, units, shifted, ram = full.cores
    assert acc.design.accelerated and not plain.design.accelerated
    assert units.design.accelerated and (units.design.P, units.design.lanes, units.design.b) == (2, 20, 15)
    assert shifted.design.warm_shift and not units.design.warm_shift
    assert (shifted.design.P, shifted.design.lanes, shifted.design.b) == (2, 20, 15)
    assert ram.design.warm_shift and ram.design.ram_state and not shifted.design.ram_state
    assert (ram.design.P, ram.design.lanes, ram.design.b) == (2, 20, 15)
    assert len({c.design.module_name for c in full.cores}) == 5 and "l20u2_b15a_" in units.design.module_name
    assert "l20u2_b15as_" in shifted.design.module_name and "l20u2_b15asr_" in ram.design.module_name
    assert {c.design.target for c in full.cores} == {"ecp5"}
    assert acc.out != plain.out and acc.design.module_name != plain.design.module_name
    # the seeds of the Fmax cores of the other sections
    assert all(c.pnr_seeds == tools.FMAX_SEEDS for c in full.cores)
    assert all(c.pnr_seeds == tools.FMAX_SEEDS_QUICK for c in quick.cores)
    assert full.steps > quick.steps and full.states > quick.states
    assert full.xilinx and not quick.xilinx


def test_multipliers_of_the_products(planned):
    from mpc_cores.target import parts

    acc, plain, units, _, ram = planned[0].cores
    # accelerated: the lanes plus the 4 + 2 products of the extrapolation and the restart test, per row unit
    for c in (acc, units):
        d = c.design
        want = sum(k * parts("ecp5", a, b) for (a, b), k in zip(d.products(), [d.P * d.lanes, 4 * d.P, 2 * d.P]))
        assert c.mult18 == want
    assert plain.mult18 == plain.design.lanes * parts("ecp5", *plain.design.products()[0])
    assert acc.mult18 > plain.mult18
    assert acc.placeable == (acc.mult18 <= ECP5_85F["MULT18X18D"])
    # 15 fraction bits: two MULT18X18D per lane, the row units' 40 lanes and their element stages fit the device
    assert units.mult18 == 2 * 40 + 2 * (4 * 4 + 2 * 2) <= ECP5_85F["MULT18X18D"] and units.placeable
    # the dual in block RAM: the same products
    assert ram.mult18 == units.mult18 and ram.placeable


def _with_sv(c) -> None:
    c.out.mkdir(parents=True, exist_ok=True)
    (c.out / "Top.sv").write_text(SV)
    c.core = {"sv": "Top.sv", "module": "Top"}


def _cache(c, step: str) -> None:
    """Files and keys as a run of the step on this SystemVerilog leaves them."""
    if step == "ecp5":
        d, _, outputs, key = tools._yosys_step(c, "ecp5")
        d.mkdir(exist_ok=True)
        for f in outputs:
            f.write_text("")
        (d / "yosys.key").write_text(key)
    else:
        for seed in c.pnr_seeds:
            _, _, key = tools._pnr_step(c, seed)
            report, plog, kf = tools._pnr_files(c.out / "ecp5", seed)
            report.write_text("")
            plog.write_text("")
            kf.write_text(key)


def _quick_cores(tmp_path, **kw):
    sec = dgp.Section(_run(REPO / "build" / "tests" / "bench_dgp", quick=True, **kw))
    sec.plan()
    for c in sec.cores:
        c.out = tmp_path / c.role
        _with_sv(c)
    return sec


def test_quick_jobs_take_the_tools_from_the_cache_only(tmp_path):
    """QUICK: Yosys and nextpnr results from the cache only; the default designs' placements only with
    --dgp-place-all (they route for hours)"""
    quick = _quick_cores(tmp_path / "a", dgp_place_all=True)
    acc, plain, units, shifted, ram = quick.cores
    _cache(acc, "ecp5")
    _cache(acc, "nextpnr")
    _cache(plain, "ecp5")
    jobs = quick.jobs()
    names = [j.name for j in jobs]
    assert sum("verilator" in n for n in names) == 5                    # every core simulated
    assert f"{acc.tag} ecp5" in names and f"{plain.tag} ecp5" in names  # cached: costs nothing
    assert f"{units.tag} ecp5" not in names and not units.place and "QUICK" in units.pnr_note  # nothing cached
    assert not shifted.place and "QUICK" in shifted.pnr_note
    assert not ram.place and "QUICK" in ram.pnr_note
    assert not any("xc7" in n for n in names)
    assert acc.place and not acc.pnr_note
    assert not plain.place and "place and route" in plain.pnr_note
    # a changed SystemVerilog has nothing cached
    (acc.out / "Top.sv").write_text(SV + "// changed\n")
    acc.synth, acc.place, acc.pnr_note = True, True, ""
    jobs = quick.jobs()
    assert f"{acc.tag} ecp5" not in [j.name for j in jobs] and acc.pnr_note.startswith("QUICK")
    # without --dgp-place-all a cached placement of a default design is not reported
    quick = _quick_cores(tmp_path / "b")
    acc, _, units, _, _ = quick.cores
    _cache(acc, "ecp5")
    _cache(acc, "nextpnr")
    quick.jobs()
    assert not acc.place and "--dgp-place-all" in acc.pnr_note and not units.place


def test_full_jobs(planned, tmp_path):
    full, _ = planned
    for c in full.cores:
        c.out = tmp_path / c.role
        _with_sv(c)
    jobs = full.jobs()
    for c in full.cores:
        mine = {j.name: j for j in jobs if j.name.startswith(c.tag + " ")}
        assert set(mine) == {f"{c.tag} verilator", f"{c.tag} ecp5", f"{c.tag} xc7"}
        assert mine[f"{c.tag} verilator"].wave < mine[f"{c.tag} ecp5"].wave
        # only the row-unit core is placed unless --dgp-place-all
        assert c.place == (c.role in dgp.PLACED) and ("--dgp-place-all" in c.pnr_note) == (c.role not in dgp.PLACED)


def test_no_place_option(tmp_path):
    import argparse as ap

    parser = ap.ArgumentParser()
    dgp.Section.add_arguments(parser)
    assert parser.parse_args(["--dgp-no-place"]).dgp_no_place and not parser.parse_args([]).dgp_no_place
    sec = dgp.Section(_run(REPO / "build" / "tests" / "bench_dgp", quick=False, dgp_no_place=True))
    sec.plan()
    for c in sec.cores:
        c.out = tmp_path / c.role
        _with_sv(c)
    names = [j.name for j in sec.jobs()]
    assert all(f"{c.tag} ecp5" in names and not c.place and "--dgp-no-place" in c.pnr_note for c in sec.cores)


# ----------------------------------------------------------------------------------------- fabricated results

def _core_json(accelerated: bool) -> dict:
    return {"name": "ms", "accelerated": accelerated, "lanes": 8, "n": 40, "nw": 12, "mc": 80, "m": 160,
            "frac_bits": 27, "int_bits": 11, "data_format": {"width": 38}, "iterations": 300, "lat_add": 1,
            "lat_mul": 4, "target": "ecp5", "cycles_per_iteration": 825 if accelerated else 821,
            "solve_overhead_cycles": 242 if accelerated else 301,
            "cycles_at_imax": (242 + 300 * 825) if accelerated else (301 + 300 * 821),
            "issue_cycles": {"F": 240, "K": 400, "G": 400}, "div_cycles_per_word": 0 if accelerated else 59,
            "zero_start_saving_cycles": 410 if accelerated else 406,
            "multipliers": 14 if accelerated else 8, "module": "Top", "sv": "Top.sv"}


def _fake_core(role: str, measured=None, ecp5=None, pnr=None):
    cj = _core_json(role == "accelerated")
    design = SimpleNamespace(P=1, lanes=8, b=27, products=lambda: [(30, 39)], accelerated=role == "accelerated")
    c = dgp.DgpBenchCore("ms", Path("/nonexistent") / role, design, role, core=cj, measured=measured, ecp5=ecp5,
                         pnr=pnr)
    return c


def _loop(iters_acc, iters_plain, zero_acc=None) -> dgp.DgpLoop:
    it = {"accelerated": np.array(iters_acc), "plain": np.array(iters_plain)}
    met = {k: v < 300 for k, v in it.items()}
    zero = {} if zero_acc is None else {"accelerated": np.array(zero_acc)}
    return dgp.DgpLoop(np.zeros((len(iters_acc), 12)), np.zeros((len(iters_acc), 4)), it, met,
                       {"accelerated": (2e-3, 1e-8), "plain": (0.1, 1e-8)},
                       {k: v + 10 for k, v in it.items()}, {k: np.ones(len(v), bool) for k, v in it.items()},
                       {"steps": len(iters_acc), "hold": 5, "seed": 1, "states": len(iters_acc), "sat_steps": 2,
                        "lead": "accelerated", "imax": {"accelerated": 300, "plain": 300},
                        "warm": {"accelerated": True, "plain": False}}, zero=zero)


def _sw() -> dict:
    rng = np.random.default_rng(0)
    return {"solvers": [SwResult("OSQP warm", "defaults", 80.0 + rng.random((2, 10)), 2e-5, [25] * 20),
                        SwResult("DAQP hot start", "defaults", np.full((2, 10), 8.0), 1e-10, [1] * 20)],
            "repeats": 2, "cpu": 1, "load": [0.5, 0.7], "missing": ["Clarabel"]}


ECP5 = {"MULT18X18D": 96, "LUT4": 9000, "CCU2C": 1500, "FF": 7000, "DP16KD": 20, "LUTRAM": 0}
PNR = {"fmax_mhz": 100.0, "target_mhz": 200.0, "fmax_seeds": [98.0, 100.0, 103.0], "seeds": 3}


def test_rows_latency_and_ratios():
    rec = {"test": "cycle_contract", "cycles_per_iteration": 825, "overhead": 242}
    acc = _fake_core("accelerated", measured=rec, ecp5=ECP5, pnr=PNR)
    plain = _fake_core("plain", measured={"test": "cycle_contract", "cycles_per_iteration": 821, "overhead": 300})
    its_a, its_p = [1, 1, 2, 5, 9, 1, 1, 1, 3, 1], [1, 1, 3, 50, 300, 1, 1, 1, 7, 1]
    zero_a = [True, True, False, False, False, True, False, True, False, True]     # the zero starts of the loop
    sw = _sw()
    a, p = dgp_report.dgp_rows([acc, plain], _loop(its_a, its_p, zero_a), sw)
    assert a["measured_equals_corejson"] is True and p["measured_equals_corejson"] is False
    cyc = 242 + 825 * np.array(its_a) - 410 * np.array(zero_a)
    assert a["loop_zero_starts"] == 5 and p["loop_zero_starts"] == 0
    assert a["loop_cycles_median"] == np.median(cyc) and a["loop_cycles_max"] == cyc.max()
    assert a["loop_iter_max"] == 9 and p["loop_met"] == 9 and a["cold_iter_max"] == 19
    assert a["loop_us_median"] == pytest.approx(np.median(cyc) / 100.0)
    assert a["worst_us"] == pytest.approx((242 + 300 * 825) / 100.0)
    assert p["loop_us_median"] is None and p["fmax_mhz"] is None          # not placed: cycles only
    assert a["fit_85f"] == "fits" and p["fit_85f"] is None
    osqp, daqp = sw["solvers"]
    assert a["osqp_warm_median_over_core"] == pytest.approx(osqp.median_us / (np.median(cyc) / 100.0))
    assert a["daqp_hot_start_p99_over_core"] == pytest.approx(8.0 / (np.percentile(cyc, 99) / 100.0))
    assert a["daqp_hot_start_throughput_ratio"] == pytest.approx(8.0 / (cyc.mean() / 100.0))
    assert a["core_solves_per_s"] == pytest.approx(1e6 / (cyc.mean() / 100.0))
    assert p.get("osqp_warm_median_over_core") is None
    # the clock at which the core's cycles take the solver's time: with or without an Fmax
    assert a["daqp_hot_start_breakeven_mhz_median"] == pytest.approx(np.median(cyc) / 8.0)
    assert a["osqp_warm_breakeven_mhz_mean"] == pytest.approx(cyc.mean() / osqp.times_us.mean(axis=1).min())
    cyc_p = 301 + 821 * np.array(its_p)               # core.json's overhead, not the measured 300
    assert p["daqp_hot_start_breakeven_mhz_p99"] == pytest.approx(np.percentile(cyc_p, 99) / 8.0)
    # at the break-even clock the core's latency is the solver's time
    assert latency_us(a["loop_cycles_median"], a["daqp_hot_start_breakeven_mhz_median"]) == pytest.approx(8.0)
    # a solver with a timer of its own: every ratio and break-even takes it, the wall time stays in median_us
    daqp.own_us, daqp.timer = np.full((2, 10), 2.0), "info solve_time"
    a2, _ = dgp_report.dgp_rows([acc, plain], _loop(its_a, its_p, zero_a), sw)
    assert a2["daqp_hot_start_basis"] == "own" and a2["osqp_warm_basis"] == "wall"
    assert a2["daqp_hot_start_median_us"] == pytest.approx(8.0) and a2["daqp_hot_start_own_median_us"] == 2.0
    assert a2["daqp_hot_start_median_over_core"] == pytest.approx(2.0 / (np.median(cyc) / 100.0))
    assert a2["daqp_hot_start_p99_over_core"] == pytest.approx(2.0 / (np.percentile(cyc, 99) / 100.0))
    assert a2["daqp_hot_start_breakeven_mhz_median"] == pytest.approx(np.median(cyc) / 2.0)


def test_fit_names_what_is_over():
    assert dgp_report.fit_85f(dict(ECP5, MULT18X18D=200)).startswith("no: 200 MULT18X18D")
    assert "LUT4" in dgp_report.fit_85f(dict(ECP5, LUT4=82000))     # with the CCU2C: two LUT4 each
    assert dgp_report.fit_85f(dict(ECP5, LUT4=80000)) == "fits"
    assert dgp_report.fit_85f(None) is None


def test_report_and_console():
    acc = _fake_core("accelerated", measured={"test": "cycle_contract", "cycles_per_iteration": 825,
                                              "overhead": 242}, ecp5=ECP5, pnr=PNR)
    plain = _fake_core("plain")
    plain.pnr_note = "QUICK: no cached Yosys result for this SystemVerilog (a full run makes one)"
    loop, sw = _loop([1, 2, 3], [4, 5, 300]), _sw()
    rows = dgp_report.dgp_rows([acc, plain], loop, sw)
    info = {"errors": ["DGP x failed"], "runtime_s": 90, "plan_text": "Cores: both.", "date": "2026-11-23 10:00 UTC",
            "quick": True}
    text = "\n".join(dgp_report.dgp_section([acc, plain], rows, loop, sw, info))
    for want in ("## Dual gradient projection core", "Run of 2026-11-23 10:00 UTC (QUICK)", "### Cycles",
                 "### Iterations and latency", "### Software on this CPU", "OSQP warm", "DAQP hot start",
                 "Not installed, not run: Clarabel", "DGP x failed", "98.0, 100.0, 103.0", "QUICK: no cached Yosys",
                 f"{242 + 300 * 825} cycles", "2 step(s) saturated", "plain cold (y = 0)",
                 f"| {plain.tag} | closed loop, cold |", f"| {acc.tag} | closed loop, warm |"):
        assert want in text, want
    # one ratio row per solver for the placed core only
    # one comparison row per core and solver; ratios only for the placed core, break-even clocks for both
    rows_sw = [ln for ln in text.splitlines() if " | OSQP warm | " in ln or " | DAQP hot start | " in ln]
    assert len(rows_sw) == 2 * 2
    assert all(("x |" in ln) == ln.startswith(f"| {acc.tag} |") for ln in rows_sw)
    assert all(ln.split(" | ")[-1].count(" / ") == 2 and "-" not in ln.split(" | ")[-1] for ln in rows_sw)
    lines = dgp_report.summary_lines(rows, sw)
    assert len(lines) == 1 + 2 + 1 + len(sw["solvers"])
    assert "measured equal" in lines[1] and "Fmax 100.0 MHz" in lines[1] and "not measured" in lines[2]
    assert "accelerated " in lines[-1] and "x, break-even" in lines[-1] and "plain break-even" in lines[-1]


def test_report_without_placed_core():
    c = _fake_core("accelerated")
    rows = dgp_report.dgp_rows([c], _loop([1, 2], [3, 4]), _sw())
    text = "\n".join(dgp_report.dgp_section([c], rows, None, _sw(), {"date": "d"}))
    assert "No core was synthesised" in text and "break-even MHz" in text
    assert "### Iterations and latency" not in text


def test_measure_cycles_compares_with_core_json(monkeypatch):
    c = _fake_core("accelerated")
    logged = []
    monkeypatch.setattr(dgp, "run_cycle_test", lambda core, test: [
        {"test": "other"}, {"test": test, "cycles_per_iteration": 824, "overhead": 242}])
    c.seconds["verilator"] = 1.0
    dgp.measure_cycles(c, "cycle_contract", logged.append)
    assert c.measured["cycles_per_iteration"] == 824 and "DIFFERENT" in logged[0]
    monkeypatch.setattr(dgp, "run_cycle_test", lambda core, test: [{"test": "other"}])
    with pytest.raises(RuntimeError, match="no record"):
        dgp.measure_cycles(c, "cycle_contract", logged.append)


def test_synthesis_places_only_what_fits(monkeypatch):
    placed = []
    monkeypatch.setattr(dgp, "synth_ecp5_and_pnr", lambda c, log: placed.append(c.role))
    for cells, want in (({"MULT18X18D": 96, "LUT4": 9000, "TRELLIS_FF": 7000}, ["accelerated"]),
                        ({"MULT18X18D": 96, "LUT4": 90000, "TRELLIS_FF": 7000}, [])):
        placed.clear()
        c = _fake_core("accelerated")
        monkeypatch.setattr(dgp, "run_yosys", lambda c, fam, log, cells=cells: (cells, {}))
        dgp.synth_ecp5(c, lambda m: None)
        assert placed == want and c.ecp5["LUT4"] == cells["LUT4"]
        assert (c.pnr_note.startswith("does not fit") and "LUT4" in c.pnr_note) == (not want)


# ----------------------------------------------------------------------------------------- loop and solvers

@pytest.fixture(scope="module")
def small():
    from mpc_cores.dgp.design import design_dgp

    p = random_problem("dgb", 2, 1, 4, 0, 5, states={"min": -0.5, "max": 0.5},
                       hard_states={"indices": [0], "min": -1.0, "max": 1.0})
    return {r: design_dgp(p, lanes=2, iterations=200, accelerated=r == "accelerated") for r in dgp.ROLES}


def test_closed_loop_replays_the_models(small):
    from mpc_cores.dgp.model import DgpFixed
    from mpc_cores.dgp.problem import solve_osqp
    from mpc_cores.fixed import quantize

    loop = dgp.closed_loop(small, steps=12, hold=4, seed=2, states=6)
    d = small["accelerated"]
    assert loop.W.shape == (12, d.nw) and loop.u_opt.shape == (12, d.nu)
    one = float(1 << d.b)
    assert np.all(loop.W >= d.xlo / one) and np.all(loop.W <= d.xhi / one)      # after the input saturation
    for role, dr in small.items():
        m = DgpFixed(dr)
        rs = [m.solve(quantize(w, dr.b)) for w in loop.W]
        assert loop.iters[role].tolist() == [int(r.iterations[0]) for r in rs]
        assert loop.zero[role].tolist() == [bool(r.zero_start[0]) for r in rs]
        assert loop.cold_zero[role].all()                                         # a cold start is a zero start
        assert len(loop.cold_iters[role]) == 6 and np.all(loop.cold_iters[role] <= dr.iterations)
        assert np.all(loop.met[role] | (loop.iters[role] == dr.iterations))
    k = 5
    assert np.allclose(loop.u_opt[k], solve_osqp(d.qp, loop.W[k], eps=1e-9)[0][: d.nu], atol=1e-7)
    assert loop.core_err["accelerated"][0] >= loop.core_err["accelerated"][1] >= 0
    assert loop.meta["warm"] == {r: dr.warm_start for r, dr in small.items()} and loop.meta["lead"] == "accelerated"


def test_solvers_reach_the_optimum_as_the_bounds_move(small):
    from mpc_cores.dgp.problem import solve_osqp

    d = small["accelerated"]
    sq = dgp.StateQp(d.qp)
    makers, missing = dgp.solver_makers(sq)
    assert len(makers) + len(missing) == len(dgp.SOLVERS)
    rng = np.random.default_rng(3)
    ws = [rng.uniform(d.problem.xmin, d.problem.xmax) for _ in range(4)]
    refs = [solve_osqp(d.qp, w, eps=1e-10)[0] for w in ws]
    for mk in makers:
        s = mk()
        for w, zs in zip(ws, refs):
            z, own = s.solve(w)
            own = own() if callable(own) else own
            tol = 2e-3 if s.name.startswith("OSQP") else 1e-5
            assert np.abs(z - zs).max() < tol, s.name
            assert own is None or own >= 0
        assert len(s.iters) == len(ws) and s.settings
    # the state rows in the solvers' units: the core's rows with its scaling undone
    lo, hi = sq.bounds(ws[0])
    lo_s, hi_s = d.qp.bounds(ws[0])
    assert np.allclose(lo * d.qp.sigma, lo_s) and np.allclose(hi * d.qp.sigma, hi_s)
    assert np.allclose(sq.G * d.qp.sigma, d.qp.G)


def test_section_restored_without_a_run():
    """The report from results at hand (Section.restore): no run, no options."""
    acc = _fake_core("accelerated", ecp5=ECP5, pnr=PNR)
    loop, sw = _loop([1, 2], [3, 4]), _sw()
    sec = dgp.Section().restore([acc], dgp_report.dgp_rows([acc], loop, sw), sw)
    sec.loop = loop
    text = "\n".join(sec.appendix_md())
    assert text.startswith("## Dual gradient projection core") and "(full)" in text
    assert sec.console_summary()[1].startswith(f"  {acc.tag}:")
    assert dgp.Section().appendix_md() == [] and dgp.Section().console_summary() == []
