"""Parsers of the hardware tools' output for the benchmark: Yosys `stat` cell counts and memory mapping, nextpnr-ecp5
logs and --report JSON (Fmax, utilisation, critical path), LPF clock constraints, and the fit check against the
LFE5U-85F. Pure functions on text and dicts; running the tools is mpc_bench.tools."""
from __future__ import annotations

import re

# nextpnr-ecp5 target: the largest ECP5 (LFE5U-85F); capacities as nextpnr reports them.
ECP5_85F = {"MULT18X18D": 156, "DP16KD": 208, "LUT4": 83640, "FF": 83640}

_STAT_NEW = re.compile(r"^\s*(\d+)\s+(\S+)\s*$")          # yosys >= 0.50:   "     1321   CCU2C"
_STAT_OLD = re.compile(r"^\s*(\S+)\s+(\d+)\s*$")          # older yosys:     "     CCU2C     1321"


def parse_yosys_stat(text: str) -> dict[str, int]:
    """Cell counts of the last cell list in the output of yosys `stat` (the whole design when it is
    hierarchical: the totals come last). Handles the count-first layout of recent yosys and the older
    name-first one ("Number of cells: N")."""
    blocks: list[dict[str, int]] = []
    cur: dict[str, int] | None = None
    for line in text.splitlines():
        s = line.strip()
        if re.fullmatch(r"\d+\s+cells", s) or re.fullmatch(r"Number of cells:\s+\d+", s):
            cur = {}
            blocks.append(cur)
            continue
        if cur is None:
            continue
        if not s or s.startswith("=") or re.fullmatch(r"\d+\s+submodules", s) or "Number of" in s \
                or s.startswith("+") or s.startswith("|"):
            cur = None
            continue
        m = _STAT_NEW.match(line)
        if m and not m.group(2).isdigit():
            cur[m.group(2)] = cur.get(m.group(2), 0) + int(m.group(1))
            continue
        m = _STAT_OLD.match(line)
        if m:
            cur[m.group(1)] = cur.get(m.group(1), 0) + int(m.group(2))
            continue
        cur = None
    if not blocks:
        raise ValueError("no cell list in the yosys stat output")
    cells = blocks[-1]
    cells.pop("$scopeinfo", None)
    return cells


def yosys_module_cells(text: str, module: str) -> dict[str, int]:
    """Cell counts of one module's own block ("=== module ===", submodules excluded) in yosys `stat` output."""
    m = re.search(rf"^=== {re.escape(module)} ===$(.*?)(?=^=== |\Z)", text, re.S | re.M)
    if not m:
        raise ValueError(f"no stat block of module {module}")
    return parse_yosys_stat(m.group(1))


def ecp5_resources(cells: dict[str, int]) -> dict[str, int]:
    """Lattice ECP5 resources from synth_ecp5 cell counts."""
    return {
        "MULT18X18D": cells.get("MULT18X18D", 0),
        "LUT4": cells.get("LUT4", 0),
        "CCU2C": cells.get("CCU2C", 0),          # carry cells, two LUT4 each
        "FF": cells.get("TRELLIS_FF", 0),
        "DP16KD": cells.get("DP16KD", 0),
        "LUTRAM": cells.get("TRELLIS_DPR16X4", 0),
    }


def xc7_resources(cells: dict[str, int]) -> dict[str, int | float]:
    """Xilinx 7-series resources from synth_xilinx cell counts; RAMB in 36 Kb blocks (a RAMB18E1 is half)."""
    lutram = ("RAM32M", "RAM64M", "RAM32X1D", "RAM64X1D", "RAM128X1D", "RAM256X1S", "RAM32X1S", "RAM64X1S",
              "RAM128X1S", "RAM16X1D", "RAM32M16", "SRL16E", "SRLC32E")
    return {
        "DSP48E1": cells.get("DSP48E1", 0),
        "LUT": sum(cells.get(f"LUT{k}", 0) for k in range(1, 7)),
        "FF": sum(cells.get(c, 0) for c in ("FDRE", "FDSE", "FDCE", "FDPE")),
        "RAMB36E1": cells.get("RAMB36E1", 0),
        "RAMB18E1": cells.get("RAMB18E1", 0),
        "RAMB": cells.get("RAMB36E1", 0) + 0.5 * cells.get("RAMB18E1", 0),
        "LUTRAM": sum(cells.get(c, 0) for c in lutram),
        "CARRY4": cells.get("CARRY4", 0),
    }


_MEM_MAP = re.compile(r"^mapping memory (\S+) via (\S+)$")
_MEM_FF = re.compile(r"^using FF mapping for memory (\S+)$")


def parse_memory_mapping(log: str) -> dict[str, str]:
    """What yosys memory_libmap made of each memory: memory -> primitive (or 'FF')."""
    out = {}
    for line in log.splitlines():
        line = line.strip()
        m = _MEM_MAP.match(line)
        if m:
            out[m.group(1)] = m.group(2).strip("$_")
            continue
        m = _MEM_FF.match(line)
        if m:
            out[m.group(1)] = "FF"
    return out


_FMAX_LOG = re.compile(r"Max frequency for clock\s+'([^']+)':\s+([0-9.]+)\s+MHz(?:\s+\((PASS|FAIL) at ([0-9.]+) MHz\))?")


def parse_nextpnr_log(text: str) -> dict | None:
    """Fmax of the first clock from the last 'Max frequency for clock' line (after routing)."""
    hits = _FMAX_LOG.findall(text)
    if not hits:
        return None
    clk, f, verdict, target = hits[-1]
    return {"clock": clk, "fmax_mhz": float(f), "target_mhz": float(target) if target else None,
            "pass": verdict == "PASS" if verdict else None}


def parse_nextpnr_report(report: dict) -> dict:
    """Fmax, utilisation and the register-to-register critical path from a nextpnr --report JSON."""
    fmax = report.get("fmax") or {}
    if not fmax:
        raise ValueError("nextpnr report has no fmax entry")
    clk = next(iter(fmax))
    out = {"clock": clk, "fmax_mhz": float(fmax[clk]["achieved"]), "target_mhz": float(fmax[clk]["constraint"]),
           "utilisation": {k: v["used"] for k, v in (report.get("utilization") or {}).items() if v.get("used")},
           "critical_path": None}
    for cp in report.get("critical_paths", []):
        if cp.get("from") == cp.get("to") and clk in str(cp.get("from")):
            out["critical_path"] = summarize_path(cp["path"])
            break
    return out


def step_kind(step: dict) -> str:
    """The ECP5 primitive behind one nextpnr timing step, from its cell name and ports."""
    cell, fp, tp = step["from"]["cell"], step["from"]["port"], step["to"]["port"]
    if step["type"] == "clk-to-q":
        return "DP16KD read" if re.fullmatch(r"DO[AB]\d+", fp) else "FF"
    if "CCU2" in cell or fp in ("FCI", "FCO") or tp in ("FCI", "FCO"):
        return "CCU2C"
    if re.fullmatch(r"[AB]\d+", fp) and re.fullmatch(r"P\d+", tp):
        return "MULT18X18D"
    if tp == "OFX":
        return "PFUMX/L6MUX21"
    if tp == "F":
        return "LUT4"
    return "other"


def summarize_path(path: list[dict]) -> dict:
    """Start and end point, logic levels (by primitive) and the logic/routing split of one nextpnr critical
    path."""
    first, last = path[0], path[-1]
    levels = [s for s in path if s["type"] == "logic"]
    nets = [s["net"] for s in path if s["type"] == "routing" and "net" in s]
    kinds: dict[str, int] = {}
    for s in levels:
        kinds[step_kind(s)] = kinds.get(step_kind(s), 0) + 1
    return {
        "source_kind": step_kind(first) if first["type"] == "clk-to-q" else first["type"],
        "kinds": kinds,
        "from": f"{first['from']['cell']}.{first['from']['port']}",
        "to": f"{last['to']['cell']}.{last['to']['port']}",
        "logic_levels": len(levels),
        "clk_to_q_ns": sum(s["delay"] for s in path if s["type"] == "clk-to-q"),
        "logic_ns": sum(s["delay"] for s in levels),
        "routing_ns": sum(s["delay"] for s in path if s["type"] == "routing"),
        "setup_ns": sum(s["delay"] for s in path if s["type"] == "setup"),
        "total_ns": sum(s["delay"] for s in path),
        "cells": [s["to"]["cell"] for s in levels],
        "nets": nets,
        "signals": rtl_names([first["from"]["cell"]] + nets + [last["to"]["cell"]]),
        "max_net": max(((s["delay"], s.get("net", "")) for s in path if s["type"] == "routing"), default=(0.0, "")),
    }


_NETLIST_SUFFIX = re.compile(r"(_TRELLIS_|_LUT4|_PFUMX|_L6MUX21|_CCU2C|_DO[AB]\d|\.mem\b|\[|\$)")


def rtl_names(names: list[str]) -> list[str]:
    """The RTL signals behind nextpnr cell and net names, in path order: yosys names the cells it maps after
    the signal they drive or read ('yReg_26_TRELLIS_FF_Q_DI' -> 'yReg_26', 'bndRam_0.mem.0.0_DOA13[1]' ->
    'bndRam_0')."""
    out: list[str] = []
    for n in names:
        n = re.sub(r"^u\d+\.", "", n)  # the instance in the Fmax harness (mpc_bench.harness)
        m = _NETLIST_SUFFIX.search(n)
        base = n[: m.start()] if m else n
        if base and base not in out:
            out.append(base)
    return out


def lpf_frequency(text: str, port: str = "clock") -> float | None:
    """MHz of `FREQUENCY PORT "<port>" <f> MHZ;` in an LPF file."""
    m = re.search(rf'FREQUENCY\s+PORT\s+"?{re.escape(port)}"?\s+([0-9.]+)\s*MHZ', text, re.IGNORECASE)
    return float(m.group(1)) if m else None


def ecp5_fit(res: dict[str, int]) -> list[str]:
    """Hard blocks the synthesised core needs beyond the LFE5U-85F's (empty when they fit); nextpnr would stop
    at placement, so the bench does not start it."""
    return [f"{res[k]} {k} needed, {ECP5_85F[k]} on the LFE5U-85F" for k in ("MULT18X18D", "DP16KD")
            if res[k] > ECP5_85F[k]]

