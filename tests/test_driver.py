"""The C drivers `make verilog` writes (mpc_cores.cdriver): compiled strictly as C99 and C11, then run on the
Verilator model of a small core of every kind with a driver (and an FGM core with the exit test) by verif/driver_tb.py:
every answer, flag, cycle count and iteration count equal to the golden model's, a data-region rewrite between
solves, the refusals. The models are the RTL suites' (the same build folders)."""
from __future__ import annotations

import json

import pytest

from mpc_cores import registry
from mpc_cores.csrc import harness
from mpc_cores.sim import run_cocotb

pytestmark = pytest.mark.skipif(harness.gcc() is None, reason="gcc not found: the drivers are compiled by gcc")

KINDS = [k for k in registry.names() if registry.get(k).driver]


def _run(out, core: dict, tmp_path, solves: int = 12) -> dict:
    drv = out / f"{core['module']}_driver.c"
    assert sorted(core["driver"]) == sorted([drv.name, f"{core['module']}_driver.h"])
    for std in ("c99", "c11"):
        harness.compile_c([drv], tmp_path / f"drv_{std}.o", "-c", f"-std={std}", f"-I{out}")
    lib = harness.compile_c([drv], tmp_path / "libdriver.so", "-fPIC", "-shared", f"-I{out}")
    measure = tmp_path / "measured.jsonl"
    env = {"CORE_OUT": str(out), "CORE_DRIVER_LIB": str(lib), "CORE_RANDOM": str(solves),
           "CORE_MEASURE": str(measure)}
    tests, failed = run_cocotb(out / core["sv"], core["module"], "verif.driver_tb", out / "sim", env,
                               log=out / "sim" / "driver.log")
    assert (tests, failed) == (1, 0), f"the driver bench failed: see {out / 'sim' / 'driver.log'}"
    return json.loads(measure.read_text().splitlines()[-1])


@pytest.mark.parametrize("kind", KINDS)
def test_driver_on_the_rtl(kind, small_cores, tmp_path):
    out, core = small_cores[kind]
    rec = _run(out, core, tmp_path)
    assert rec["solves"] == 12 and rec["warm"] and rec["out_all"]
    assert rec["rewrites"] == (3 if core["regions"] else 0), rec     # the DGP core has no writable data


def test_driver_with_the_exit_test(cores, tmp_path):
    """ITERATIONS read back as the exit test ends the solves (an FGM core with the test)"""
    out = cores["rand_n6_p6_b12_l00_exit"]
    core = json.loads((out / "core.json").read_text())
    assert core["early_exit"] and "EXIT_TOL" in {r["name"] for r in core["registers"]}
    _run(out, core, tmp_path)


def test_kinds_without_a_driver_write_none(small_cores):
    """the float cores (minres, ipm) stream float words: no driver yet, and core.json names none"""
    for k in registry.names():
        if k not in KINDS:
            out, core = small_cores[k]
            assert "driver" not in core and not list(out.glob("*_driver.c"))
