"""Packaging of a generated core: the FuseSoC core file lints with Verilator through FuseSoC from a clean cores
root, for one core of each kind (a broken SystemVerilog file fails the same target); the console command."""
from __future__ import annotations

import importlib.util
import json
import os
import shutil
import subprocess
import sys

import pytest

from mpc_cores import registry
from mpc_cores.flow import REPO

@pytest.fixture(scope="module")
def one_core_per_kind(small_cores):
    return {k: out for k, (out, _) in small_cores.items()}


def _lint(src_dir, root, work):
    """Copy a generated core's files named by its .core file into a clean cores root; run the lint target."""
    core = json.loads((src_dir / "core.json").read_text())
    shutil.rmtree(root, ignore_errors=True)
    root.mkdir(parents=True)
    for f in [core["sv"], core["fusesoc_core"]] + [core[k] for k in ("rdl", "header", "regmap_doc", "ipxact",
                                                                     "ipxact_component") if core.get(k)]:
        shutil.copy(src_dir / f, root / f)
    return core, _fusesoc(root, work, "lint", core["fusesoc_vlnv"])


def _fusesoc(root, work, target: str, vlnv: str):
    """fusesoc run as a user with the venv active: the venv's bin folder first on PATH, then the system's (the
    venv's `verilator` and `yosys` are mpc_cores.shims's)"""
    bin_dir = os.path.dirname(sys.executable)
    env = {"HOME": os.environ.get("HOME", "/tmp"), "PATH": bin_dir + os.pathsep + "/usr/bin:/bin",
           "VIRTUAL_ENV": os.path.dirname(bin_dir)}
    return subprocess.run([os.path.join(bin_dir, "fusesoc"), "--cores-root", str(root), "run", "--build-root",
                           str(work), f"--target={target}", vlnv], stdin=subprocess.DEVNULL, capture_output=True,
                          text=True, env=env)


@pytest.mark.parametrize("kind", registry.names())
def test_fusesoc_lint(kind, one_core_per_kind, tmp_path):
    core, p = _lint(one_core_per_kind[kind], tmp_path / "root", tmp_path / "work")
    assert p.returncode == 0, p.stdout[-2000:] + p.stderr[-2000:]
    text = (tmp_path / "root" / core["fusesoc_core"]).read_text()
    assert text.startswith("CAPI=2:") and "lint:" in text and "synth:" in text and "arch: ecp5" in text
    assert core["fusesoc_vlnv"] == f"mpc-cores:{kind}:{core['module']}:0.1.0"


@pytest.mark.skipif(importlib.util.find_spec("tkinter") is None,
                    reason="no Tcl in this Python (tkinter): the yosys shim evaluates edalize's Tcl script with it")
@pytest.mark.parametrize("kind", [k if k == "fgm" else pytest.param(k, marks=pytest.mark.slow)
                                  for k in registry.names()])
def test_fusesoc_synth(kind, one_core_per_kind, tmp_path):
    """The core file's synth target (Yosys synth_ecp5 through edalize) with the venv's tools only (the kinds other
    than fgm under the slow marker: a synthesis each)"""
    core = json.loads((one_core_per_kind[kind] / "core.json").read_text())
    p = _fusesoc(one_core_per_kind[kind], tmp_path / "work", "synth", core["fusesoc_vlnv"])
    assert p.returncode == 0, p.stdout[-2000:] + p.stderr[-2000:]
    net = json.loads(next((tmp_path / "work").glob("*/synth-yosys/*.json")).read_text())
    assert core["module"] in net["modules"]


def test_shims_are_the_venvs_tools():
    """`verilator` and `yosys` in the venv's bin folder are mpc_cores.shims's, and a user's own command is kept"""
    from mpc_cores import shims

    bin_dir = os.path.dirname(sys.executable)
    for cmd in ("verilator", "yosys"):
        assert shims.MARK in open(os.path.join(bin_dir, cmd)).read()
    p = subprocess.run([os.path.join(bin_dir, "verilator"), "--version"], capture_output=True, text=True,
                       env={"PATH": "/usr/bin:/bin"})
    assert p.returncode == 0 and " rev " in p.stdout, p.stdout + p.stderr


def test_shim_leaves_a_users_command(tmp_path):
    from mpc_cores import shims

    (tmp_path / "verilator").write_text("#!/bin/sh\necho mine\n")
    assert tmp_path / "verilator" not in shims.install(tmp_path)
    assert (tmp_path / "verilator").read_text() == "#!/bin/sh\necho mine\n"


def test_fusesoc_lint_fails_on_broken_verilog(one_core_per_kind, tmp_path):
    src = tmp_path / "src"
    shutil.copytree(one_core_per_kind["fgm"], src, ignore=shutil.ignore_patterns("sim", "*.lock"))
    core = json.loads((src / "core.json").read_text())
    sv = src / core["sv"]
    sv.write_text(sv.read_text().replace("endmodule", "endmodul", 1))
    _, p = _lint(src, tmp_path / "root", tmp_path / "work")
    assert p.returncode != 0


def test_console_command():
    for cmd in ([os.path.join(os.path.dirname(sys.executable), "mpc-cores"), "--help"],
                [sys.executable, "-m", "mpc_cores", "--help"]):
        p = subprocess.run(cmd, capture_output=True, text=True, cwd=REPO)
        assert p.returncode == 0, p.stderr
        for sub in ("design", "verilog", "demo", "table2", "bench", "test"):
            assert sub in p.stdout
    p = subprocess.run([sys.executable, "-m", "mpc_cores", "design", "--core", "nosuch"], capture_output=True,
                       text=True, cwd=REPO)
    assert p.returncode == 2 and p.stderr.strip().startswith("error: CORE=nosuch") and "Traceback" not in p.stderr
