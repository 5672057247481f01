"""The heterogeneous split of the ADMM family (004, section 5; mpc_cores/admm/split.py): the matrix-vector block
against its bit-exact model in Verilator (words, flags, cycle contract, backpressure, reset), and a closed loop in
which the generated C runs the method with every s = M11 v from that block, word for word equal to the C alone,
to the golden model and to the all-hardware core fed the same parameter words."""
from __future__ import annotations

import json

import numpy as np
import pytest

from conftest import ADMM_CASES, RATE, SOFT1, random_spec
from mpc_cores.admm import c as admm_c
from mpc_cores.admm.design import design_admm
from mpc_cores.admm.split import LinStep, generate_linstep, linstep_config
from mpc_cores.csrc import harness
from mpc_cores.flow import REPO
from mpc_cores.problem import load_spec
from mpc_cores.sim import run_cocotb

CASE = "rand_soft_n19_p3_l00_trunc"          # an ADMM core of tests/test_admm_rtl.py (its Verilator model is reused)
SPEC = ("ra19", 2, 1, 3, 1, 5)
STEPS, HOLD = 12, 4
BUILD = REPO / "build/test_split"


@pytest.fixture(scope="module")
def split(admm_cores, tmp_path_factory):
    """(spec path, ADMM design, its core's output folder, the block's output folder, the C folder)."""
    tmp = tmp_path_factory.mktemp("split")
    spec = tmp / "ra19.yaml"
    spec.write_text(json.dumps(random_spec(*SPEC, input_rate=RATE, soft_states=SOFT1)))
    _, ov, _ = ADMM_CASES[CASE]
    d = design_admm(load_spec(spec), **ov)
    core_out = admm_cores[CASE]
    assert json.loads((core_out / "config.json").read_text()) == json.loads(json.dumps(d.config())), \
        "the spec file does not give the suite's core"
    ls_out = BUILD / CASE
    generate_linstep(d, ls_out)
    admm_c.write_c(d, tmp / "c")
    return spec, d, core_out, ls_out, tmp / "c"


def test_model_is_the_cores_tree(split):
    """LinStep's s is the golden model's M11 v (AdmmFixed._dot), flags included, also beyond the operand width."""
    from mpc_cores.admm.model import AdmmFixed

    _, d, *_ = split
    cfg = linstep_config(d)
    ls, m = LinStep(cfg), AdmmFixed(d)
    rng = np.random.default_rng(0)
    ow = cfg["op_width"]
    for k in range(20):
        v = rng.integers(-(1 << (ow - 1)), 1 << (ow - 1), size=d.n) >> rng.integers(0, ow - 1)
        s, ovf, sat = ls(v)
        s2, f2, _ = m._dot(m.M11, v[None])
        assert np.array_equal(s, s2[0]) and ovf.any() == f2 and not sat
    s, ovf, sat = ls(np.full(d.n, 1 << ow))
    assert sat and np.array_equal(s, ls(np.full(d.n, (1 << (ow - 1)) - 1))[0])


def test_linstep_rtl(split):
    _, d, _, out, _ = split
    meta = json.loads((out / "linstep.json").read_text())
    assert meta["n"] == d.n and meta["P"] == d.P and meta["multipliers"] == d.n * d.P
    assert meta["latency_cycles"] == meta["run_cycles"] + 4 and meta["period_cycles"] == meta["run_cycles"] + 1 + d.n
    tests, failed = run_cocotb(out / meta["sv"], meta["module"], "verif.admm.split_tb", out / "sim",
                               {"LINSTEP_OUT": str(out)}, testcase="linstep_words")
    assert (tests, failed) == (1, 0), f"see {out / 'sim' / 'sim.log'}"


def test_split_closed_loop_equals_all_hardware(split, tmp_path):
    spec, d, core_out, ls_out, c_dir = split
    meta = json.loads((ls_out / "linstep.json").read_text())
    result = tmp_path / "split.json"
    tests, failed = run_cocotb(ls_out / meta["sv"], meta["module"], "verif.admm.split_tb", ls_out / "sim",
                               {"LINSTEP_OUT": str(ls_out), "CL_SPEC": str(spec), "CORE_CFG": str(core_out / "config.json"),
                                "C_DIR": str(c_dir), "CL_STEPS": str(STEPS), "CL_HOLD": str(HOLD),
                                "CL_RESULT": str(result)},
                               testcase="split_closed_loop", log=tmp_path / "split.log")
    assert (tests, failed) == (1, 0), f"see {tmp_path / 'split.log'}"
    split_run = json.loads(result.read_text())
    assert len(split_run["words"]) == STEPS and split_run["calls"] == STEPS * d.iterations
    # the same parameter words through the ADMM core in Verilator: the same answers and flags
    core = json.loads((core_out / "core.json").read_text())
    replay = tmp_path / "replay.json"
    tests, failed = run_cocotb(core_out / core["sv"], core["module"], "verif.admm.split_tb", core_out / "sim",
                               {"CORE_OUT": str(core_out), "REPLAY_IN": str(result), "REPLAY_OUT": str(replay)},
                               testcase="replay", log=tmp_path / "replay.log")
    assert (tests, failed) == (1, 0), f"see {tmp_path / 'replay.log'}"
    hw = json.loads(replay.read_text())
    assert hw["words"] == split_run["words"]
    assert bool(hw["status"]["OVERFLOW"]) == any(f[2] for f in split_run["flags"])
    assert bool(hw["status"]["SAT"]) == any(f[1] for f in split_run["flags"])


def test_split_api_without_hardware(split, tmp_path):
    """`_solve_split` with a linstep in C terms: equal to `_solve` when it answers like the block, the state kept
    when it fails."""
    _, d, _, _, c_dir = split
    lib = harness.load(c_dir, admm_c.emit.names(d.module_name), d.config(), build_dir=tmp_path, split=True)
    ls = LinStep(linstep_config(d))
    rng = np.random.default_rng(3)
    a, b = lib.new_state(), lib.new_state()
    wlo, whi = np.array(d.wlo), np.array(d.whi)
    for k in range(6):
        w = rng.integers(wlo, whi + 1)
        got = lib.solve(a, w, None, linstep=lambda v: (lambda s, o, _: (s, o.any()))(*ls(v)))
        sw = lib.solve(b, w, None)
        assert np.array_equal(got[0], sw[0]) and got[1] == sw[1], k
    w = rng.integers(wlo, whi + 1)
    before = bytes(a.raw)
    out, _, _ = lib.solve(a, w, None, linstep=lambda v: None)
    assert len(out) == 0 and bytes(a.raw) == before


def test_make_split_cli(split):
    """`mpc-cores split` (make split) writes the block and the C with `_solve_split`; other kinds are refused."""
    import subprocess
    import sys

    spec, d, _, out, _ = split
    _, ov, _ = ADMM_CASES[CASE]
    args = [f"--{k.replace('_', '-')}={v}" for k, v in ov.items()]
    p = subprocess.run([sys.executable, "-m", "mpc_cores", "split", "--core", "admm", "--problem", str(spec), *args,
                        "--out", str(out)], capture_output=True, text=True, cwd=REPO)
    assert p.returncode == 0, p.stdout + p.stderr
    assert f"{d.iterations} per solve" in p.stdout and "_linstep.sv" in p.stdout
    h = (out / f"{d.module_name}_solver.h").read_text()
    assert "_solve_split(" in h and "_linstep_fn" in h
    p = subprocess.run([sys.executable, "-m", "mpc_cores", "split", "--core", "fgm"], capture_output=True, text=True,
                       cwd=REPO)
    assert p.returncode != 0 and p.stderr.strip().splitlines() == [
        "error: CORE=fgm: the heterogeneous split is generated for the cores admm, ama, vucondat"]


def test_split_api_plain_form(tmp_path):
    """A design without input_rate (w = (x, r), u_0 out): `_solve_split` with the block's model answering equals
    `_solve` and the golden model built from its config.json, over a warm-started sequence."""
    from mpc_cores.admm.model import AdmmFixed

    d = design_admm(load_spec(REPO / "examples/masses.yaml"), iterations=6, sizing_solves=8)
    cfg = d.config()
    assert cfg["rate"] is False
    admm_c.write_c(d, tmp_path / "c")
    nm = admm_c.emit.names(d.module_name)
    assert "w = (x, r) saturated to its box" in (tmp_path / "c" / f"{nm.stem}.c").read_text()
    lib = harness.load(tmp_path / "c", nm, cfg, build_dir=tmp_path, split=True)
    ls, model = LinStep(linstep_config(d)), AdmmFixed(cfg)
    rng = np.random.default_rng(4)
    a, b = lib.new_state(), lib.new_state()
    for k in range(6):
        w = rng.integers(np.array(d.wlo), np.array(d.whi) + 1)
        got = lib.solve(a, w, None, linstep=lambda v: (lambda s, o, _: (s, o.any()))(*ls(v)))
        sw = lib.solve(b, w, None)
        assert np.array_equal(got[0], sw[0]) and got[1] == sw[1], k
        assert np.array_equal(got[0], model.solve(w).z[: d.nu]), k
