"""Short form of `make table2` (verif/tables.py): a 2 x 2 corner of Table II(a) of 002 on the masses, golden model
only, through the same sweep and CSV functions."""
from __future__ import annotations

import csv
from dataclasses import replace

from verif import tables

# The first two reference segments of the full run (same seed and hold): references close to reachable, so the
# loop is sensitive to the solver's accuracy.
STEPS, HOLD, SEED = 60, 10, 0


def _read(path):
    with open(path, newline="") as f:
        return list(csv.reader(f))


def test_masses_corner(tmp_path):
    sw = replace(tables.masses_sweep(steps=STEPS, hold=HOLD, seed=SEED), bs=(10, 16), imaxes=(5, 15))
    res = tables.run_sweeps([sw], workers=2, progress=False)["masses"]
    out = tmp_path / "table2_fgm.csv"
    tables.write_csv(out, res)
    rows = _read(out)
    assert rows[0] == ["imax", "b", "cost_pct"]
    assert [(int(r[0]), int(r[1])) for r in rows[1:]] == [(5, 10), (5, 16), (15, 10), (15, 16)]
    pct = {(int(r[0]), int(r[1])): float(r[2]) for r in rows[1:]}
    # Table II(a) of 002: b = 16, Imax = 15 is near the optimum; b = 10 is clearly worse
    assert abs(pct[(15, 16)]) <= tables.NEAR_PCT
    assert pct[(15, 10)] > pct[(15, 16)]
    assert "| 15 |" in tables.table_markdown(res, "t", "p", tables.PAPER_002_B, tables.PAPER_002, [])


def test_refused_cell_has_empty_cost(tmp_path):
    # afm_like at b = 10 fails Assumption 1(i) of 002 (smallest eigenvalue of the quantised H_n <= 0)
    sw = replace(tables.afm_sweep(steps=4, hold=2), bs=(10,), imaxes=(15,))
    res = tables.run_sweeps([sw], workers=1, progress=False)["afm_like"]
    assert "Assumption 1" in res.cells[(15, 10)]["refused"]
    out = tmp_path / "table1_afm.csv"
    tables.write_csv(out, res)
    assert _read(out) == [["imax", "b", "cost_pct"], ["15", "10", ""]]
    assert "refused" in tables.table_markdown(res, "t", "p", tables.PAPER_000_B, tables.PAPER_000, [])
