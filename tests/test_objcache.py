"""mpc_cores/objcache.py, the Verilator makefiles' OBJCACHE: a runtime object is compiled once per set of flags and
copied into the next model's folder; other compiles, and a runtime source with other flags, go to the compiler."""
from __future__ import annotations

import sys
from pathlib import Path

from mpc_cores import objcache

# a stand-in compiler: appends its call to calls.txt and writes the object (its flags) and the -MMD dependency file
FAKE_CXX = """import sys
from pathlib import Path
args = sys.argv[1:]
obj = Path(args[args.index("-o") + 1])
with open({log!r}, "a") as f:
    f.write(" ".join(args) + "\\n")
obj.write_text("object of " + " ".join(a for a in args if a.startswith("-D")))
obj.with_suffix(".d").write_text(f"{{obj.name}}: {{args[-1]}}\\n")
"""


def test_runtime_objects_compiled_once_per_flags(tmp_path, monkeypatch):
    root = tmp_path / "verilator"
    (root / "include").mkdir(parents=True)
    rt = root / "include" / "verilated.cpp"
    rt.write_text("// runtime")
    user = tmp_path / "verilator.cpp"
    user.write_text("// a model's own file")
    log = tmp_path / "calls.txt"
    cxx = tmp_path / "cxx.py"
    cxx.write_text(FAKE_CXX.format(log=str(log)))
    monkeypatch.setenv("VERILATOR_ROOT", str(root))
    cache = tmp_path / "cache"

    def compile_in(model: str, src: Path, *flags: str) -> Path:
        d = tmp_path / model
        d.mkdir(exist_ok=True)
        monkeypatch.chdir(d)
        obj = src.with_suffix(".o").name
        assert objcache.main(["objcache.py", str(cache), sys.executable, str(cxx), *flags, "-c", "-o", obj,
                              str(src)]) == 0
        return d / obj

    a = compile_in("a", rt, "-DVM_TRACE=0")
    b = compile_in("b", rt, "-DVM_TRACE=0")
    assert a.read_text() == b.read_text() == "object of -DVM_TRACE=0"
    assert (tmp_path / "b" / "verilated.d").read_text() == f"verilated.o: {rt}\n"
    assert len(log.read_text().splitlines()) == 1            # b's copy came from the cache
    c = compile_in("c", rt, "-DVM_TRACE=1")                 # other flags: another object
    assert c.read_text() == "object of -DVM_TRACE=1" and len(log.read_text().splitlines()) == 2
    compile_in("a", user, "-DVM_TRACE=0")
    compile_in("b", user, "-DVM_TRACE=0")                   # not a runtime source: compiled every time
    assert len(log.read_text().splitlines()) == 4
    rt.write_text("// another Verilator's runtime")         # a new runtime source: compiled again
    compile_in("d", rt, "-DVM_TRACE=0")
    assert len(log.read_text().splitlines()) == 5
