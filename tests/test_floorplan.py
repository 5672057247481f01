"""mpc_bench.floorplan: the row units of an FGM core pinned to rows of the LFE5U-85F (on netlists of the FGM
generator's naming, built here: the bench's place and route runs it on the real ones and refuses any it cannot
place)."""
import re

import pytest

from mpc_bench import floorplan as fp

CORE, WRAP = "FgmCore_t", "FgmCore_t" + fp.MULT_WRAPPER


def netlist(P: int, m: int, bnd_lanes: int = 2, extra: dict | None = None) -> dict:
    cells = {}
    for u in range(P):
        tree = "dp" if u == 0 else ("tree" if u == 1 else f"tree_{u - 1}")
        for j in range(m):
            cells[f"{tree}.level0_parts_m" + (f"_{j}" if j else "")] = {"type": WRAP}
            cells[f"matRam_{u}.bram_l{j}_s0"] = {"type": "DP16KD"}
        for k in ("ra", "rb"):
            cells[f"{k}_parts_m" + (f"_{u}" if u else "")] = {"type": WRAP}
        for j in range(bnd_lanes):
            cells[f"bndRam_{u}.bram_l{j}_s0"] = {"type": "DP16KD"}
    cells.update(extra or {})
    return {"modules": {CORE: {"cells": cells}, WRAP: {"cells": {"dsp": {"type": "MULT18X18D"}}}}}


def _xy(bel: str) -> tuple[int, int]:
    x, y = re.match(r"X(\d+)/Y(\d+)/", bel).groups()
    return int(x), int(y)


@pytest.mark.parametrize("P", [1, 2, 3])
def test_units_in_rows_of_their_own(P):
    m = 40
    d = netlist(P, m)
    bels = fp.floorplan(d, CORE)
    assert len(bels) == P * 2 * (m + 2) and len(set(bels.values())) == len(bels)
    rows = fp.UNIT_ROWS[P]
    for u in range(P):
        tree = "dp" if u == 0 else ("tree" if u == 1 else f"tree_{u - 1}")
        for j in range(m):
            dx, dy = _xy(bels[f"{tree}.level0_parts_m" + (f"_{j}" if j else "")])
            mx, my = _xy(bels[f"matRam_{u}.bram_l{j}_s0"])
            assert (dy, my) == rows[u]
            assert abs(dx - mx) <= 6, f"lane {j} of unit {u}: multiplier at x={dx}, its memory at x={mx}"
    # every multiplier instance has a wrapper copy of its own, pinned
    mods, cells = d["modules"], d["modules"][CORE]["cells"]
    for name, c in cells.items():
        if c["type"] != "DP16KD":
            assert c["type"] != WRAP and mods[c["type"]]["cells"]["dsp"]["attributes"]["BEL"] == bels[name]


def test_lanes_in_order_along_the_row():
    bels = fp.floorplan(netlist(1, 40), CORE)
    xs = [_xy(bels["dp.level0_parts_m" + (f"_{j}" if j else "")])[0] for j in range(40)]
    assert xs == sorted(xs) and xs[0] < _xy(bels["ra_parts_m"])[0] < xs[-1]


@pytest.mark.parametrize("bad, msg", [
    (lambda: netlist(1, 40, extra={"other_parts_m": {"type": WRAP}}), "not a row unit's"),
    (lambda: netlist(1, 40, extra={"fifo.bram_l0_s0": {"type": "DP16KD"}}), "not a row unit's"),
    (lambda: netlist(1, 51), "needs 53 sites"),
    (lambda: netlist(4, 8), "1 to 3"),
])
def test_refuses_what_it_cannot_place(bad, msg):
    with pytest.raises(fp.FloorplanError, match=msg):
        fp.floorplan(bad(), CORE)
