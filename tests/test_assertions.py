"""The protocol assertions of the RTL (src/main/scala/bus/Protocol.scala): present in every small core, out of
synthesis (firtool guards them with `ifndef SYNTHESIS), and live in the Verilator models the suite runs: a
violation forced into a core (verif/fuzz/violations.py) stops the simulation with the assertion's message.
"""
from __future__ import annotations

import re

import pytest

from conftest import suite_kinds
from mpc_cores.sim import run_cocotb
from verif.fuzz import kinds
from verif.fuzz.violations import MESSAGES

KINDS = suite_kinds("assertions")
# (kind, a violation forced into its small core): those its family declares (CoreKind.fuzz)
VIOLATIONS = [(k, v) for k in KINDS for v in kinds.violations(k)]
GUARDED = re.compile(r"`ifndef SYNTHESIS\n.*?`endif // not def SYNTHESIS\n", re.S)


@pytest.mark.parametrize("kind", KINDS)
def test_assertions_outside_synthesis(small_cores, kind):
    """Each core carries the checks of its ports and of its queues (the kind's adapter names them), every one
    inside an `ifndef SYNTHESIS block."""
    out, core = small_cores[kind]
    sv = (out / core["sv"]).read_text()
    guarded = "".join(GUARDED.findall(sv))
    msgs = set(re.findall(r'Assertion failed: ([^\\"]+)', guarded))
    want = {f"{port}: {what}" for port in ("s_axil B", "s_axil R", "m_axis")
            for what in ("valid dropped before ready", "payload changed while valid and not ready")}
    want |= {f"{q}: enqueue while full" for q in kinds.family(kind).adapter.queue_checks(core)}
    assert want <= msgs, f"missing: {want - msgs}"
    rest = GUARDED.sub("", sv)
    for task in ("$error", "$fatal", "assert("):
        assert task not in rest, f"{task} outside `ifndef SYNTHESIS"


@pytest.mark.parametrize("kind,violation", VIOLATIONS)
def test_violation_stops_the_simulation(small_cores, kind, violation, tmp_path):
    out, core = small_cores[kind]
    log = tmp_path / "sim.log"
    try:
        tests, failed = run_cocotb(out / core["sv"], core["module"], "verif.fuzz.violations", out / "sim",
                                   {"CORE_OUT": str(out)}, testcase=violation, log=log)
        assert failed == tests == 1, f"the violation went unnoticed: see {log}"
    except RuntimeError:
        pass  # the simulator stopped: its log says why
    text = log.read_text()
    assert f"Assertion failed: {MESSAGES[violation]}" in text, f"no assertion message: see {log}"
    assert "went on, no assertion stopped it" not in text
