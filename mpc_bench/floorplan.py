"""Row floorplan of an FGM core on the LFE5U-85F: each row unit's multipliers pinned to one DSP row of the device
and its block RAMs to a block RAM row beside it, lane j of the multipliers above lane j of the memories.

Left to itself, nextpnr's analytic placer spreads the three row units of an FGM core at P = 3 over every DSP row
(all three units in each row), so that a unit's adder tree, operand copies and coefficient memories span the whole
die and most of its paths carry 3 to 6 ns of routing. With each unit in a band of its own (a DSP row and the block
RAM row next to it) the fabric logic follows its hard blocks and the paths stay within the band. The pins are the
`BEL` attributes nextpnr honours on cells of the netlist (docs/constraints.md of nextpnr): the Yosys netlist is
rewritten, the core's RTL is unchanged. A user placing the core with nextpnr can apply the same function.

Device geometry (LFE5U-85F, from nextpnr's placements): 13 DSP tiles per row at x = 4, 13, ..., 114 (the gap at
the centre clock spine), each with MULT18_0, _1, _4 and _5 (x, x + 1, x + 4, x + 5): 52 MULT18X18D per row, rows
y = 10, 34, 58 (156). Block RAM tiles at the same x with EBR0..3 at x, x + 2, x + 4, x + 6: 52 DP16KD per row,
rows y = 22, 46, 70, 82 (208).

The cells are found by the FGM generator's instance names: the row units' dot-product trees (`dp` for unit 0,
`tree`, `tree_1`, ... after it) with their multipliers `level0_parts_m_<i>`, the y update's `ra_parts_m_<i>` and
`rb_parts_m_<i>` (per unit in order), and the memories `matRam_<u>` and `bndRam_<u>` (`bram_l<lane>_s<slice>`).
A netlist where any multiplier or block RAM of the core is not found that way is refused (FloorplanError).
"""
from __future__ import annotations

import copy
import json
import re
from pathlib import Path

TILES = (4, 13, 22, 31, 40, 49, 58, 69, 78, 87, 96, 105, 114)
DSP_ROWS = (10, 34, 58)
EBR_ROWS = (22, 46, 70, 82)
# (DSP row, block RAM row) of each unit, by the number of units: the rows nearest the die's centre first
UNIT_ROWS = {1: [(34, 46)], 2: [(10, 22), (34, 46)], 3: [(10, 22), (34, 46), (58, 70)]}
SITES_PER_ROW = 4 * len(TILES)
MULT_WRAPPER = "_mpc_ecp5_mult18x18"


class FloorplanError(ValueError):
    pass


def dsp_sites(y: int) -> list[str]:
    return [f"X{b + o}/Y{y}/MULT18_{o}" for b in TILES for o in (0, 1, 4, 5)]


def ebr_sites(y: int) -> list[str]:
    return [f"X{b + 2 * s}/Y{y}/EBR{s}" for b in TILES for s in range(4)]


def _suffix(s: str | None) -> int:
    return int(s) if s else 0


def row_slots(lanes: int, centre: int) -> list[int]:
    """Site indices (of a row's 52, by x) of `lanes` lane cells, then of `centre` cells placed between the lanes'
    two halves; the whole centred in the row."""
    used = lanes + centre
    if used > SITES_PER_ROW:
        raise FloorplanError(f"a unit needs {used} sites in a row, the row has {SITES_PER_ROW}")
    off, half = (SITES_PER_ROW - used) // 2, lanes // 2
    return ([off + j + (centre if j >= half else 0) for j in range(lanes)] + [off + half + c for c in range(centre)])


def unit_cells(cells: dict) -> tuple[dict, dict]:
    """The core module's multiplier instances and block RAMs per unit: ({u: (lane list, centre list)}, same for the
    memories), each list in lane order."""
    tree, upd, mat, bnd = {}, {}, {}, {}
    for name, c in cells.items():
        if c["type"].endswith(MULT_WRAPPER):
            m = re.fullmatch(r"(dp|tree(?:_(\d+))?)\.level0_parts_m(?:_(\d+))?", name)
            if m:
                u = 0 if m.group(1) == "dp" else 1 + _suffix(m.group(2))
                tree.setdefault(u, []).append((_suffix(m.group(3)), name))
                continue
            m = re.fullmatch(r"(ra|rb)_parts_m(?:_(\d+))?", name)
            if not m:
                raise FloorplanError(f"multiplier {name}: not a row unit's (FGM naming)")
            upd.setdefault(m.group(1), []).append((_suffix(m.group(2)), name))
        elif c["type"] == "DP16KD":
            m = re.fullmatch(r"(matRam|bndRam)_(\d+)\.bram_l(\d+)_s(\d+)", name)
            if not m:
                raise FloorplanError(f"block RAM {name}: not a row unit's (FGM naming)")
            (mat if m.group(1) == "matRam" else bnd).setdefault(int(m.group(2)), []).append(
                ((int(m.group(3)), int(m.group(4))), name))
    units = sorted(tree)
    if not units or units != list(range(len(units))) or sorted(mat) != units or sorted(bnd) != units:
        raise FloorplanError(f"row units of trees {sorted(tree)}, coefficient memories {sorted(mat)} and bound "
                             f"memories {sorted(bnd)} do not match")
    P = len(units)
    per = {k: len(v) // P for k, v in upd.items()}
    if any(len(v) % P for v in upd.values()):
        raise FloorplanError(f"y update multipliers {[len(v) for v in upd.values()]} do not divide among {P} units")
    ordered = {k: [n for _, n in sorted(v)] for k, v in upd.items()}
    dsp = {u: ([n for _, n in sorted(tree[u])],
               [n for k in ("ra", "rb") for n in ordered.get(k, [])[u * per.get(k, 0):(u + 1) * per.get(k, 0)]])
           for u in units}
    mem = {u: ([n for _, n in sorted(mat[u])], [n for _, n in sorted(bnd[u])]) for u in units}
    return dsp, mem


def floorplan(netlist: dict, module: str) -> dict[str, str]:
    """Pins the row units of `module` (an FGM core kept as a module of the Yosys netlist, instanced once) in the
    netlist dict, in place. Returns cell name -> BEL."""
    mods = netlist["modules"]
    if module not in mods:
        raise FloorplanError(f"module {module} not in the netlist")
    cells = mods[module]["cells"]
    dsp, mem = unit_cells(cells)
    P = len(dsp)
    if P not in UNIT_ROWS:
        raise FloorplanError(f"{P} row units: the LFE5U-85F's rows place 1 to {max(UNIT_ROWS)}")
    bels = {}
    for u, (dy, ey) in enumerate(UNIT_ROWS[P]):
        for (lanes, centre), sites in ((dsp[u], dsp_sites(dy)), (mem[u], ebr_sites(ey))):
            for name, i in zip(lanes + centre, row_slots(len(lanes), len(centre))):
                bels[name] = sites[i]
    for name, bel in bels.items():
        c = cells[name]
        if c["type"] == "DP16KD":
            c.setdefault("attributes", {})["BEL"] = bel
            continue
        # the multiplier sits in a wrapper module shared by every instance: each instance gets a copy of its own
        wrap = copy.deepcopy(mods[c["type"]])
        inner = [cc for cc in wrap["cells"].values() if cc["type"] == "MULT18X18D"]
        if len(inner) != 1:
            raise FloorplanError(f"{c['type']}: {len(inner)} MULT18X18D cells, expected 1")
        inner[0].setdefault("attributes", {})["BEL"] = bel
        copy_name = f"{c['type']}__{re.sub(r'[^0-9A-Za-z_]', '_', name)}"
        mods[copy_name] = wrap
        c["type"] = copy_name
    return bels


def floorplan_file(src: Path, dst: Path, module: str) -> int:
    """floorplan() from the netlist file `src` into `dst`; the number of pinned cells."""
    d = json.loads(Path(src).read_text())
    n = len(floorplan(d, module))
    Path(dst).write_text(json.dumps(d))
    return n
