"""The shared blocks on their own: bus.RegSlice, bus.FlowQueue, shell.AnswerQueue, shell.FrameIn,
shell.PassSequencer, shell.TurnSequencer, fixed.SerialDivider and mem.InitRam, a few parameterisations each
(verif/blocks BLOCKS), elaborated in one generator run (gen.BlocksMain) and simulated side by side in one
Verilator model; each block's cocotb bench (verif/blocks/<bench>.py) checks it against a Python model of its
documented contract under random stimulus, idle cycles and backpressure, with a reset in the middle."""
from __future__ import annotations

import pytest

from mpc_cores.flow import REPO
from mpc_cores.sim import run_cocotb
from verif.blocks import BENCHES, TOP, generate
from verif.blocks.violations import MESSAGES

BUILD = REPO / "build" / "tests" / "blocks"


@pytest.fixture(scope="module")
def blocks():
    """The blocks' folder (hw.json, <name>.sv per block, blocks_top.sv)."""
    hw = generate(BUILD)
    return [BUILD / b["sv"] for b in hw["blocks"]] + [BUILD / f"{TOP}.sv"]


def run(sources, bench: str, testcase):
    log = BUILD / "sim" / f"{bench}-{testcase if isinstance(testcase, str) else testcase[0]}.log"
    return run_cocotb(sources, TOP, f"verif.blocks.{bench}", BUILD / "sim", {"BLOCKS_OUT": str(BUILD)},
                      testcase=testcase, log=log), log


@pytest.mark.parametrize("bench", BENCHES)
def test_block(blocks, bench):
    (tests, failed), log = run(blocks, bench, BENCHES[bench])
    assert tests == len(BENCHES[bench]) and failed == 0, f"{failed} of {tests} cocotb tests failed: see {log}"


@pytest.mark.parametrize("violation", MESSAGES)
def test_violation_stops_the_simulation(blocks, violation):
    try:
        (tests, failed), log = run(blocks, "violations", violation)
        assert failed == tests == 1, f"the violation went unnoticed: see {log}"
    except RuntimeError:
        pass  # the simulator stopped: its log says why
    log = BUILD / "sim" / f"violations-{violation}.log"
    text = log.read_text()
    assert f"Assertion failed: {MESSAGES[violation]}" in text, f"no assertion message: see {log}"
    assert "went on, no assertion stopped it" not in text
