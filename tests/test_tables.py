"""Short form of `make table2` (mpc_bench/tables.py): 2 x 2 corners of Table II(a) (FGM, masses) and Table II(b) (ADMM,
masses_rate_soft) of 002, golden model only, through the same sweep, CSV and markdown functions."""
from __future__ import annotations

import csv
from dataclasses import replace

from mpc_bench import tables_admm, tables_fgm, tables_paper, tables_sweep

# The first two reference segments of the full run (same seed and hold): references close to reachable, so the
# loop is sensitive to the solver's accuracy.
STEPS, HOLD, SEED = 60, 10, 0


def _read(path):
    with open(path, newline="") as f:
        return list(csv.reader(f))


def test_masses_corner(tmp_path):
    sw = replace(tables_sweep.masses_sweep(steps=STEPS, hold=HOLD, seed=SEED), bs=(10, 16), imaxes=(5, 15))
    res = tables_sweep.run_sweeps([sw], workers=2, progress=False)["masses"]
    out = tmp_path / "table2_fgm.csv"
    tables_sweep.write_csv(out, res)
    rows = _read(out)
    assert rows[0] == ["imax", "b", "cost_pct"]
    assert [(int(r[0]), int(r[1])) for r in rows[1:]] == [(5, 10), (5, 16), (15, 10), (15, 16)]
    pct = {(int(r[0]), int(r[1])): float(r[2]) for r in rows[1:]}
    # Table II(a) of 002: b = 16, Imax = 15 is near the optimum; b = 10 is clearly worse
    assert abs(pct[(15, 16)]) <= tables_fgm.NEAR_PCT
    assert pct[(15, 10)] > pct[(15, 16)]
    assert "| 15 |" in tables_fgm.table_markdown(res, "t", "p", tables_paper.PAPER_002_B, tables_paper.PAPER_002, [])


def test_refused_cell_has_empty_cost(tmp_path):
    # afm_like at b = 10 fails Assumption 1(i) of 002 (smallest eigenvalue of the quantised H_n <= 0)
    sw = replace(tables_sweep.afm_sweep(steps=4, hold=2), bs=(10,), imaxes=(15,))
    res = tables_sweep.run_sweeps([sw], workers=1, progress=False)["afm_like"]
    assert "Assumption 1" in res.cells[(15, 10)]["refused"]
    out = tmp_path / "table1_afm.csv"
    tables_sweep.write_csv(out, res)
    assert _read(out) == [["imax", "b", "cost_pct"], ["15", "10", ""]]
    assert "refused" in tables_fgm.table_markdown(res, "t", "p", tables_paper.PAPER_000_B, tables_paper.PAPER_000, [])


# ADMM (Table II(b) of 002) on masses_rate_soft: two reference segments of the full run (same seed and hold).
ADMM_STEPS = 30


def test_admm_corner(tmp_path):
    """A 2 x 2 corner of Table II(b) through the same sweep, CSV, markdown and figure functions: b = 18 at Imax = 40
    is near the optimum, b = 10 clearly worse; a refused design (b = 8, Assumption 2 of 002) keeps its row empty."""
    # a shorter sizing run than the design flow's default (the test's time); the words must still never saturate
    sw = replace(tables_sweep.admm_sweep(steps=ADMM_STEPS), bs=(10, 18), imaxes=(10, 40), overrides=(("sizing_solves", 8),))
    refused = replace(sw, key="admm_b8", bs=(8,), imaxes=(40,))
    res = tables_sweep.run_sweeps([sw, refused], workers=2, progress=False)
    admm, r8 = res["admm"], res["admm_b8"]
    assert admm.opt is r8.opt                          # one optimal loop for sweeps that share the references
    md = tables_admm.write_admm_outputs(tmp_path, {tables_sweep.ADMM_ROUNDING: admm}, notes=["a note"])
    rows = _read(tmp_path / "table2_admm.csv")
    assert rows[0] == ["imax", "b", "cost_pct"]
    assert [(int(r[0]), int(r[1])) for r in rows[1:]] == [(10, 10), (10, 18), (40, 10), (40, 18)]
    pct = {(int(r[0]), int(r[1])): float(r[2]) for r in rows[1:]}
    # Table II(b) of 002: b = 18 at Imax = 40 within a fraction of a percent, b = 10 tens of percent
    assert abs(pct[(40, 18)]) < 0.6
    assert pct[(40, 10)] > 10 * abs(pct[(40, 18)]) and pct[(10, 10)] > 10 * abs(pct[(40, 18)])
    # the float64 ADMM (no round-off) converges with Imax and is near the optimum at 40
    assert abs(tables_admm.float_pct(admm, 40)) < 0.5 and tables_admm.float_pct(admm, 10) > tables_admm.float_pct(admm, 40)
    assert not tables_admm.overflow_cells(admm)
    assert "| 40 | " in md and "float64 ADMM at Imax = 40 vs optimal" in md and "a note" in md
    assert "Table II(b) of 002 (paper values" in md and (tmp_path / "fig_table2_admm.png").stat().st_size > 0
    assert "Assumption 2" in r8.cells[(40, 8)]["refused"]
    tables_sweep.write_csv(tmp_path / "b8.csv", r8)
    assert _read(tmp_path / "b8.csv") == [["imax", "b", "cost_pct"], ["40", "8", ""]]
    # an RTL row renders in the same section format as the FGM table
    rtl = [{"b": 18, "imax": 40, "steps": ADMM_STEPS, "golden_pct": pct[(40, 18)], "rtl_pct": pct[(40, 18)],
            "same_words": True, "same_cost": True}]
    assert "## RTL in the loop" in tables_admm.admm_table_markdown({"nearest": admm}, rtl=rtl)
