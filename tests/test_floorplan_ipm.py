"""mpc_bench.floorplan_ipm: the block RAMs of an interior-point core pinned by part, Stage 1's in the block RAM rows at
y = 70 and 82, MINRES's in the row at y = 46 (on netlists of the generator's naming, built here: the bench's place
and route runs it on the real ones and refuses any it cannot place)."""
import json
import re

import pytest

from mpc_bench import floorplan_ipm as fpi
from mpc_bench.floorplan import FloorplanError

CORE = "IpmCore_t"
TABLES = ["st1.constA_ram.bram_l0_s0", "st1.constB_ram.bram_l0_s0", "st1.tabA_ram.bram_l0_s0",
          "st1.tabB_ram.bram_l0_s0", "st1.tabD_ram.bram_l0_s0"]


def netlist(banks: int = 20, slices: int = 3, vecs: int = 15, extra: dict | None = None) -> dict:
    cells = {n: {"type": "DP16KD"} for n in TABLES}
    for k in range(banks):
        for s in range(slices):
            cells[f"st1.ram{'' if k == 0 else f'_{k}'}.bram_s{s}"] = {"type": "DP16KD"}
    for k in range(vecs):
        for s in range(2):
            cells[f"mr.r{'' if k == 0 else f'_{k}'}.bram_s{s}"] = {"type": "DP16KD"}
    cells["st1.alu.mul.prod_dsp"] = {"type": "IpmCore_t_mpc_ecp5_mult18x18"}
    cells["mr.g_TRELLIS_FF_Q"] = {"type": "TRELLIS_FF"}
    cells.update(extra or {})
    return {"modules": {CORE: {"cells": cells}}}


def _xy(bel: str) -> tuple[int, int]:
    x, y = re.match(r"X(\d+)/Y(\d+)/EBR\d$", bel).groups()
    return int(x), int(y)


def test_parts_in_rows_of_their_own():
    d = netlist()
    bels = fpi.floorplan(d, CORE)
    cells = d["modules"][CORE]["cells"]
    brams = [n for n, c in cells.items() if c["type"] == "DP16KD"]
    assert sorted(bels) == sorted(brams) and len(set(bels.values())) == len(bels)
    for n, bel in bels.items():
        assert cells[n]["attributes"]["BEL"] == bel
        assert _xy(bel)[1] in (fpi.STAGE1_ROWS if n.startswith("st1.") else fpi.MINRES_ROWS), (n, bel)
    # the multiplier and the logic are the placer's
    assert "attributes" not in cells["st1.alu.mul.prod_dsp"] and "attributes" not in cells["mr.g_TRELLIS_FF_Q"]


def test_stage1_tables_nearest_the_centre_and_banks_in_order():
    bels = fpi.floorplan(netlist(), CORE)
    dist = {n: abs(_xy(b)[0] - fpi.CENTRE_X) + 1000 * fpi.STAGE1_ROWS.index(_xy(b)[1])
            for n, b in bels.items() if n.startswith("st1.")}
    tables = max(dist[n] for n in TABLES)
    assert all(dist[n] > tables for n in dist if n not in TABLES)
    # the slot memory's banks fill outwards in bank order: bank 2 no nearer than bank 1's slices
    b1 = [dist[f"st1.ram_1.bram_s{s}"] for s in range(3)]
    b2 = [dist[f"st1.ram_2.bram_s{s}"] for s in range(3)]
    assert max(b1) <= min(b2)
    # the second Stage 1 row takes over when the first is full (52 sites)
    rows = {_xy(b)[1] for n, b in bels.items() if n.startswith("st1.")}
    assert rows == set(fpi.STAGE1_ROWS)


def test_file_round_trip(tmp_path):
    src, dst = tmp_path / "n.json", tmp_path / "f.json"
    src.write_text(json.dumps(netlist(banks=4, vecs=3)))
    assert fpi.floorplan_file(src, dst, CORE) == 5 + 12 + 6
    out = json.loads(dst.read_text())["modules"][CORE]["cells"]
    assert out["mr.r_2.bram_s1"]["attributes"]["BEL"].endswith(tuple(f"EBR{s}" for s in range(4)))


@pytest.mark.parametrize("bad, msg", [
    (dict(extra={"shell.fifo.bram_s0": {"type": "DP16KD"}}), r"block RAM shell\.fifo\.bram_s0: neither"),
    (dict(vecs=27), r"MINRES: 54 block RAMs, its rows y = \(46,\) hold 52"),
    (dict(banks=34), r"Stage 1: 107 block RAMs"),
])
def test_refuses_what_it_cannot_place(bad, msg):
    with pytest.raises(FloorplanError, match=msg):
        fpi.floorplan(netlist(**bad), CORE)


def test_refuses_a_missing_module():
    with pytest.raises(FloorplanError, match="module Other not in the netlist"):
        fpi.floorplan(netlist(), "Other")
