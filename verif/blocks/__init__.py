"""Unit benches of the shared blocks, each on its own: bus.RegSlice, bus.FlowQueue, shell.AnswerQueue, shell.FrameIn,
shell.PassSequencer, shell.TurnSequencer, fixed.SerialDivider and mem.InitRam.

`BLOCKS` lists the parameterisations. `generate` elaborates them in one generator run (gen.BlocksMain, cached like
the cores: skipped when the list and the generator sources are unchanged), each a top-level module of its own
(<name>.sv), and `wrapper` writes `blocks_top`, which places them side by side in one Verilator model (one C++
build for all): a shared `clock`, per block a `<name>_reset` and its ports as `<name>_<port>`. The cocotb benches
(verif/blocks/*_tb.py) find a block's parameters in BLOCKS_JSON (hw.json) and check it against a Python model of
its documented contract under random stimulus, idle cycles and backpressure.
"""
from __future__ import annotations

import json
import re
from pathlib import Path

MAIN = "gen.BlocksMain"
TOP = "blocks_top"
# the cocotb module of each block and its tests that must pass
BENCHES = {"regslice_tb": ["reg_slice"], "flowqueue_tb": ["flow_queue"], "answerqueue_tb": ["answer_queue"],
           "framein_tb": ["frame_in"], "passseq_tb": ["pass_sequencer"], "turnseq_tb": ["turn_sequencer"],
           "divider_tb": ["serial_divider", "serial_divider_wide_divisor"], "initram_tb": ["init_ram"]}

BLOCKS: list[dict] = [
    {"name": "rs_u8", "block": "RegSlice", "width": 8},
    {"name": "rs_sw16", "block": "RegSlice", "width": 16, "stream": True},
    {"name": "fq_d2", "block": "FlowQueue", "width": 8, "depth": 2},
    {"name": "fq_d5", "block": "FlowQueue", "width": 8, "depth": 5},
    {"name": "aq_w8", "block": "AnswerQueue", "width": 8},
    {"name": "aq_w32", "block": "AnswerQueue", "width": 32},
    {"name": "fi_w3", "block": "FrameIn", "words": 3, "wordW": 8, "streamW": 8, "ids": 1,
     "box": [[-20, 30], [0, 0], [-128, 127]]},
    {"name": "fi_w1", "block": "FrameIn", "words": 1, "wordW": 6, "streamW": 8, "ids": 1, "box": [[-5, 7]]},
    {"name": "fi_w4_id3", "block": "FrameIn", "words": 4, "wordW": 12, "streamW": 16, "ids": 3,
     "box": [[-100, 100], [-2048, 2047], [5, 9], [-300, -200]]},
    # the passes' gaps (firstLen - K, L - K): (2, 1), (1, 0), (0, 1), (3, 0)
    {"name": "ps_k3", "block": "PassSequencer", "K": 3, "firstLen": 5, "L": 4, "copyAfterFirst": True, "maxOut": 4},
    {"name": "ps_k1", "block": "PassSequencer", "K": 1, "firstLen": 2, "L": 1, "copyAfterFirst": False, "maxOut": 1},
    {"name": "ps_k2", "block": "PassSequencer", "K": 2, "firstLen": 2, "L": 3, "copyAfterFirst": True, "maxOut": 3},
    {"name": "ps_k4", "block": "PassSequencer", "K": 4, "firstLen": 7, "L": 4, "copyAfterFirst": False, "maxOut": 2},
    # rounds R = max(L, Kp K) with pad R - Kp K: 2, 0, 1
    {"name": "ts_k2p2", "block": "TurnSequencer", "K": 2, "Kp": 2, "L": 6, "maxOut": 3},
    {"name": "ts_k3p3", "block": "TurnSequencer", "K": 3, "Kp": 3, "L": 4, "maxOut": 2},
    {"name": "ts_k1p3", "block": "TurnSequencer", "K": 1, "Kp": 3, "L": 4, "maxOut": 1},
    {"name": "sd_6_3", "block": "SerialDivider", "xW": 6, "dW": 3},
    {"name": "sd_16_8", "block": "SerialDivider", "xW": 16, "dW": 8},
    {"name": "sd_34_18", "block": "SerialDivider", "xW": 34, "dW": 18},
    {"name": "sd_8_8", "block": "SerialDivider", "xW": 8, "dW": 8},
    {"name": "ir_plain", "block": "InitRam", "depth": 5, "lanes": 3, "laneW": 6,
     "init": [[1, -2, 31], [-32, 0, 7], [5, 5, -1]]},
    {"name": "ir_outreg", "block": "InitRam", "depth": 8, "lanes": 2, "laneW": 9, "outReg": True,
     "init": [[i * 37 - 200, 255 - i * 50] for i in range(8)]},
    {"name": "ir_ahead", "block": "InitRam", "depth": 4, "lanes": 1, "laneW": 8, "outReg": True, "raddrAhead": True,
     "init": [[-128], [127], [0], [-1]]},
    {"name": "ir_ahead_noreg", "block": "InitRam", "depth": 6, "lanes": 1, "laneW": 5, "raddrAhead": True,
     "init": [[-16], [15]]},
    {"name": "ir_ecp5", "block": "InitRam", "depth": 16, "lanes": 2, "laneW": 10, "outReg": True, "ecp5": True,
     "raddrAhead": True, "broadcast": True, "init": [[-512, 511], [3, -3], [100, 200], [0, 1], [-7, 9]]},
    {"name": "ir_depth1", "block": "InitRam", "depth": 1, "lanes": 2, "laneW": 4, "init": [[-8, 7]]},
]


def of_kind(blocks: list[dict], kind: str) -> list[dict]:
    return [b for b in blocks if b["block"] == kind]


def _current(out: Path) -> bool:
    try:
        hw = json.loads((out / "hw.json").read_text())
    except (OSError, ValueError):
        return False
    return all((out / b["sv"]).exists() for b in hw["blocks"])


def generate(out: Path, blocks: list[dict] = BLOCKS) -> dict:
    """Elaborate `blocks` into `out` (one generator run; skipped when current) and write the wrapper; returns
    hw.json (the blocks, each with its `sv`)."""
    from mpc_cores.flow import GENERATE_LOCK, locked, run_stale

    out = Path(out)
    text = json.dumps({"blocks": blocks}, sort_keys=True)

    def write_config(path):
        Path(path).write_text(text)

    with locked(GENERATE_LOCK):
        run_stale(MAIN, [(text, out, write_config)], _current)
        hw = json.loads((out / "hw.json").read_text())
        top, text = out / f"{TOP}.sv", wrapper(out, hw["blocks"])
        if not top.exists() or top.read_text() != text:  # rewritten, it would rebuild the model
            top.write_text(text)
    return hw


PORT = re.compile(r"^\s*(?:(input|output)\s+)?(?:\[(\d+):0\]\s+)?(\w+)\s*,?\s*(?://.*)?$")


def ports(sv: str, module: str) -> list[tuple[str, int, str]]:
    """(direction, width, name) of `module`'s ports in firtool's output (ANSI ports; a port without a direction or
    a range takes those of the port before it, as in SystemVerilog)."""
    m = re.search(rf"^module {re.escape(module)}\((.*?)\);", sv, re.S | re.M)
    assert m, f"no module {module}"
    res, d, w = [], None, 1
    for line in m.group(1).splitlines():
        if not line.strip() or line.strip().startswith("//"):
            continue
        p = PORT.match(line)
        assert p, f"{module}: cannot read the port line {line!r}"
        if p.group(1):
            d, w = p.group(1), int(p.group(2)) + 1 if p.group(2) else 1
        elif p.group(2):
            w = int(p.group(2)) + 1
        res.append((d, w, p.group(3)))
    return res


def wrapper(out: Path, blocks: list[dict]) -> str:
    """`blocks_top`: every block of `blocks` side by side on one clock, with a reset and ports of its own."""
    decl, body = ["input clock"], []
    for b in blocks:
        name = b["name"]
        conns = []
        for d, w, p in ports((Path(out) / b["sv"]).read_text(), name):
            if p == "clock":
                conns.append(".clock(clock)")
                continue
            rng = f"[{w - 1}:0] " if w > 1 else ""
            decl.append(f"{d} {rng}{name}_{p}")
            conns.append(f".{p}({name}_{p})")
        body.append(f"  {name} u_{name} (" + ", ".join(conns) + ");")
    return ("// the shared blocks side by side (generated by verif/blocks/__init__.py)\n"
            f"module {TOP}(\n  " + ",\n  ".join(decl) + "\n);\n" + "\n".join(body) + "\nendmodule\n")
