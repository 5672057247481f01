"""Protocol fuzz of a small core of each kind in Verilator (verif/fuzz/tb.py): AXI4-Lite against the RDL during
solves too, AXI4-Stream tlast errors with gaps and backpressure, reset swept across a solve; every answer
bit-exact with the golden model, with the RTL's protocol assertions on.

The cores are conftest's `small_cores` (their Verilator models are shared with the other suites), one for every
kind of the registry (conftest.suite_kinds; tests/test_suites.py checks that none is left out). The long variant
(every address, more rounds, reset at every cycle) is marked slow.
"""
from __future__ import annotations

import pytest

from conftest import suite_kinds
from mpc_cores.sim import run_cocotb

KINDS = suite_kinds("fuzz")
SCENARIOS = 3  # cocotb tests in verif/fuzz/tb.py


def _fuzz(small_cores, kind: str, long: bool):
    out, core = small_cores[kind]
    env = {"CORE_OUT": str(out), "FUZZ_LONG": "1" if long else "0"}
    tests, failed = run_cocotb(out / core["sv"], core["module"], "verif.fuzz.tb", out / "sim", env)
    assert tests == SCENARIOS, f"{tests} cocotb tests ran, expected {SCENARIOS}: see {out / 'sim' / 'sim.log'}"
    assert failed == 0, f"{failed} of {tests} scenarios failed: see {out / 'sim' / 'sim.log'}"


@pytest.mark.parametrize("kind", KINDS)
def test_protocol_fuzz(small_cores, kind):
    _fuzz(small_cores, kind, long=False)


@pytest.mark.slow
@pytest.mark.parametrize("kind", KINDS)
def test_protocol_fuzz_long(small_cores, kind):
    _fuzz(small_cores, kind, long=True)
