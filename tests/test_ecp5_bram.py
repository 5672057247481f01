"""The ECP5 block RAMs (mem/Ecp5BlockRam.scala, mem/Ecp5SdpRam.scala): on TARGET=ecp5 the FGM and ADMM row
memories, the MINRES vector memories and the Stage 1 slot memory are DP16KD primitives with their output register
for synthesis. Every other test simulates their behavioural branch; here the synthesis branch itself runs in
Verilator (-DSYNTHESIS) against a model of the primitive (verif/ecp5/bram_tb.py): initial contents from INITVAL,
the two-cycle read, lane-masked writes, lanes of one and of two primitives; the simple dual-port RAM in the x18 and
x9 modes (a read and a write on one cycle)."""
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
    # broadcast writes (InitRam's `broadcast`): one word for every lane, the first write register one lane wide
    broadcast = re.search(r"wdata_p <= wdata\[\d+:0\];", text) is not None
    return {"depth": depth, "lanes": lanes, "lane_width": lw, "rows": [rows.get(a, 0) for a in range(depth)],
            "broadcast": broadcast}


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
    # a row memory addressed a cycle ahead: each primitive has its own kept address register
    spec["ahead"] = "ra_bram_" in text
    assert spec["ahead"] == (mem.startswith("mat"))
    assert spec["broadcast"], "the row memories are written with one word for all lanes"
    if spec["ahead"]:
        assert text.count("(* keep *) always @(posedge clock) ra_bram_") == prims
    (d / "spec.json").write_text(json.dumps(spec))
    tests, failed = run_cocotb([d / f"{name}.sv", d / "dp16kd_model.v"], name, "verif.ecp5.bram_tb", d / "sim",
                               {"BRAM_SPEC": str(d / "spec.json")}, testcase="bram_rows", extra_args=("-DSYNTHESIS",))
    assert (tests, failed) == (1, 0), f"see {d / 'sim' / 'sim.log'}"


@pytest.fixture(scope="module")
def stage1_masses_ecp5():
    """A Stage 1 engine of the masses' programs on two slots, target ecp5: its slot memory banks (2048 words, the
    x9 mode) and the last, shorter one."""
    from mpc_cores.ipm import stage1_config as sc
    from mpc_cores.ipm.design import FLOOR, SIGMA, START, TAU
    from mpc_cores.ipm.program import build
    from mpc_cores.ipm.sparse import sparse_mpc
    from mpc_cores.problem import load_spec

    st = build(sparse_mpc(load_spec(REPO / "examples/masses.yaml")), SIGMA, TAU, True, START, FLOOR)
    cfg = sc.config(st, "masses", slots=2, target="ecp5")
    out = BUILD / "stage1_masses"
    hw = sc.generate([(cfg, out)])[0]
    return out, hw


def sdp_spec(text: str) -> dict:
    depth = int(re.search(r"reg \[\d+:0\] mem \[0:(\d+)\];", text).group(1)) + 1
    width = int(re.search(r"output +\[(\d+):0\] rdata", text).group(1)) + 1
    return {"kind": "sdp", "depth": depth, "lanes": 1, "lane_width": width}


@pytest.mark.parametrize("bank", ["b0", "last"])
def test_sdp_synthesis_branch(bank, stage1_masses_ecp5):
    out, hw = stage1_masses_ecp5
    sv = (out / f"{hw['module']}.sv").read_text()
    names = sorted(re.findall(r"^module (\w+_slotmem_0_b\d+) ", sv, re.M), key=lambda n: int(n.rsplit("_b", 1)[1]))
    assert len(names) >= 2, "a slot memory of several banks"
    name = names[0] if bank == "b0" else names[-1]
    text = module_text(sv, name)
    assert 'REGMODE_B("OUTREG")' in text and "`ifdef SYNTHESIS" in text
    spec = sdp_spec(text)
    mode = 18 if spec["depth"] <= 1024 else 9 if spec["depth"] <= 2048 else None
    assert mode and f".DATA_WIDTH_A({mode})" in text
    assert (bank == "b0") == (mode == 9), "the first bank is 2048 words"
    assert text.count("DP16KD #(") == -(-spec["lane_width"] // mode)
    d = BUILD / name
    d.mkdir(parents=True, exist_ok=True)
    (d / f"{name}.sv").write_text(text)
    (d / "dp16kd_model.v").write_text(dp16kd_model_text())
    (d / "spec.json").write_text(json.dumps(spec))
    tests, failed = run_cocotb([d / f"{name}.sv", d / "dp16kd_model.v"], name, "verif.ecp5.bram_tb", d / "sim",
                               {"BRAM_SPEC": str(d / "spec.json")}, testcase="sdp_rows", extra_args=("-DSYNTHESIS",))
    assert (tests, failed) == (1, 0), f"see {d / 'sim' / 'sim.log'}"


def dp16kd_model_text() -> str:
    from verif.ecp5.bram_tb import dp16kd_model

    return dp16kd_model()
