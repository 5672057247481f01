"""Block RAM floorplan of an interior-point core on the LFE5U-85F: the Stage 1 engine's block RAMs (its instruction
tables and constant ROMs, then the slot memory's banks) in the block RAM rows at y = 70 and 82, MINRES's vector
memories in the row at y = 46, each group filling its rows from the die's centre outwards.

Left to itself, nextpnr spreads the core's block RAMs over all four rows, and a memory can land far from the logic
it feeds: in the bench's run at 6f826f9 (docs/bench/2026-11-29-ipm.md), seed 2 placed a Stage 1 table ROM some 50
rows from the operand address adder it feeds, 4.2 ns of routing on a 6.9 ns path. With each group in rows of its
own the placer gathers its fabric logic there. The pins are `BEL` attributes on the netlist's DP16KD cells
(mpc_bench.floorplan, which pins the FGM's row units the same way); the multipliers and the logic are left to the
placer. The core's RTL is unchanged, and a user placing the core with nextpnr can apply the same function.

The cells are found by the interior-point generator's instance names: `st1.` (Stage 1) and `mr.` (MINRES). A
netlist with a block RAM of neither, or more than its rows hold, is refused (FloorplanError).
"""
from __future__ import annotations

import re
from pathlib import Path

from mpc_bench import floorplan as fp
from mpc_bench.floorplan import FloorplanError

# block RAM rows (mpc_bench.floorplan.EBR_ROWS) of each group; the x the rows are filled from
STAGE1_ROWS = (70, 82)
MINRES_ROWS = (46,)
CENTRE_X = 60


def _natural(name: str) -> list:
    return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", name)]


def centred_sites(rows: tuple) -> list[str]:
    """The block RAM sites of `rows`, row by row, each row's from the die's centre outwards."""
    return [s for y in rows for s in sorted(fp.ebr_sites(y), key=lambda b: abs(int(b.split("/")[0][1:]) - CENTRE_X))]


def groups(cells: dict) -> tuple[list[str], list[str]]:
    """The core's block RAM cells: (Stage 1's, tables and constants first, then the slot memory; MINRES's), each in
    the natural order of their names."""
    brams = sorted((n for n, c in cells.items() if c["type"] == "DP16KD"), key=_natural)
    st1 = [n for n in brams if n.startswith("st1.")]
    mr = [n for n in brams if n.startswith("mr.")]
    other = [n for n in brams if n not in st1 and n not in mr]
    if other:
        raise FloorplanError(f"block RAM {other[0]}: neither Stage 1's (st1.) nor MINRES's (mr.)")
    slots = [n for n in st1 if n.startswith("st1.ram")]
    return [n for n in st1 if n not in slots] + slots, mr


def floorplan(netlist: dict, module: str) -> dict[str, str]:
    """Pins the block RAMs of `module` (an interior-point core kept as a module of the Yosys netlist, instanced
    once) in the netlist dict, in place. Returns cell name -> BEL."""
    mods = netlist["modules"]
    if module not in mods:
        raise FloorplanError(f"module {module} not in the netlist")
    cells = mods[module]["cells"]
    st1, mr = groups(cells)
    bels = {}
    for part, names, rows in (("Stage 1", st1, STAGE1_ROWS), ("MINRES", mr, MINRES_ROWS)):
        sites = centred_sites(rows)
        if len(names) > len(sites):
            raise FloorplanError(f"{part}: {len(names)} block RAMs, its rows y = {rows} hold {len(sites)}")
        bels.update(zip(names, sites))
    for name, bel in bels.items():
        cells[name].setdefault("attributes", {})["BEL"] = bel
    return bels


def floorplan_file(src: Path, dst: Path, module: str) -> int:
    """floorplan() from the netlist file `src` into `dst`; the number of pinned cells."""
    return fp.floorplan_file(src, dst, module, plan=floorplan)
