"""OBJCACHE of the Verilator models' makefiles (`$(OBJCACHE) $(CXX) ...`): the Verilator runtime.

Every model compiles the same runtime sources (verilated.cpp, verilated_vpi.cpp, ...) with the same flags, which is
most of a small model's compile time. This wrapper compiles each runtime object once per set of flags, keeps it
under a cache folder, and copies it (and its dependency file) into the next model's folder. Any other compile (the
model, cocotb's main) runs as given.

Usage (as OBJCACHE): python objcache.py CACHE_DIR CXX ARGS... ; only the standard library, so that it starts fast.
"""
from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path


def runtime_source(cmd: list[str]) -> Path | None:
    """The runtime source `cmd` compiles (a file of $VERILATOR_ROOT/include given last), or None."""
    root = os.environ.get("VERILATOR_ROOT")
    if not root or "-c" not in cmd or "-o" not in cmd or not cmd[-1].endswith(".cpp"):
        return None
    src = Path(cmd[-1])
    return src if src.is_absolute() and Path(root, "include") in src.parents else None


def key(cmd: list[str], src: Path) -> str:
    """The cache key: the command without its output, and the source's size and time (a new Verilator, new key)."""
    i = cmd.index("-o")
    st = src.stat()
    text = json.dumps([cmd[:i] + cmd[i + 2:], st.st_size, st.st_mtime_ns])
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def copy_in(src: Path, dst: Path) -> None:
    """Copy `src` to `dst` through a temporary name, so that a parallel reader never sees half a file."""
    tmp = dst.with_name(f".{dst.name}.{os.getpid()}")
    shutil.copyfile(src, tmp)
    os.replace(tmp, dst)


def main(argv: list[str]) -> int:
    cache, cmd = Path(argv[1]), argv[2:]
    src = runtime_source(cmd)
    if src is None:
        return subprocess.call(cmd)
    obj = Path(cmd[cmd.index("-o") + 1])
    dep = obj.with_suffix(".d")
    entry = cache / key(cmd, src)
    if (entry / "obj").exists() and (entry / "dep").exists():
        copy_in(entry / "dep", dep)
        copy_in(entry / "obj", obj)
        return 0
    rc = subprocess.call(cmd)
    if rc == 0 and obj.exists() and dep.exists():
        entry.mkdir(parents=True, exist_ok=True)
        copy_in(dep, entry / "dep")
        copy_in(obj, entry / "obj")
    return rc


if __name__ == "__main__":
    sys.exit(main(sys.argv))
