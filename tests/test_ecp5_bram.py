"""The ECP5 block RAMs of the row memories (mem/Ecp5BlockRam.scala): on TARGET=ecp5 the FGM and ADMM row memories
are DP16KD primitives with their output register for synthesis. Every other test simulates their behavioural
branch; here the synthesis branch itself runs in Verilator (-DSYNTHESIS) against a model of the primitive
(verif/ecp5/bram_tb.py): initial contents from INITVAL, the two-cycle read, lane-masked writes, lanes of one and
of two primitives."""
from __future__ import annotations

import json
import re

import pytest

from mpc_cores.flow import REPO
from mpc_cores.sim import run_cocotb

# (suite, case, memory): an FGM row memory (lanes of <= 18 bits: one primitive each) and an ADMM core's bounds
# (lanes wider than 18 bits: two primitives each)
MEMS = [("fgm", "afm_p2_b16_ecp5", "mat1"), ("admm", "rand_soft_n26_p2_l24_ecp5", "bnd1")]
BUILD = REPO / "build/test_ecp5_bram"


def module_text(sv: str, name: str) -> str:
    m = re.search(rf"^module {re.escape(name)} \(.*?^endmodule", sv, re.S | re.M)
    assert m, f"no module {name}"
    return m.group(0)


def spec_of(text: str) -> dict:
    """depth, lanes, lane width and the initial rows, from the behavioural branch of an InitRam"""
    depth = int(re.search(r"reg \[\d+:0\] mem \[0:(\d+)\];", text).group(1)) + 1
    lanes = int(re.search(r"for \(i = 0; i < (\d+); i = i \+ 1\)", text).group(1))
    lw = int(re.search(r"wdata_q\[i\*(\d+) \+:", text).group(1))
    rows = {int(a): int(v, 16) for a, v in re.findall(r"mem\[(\d+)\] = \d+'h([0-9a-f]+);", text)}
    return {"depth": depth, "lanes": lanes, "lane_width": lw, "rows": [rows.get(a, 0) for a in range(depth)]}


@pytest.mark.parametrize("suite,case,mem", MEMS, ids=[f"{c}-{m}" for _, c, m in MEMS])
def test_synthesis_branch_reads_and_writes(suite, case, mem, cores, admm_cores):
    from verif.ecp5.bram_tb import dp16kd_model

    out = (cores if suite == "fgm" else admm_cores)[case]
    core = json.loads((out / "core.json").read_text())
    name = f"{core['module']}_{mem}"
    text = module_text((out / core["sv"]).read_text(), name)
    assert 'REGMODE_B("OUTREG")' in text and "`ifdef SYNTHESIS" in text
    spec = spec_of(text)
    assert any(spec["rows"]), "a memory with initial contents"
    d = BUILD / name
    d.mkdir(parents=True, exist_ok=True)
    (d / f"{name}.sv").write_text(text)
    (d / "dp16kd_model.v").write_text(dp16kd_model())
    (d / "spec.json").write_text(json.dumps(spec))
    prims = text.count("DP16KD #(")
    assert prims == spec["lanes"] * -(-spec["lane_width"] // 18)
    tests, failed = run_cocotb([d / f"{name}.sv", d / "dp16kd_model.v"], name, "verif.ecp5.bram_tb", d / "sim",
                               {"BRAM_SPEC": str(d / "spec.json")}, extra_args=("-DSYNTHESIS",))
    assert (tests, failed) == (1, 0), f"see {d / 'sim' / 'sim.log'}"
