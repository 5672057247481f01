"""The shape of the Python code: modules stay small and the module graph has no cycles (imports inside functions
count), the product package does not import the testbenches or the benchmark, and every core kind of the registry
provides what the interface asks for."""
from __future__ import annotations

import ast
import importlib.util
from pathlib import Path

import pytest

from mpc_cores import registry
from mpc_cores.flow import REPO

PACKAGES = ("mpc_cores", "mpc_bench", "verif")
MAX_LINES = 600


def _modules() -> dict[str, Path]:
    mods = {}
    for pkg in PACKAGES:
        for f in sorted((REPO / pkg).rglob("*.py")):
            parts = list(f.relative_to(REPO).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            mods[".".join(parts)] = f
    return mods


def _imports(name: str, path: Path, known: set[str]) -> set[str]:
    """The project modules `name` imports anywhere in its body."""
    out = set()
    is_pkg = path.name == "__init__.py"
    for node in ast.walk(ast.parse(path.read_text())):
        targets = []
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                pkg = name.split(".") if is_pkg else name.split(".")[:-1]
                pkg = pkg[: len(pkg) - node.level + 1]
                base = ".".join(pkg + ([base] if base else []))
            targets = [base] + [f"{base}.{a.name}" for a in node.names]
        for t in targets:
            while t and t not in known:
                t = t.rpartition(".")[0]
            if t and t != name:
                out.add(t)
    return out


def _graph() -> dict[str, set[str]]:
    mods = _modules()
    known = set(mods)
    return {m: _imports(m, f, known) for m, f in mods.items()}


def test_modules_are_small():
    big = {m: n for m, f in _modules().items() if (n := len(f.read_text().splitlines())) > MAX_LINES}
    assert not big, f"modules over {MAX_LINES} lines: {big}"


def test_no_import_cycles():
    g = _graph()
    # packages import their submodules' names only through explicit imports; a package __init__ counts as a module
    state: dict[str, int] = {}
    cycles = []

    def visit(m, stack):
        state[m] = 1
        stack.append(m)
        for d in sorted(g.get(m, ())):
            if state.get(d) == 1:
                cycles.append(stack[stack.index(d):] + [d])
            elif d not in state:
                visit(d, stack)
        stack.pop()
        state[m] = 2

    for m in sorted(g):
        if m not in state:
            visit(m, [])
    assert not cycles, "import cycles: " + "; ".join(" -> ".join(c) for c in cycles[:5])


def test_product_does_not_import_tests_or_bench():
    g = _graph()
    bad = {m: sorted(d for d in deps if d.split(".")[0] in ("verif", "mpc_bench"))
           for m, deps in g.items() if m.split(".")[0] == "mpc_cores"}
    assert not {m: d for m, d in bad.items() if d}


@pytest.mark.parametrize("name", registry.names())
def test_core_kind_provides_its_parts(name):
    """Every reference of a registered kind resolves: design, report, golden model, testbench (with its cycle-contract
    scenario), benchmark section, generator main (a Scala source of that object), soak space, protocol-fuzz family,
    small core (its design flow accepts it, in a folder of its kind's RTL suite), docs page, clock constraints, and
    its own spec rules among the keys it reads."""
    k = registry.get(name)
    from mpc_cores.kind import load

    assert callable(load(k.design_fn))
    rep = load(k.report_module)
    assert callable(rep.core_json) and callable(rep.design_report)
    assert callable(load(k.model_fn))
    tb = ast.parse(Path(importlib.util.find_spec(k.testbench).origin).read_text())
    bound = {n.name for n in tb.body if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))}
    bound |= {a.asname or a.name for n in tb.body if isinstance(n, ast.ImportFrom) for a in n.names}
    assert k.cycle_test in bound, f"{k.testbench} has no cocotb test {k.cycle_test}"
    assert importlib.util.find_spec(k.bench) is not None, f"no benchmark section {k.bench}"
    pkg, obj = k.generator_main.rsplit(".", 1)
    scala = REPO / "src/main/scala" / pkg.replace(".", "/")
    assert any(f"object {obj}" in f.read_text() for f in scala.glob("*.scala")), f"no Scala object {k.generator_main}"
    from mpc_cores.soak.space import SoakSpace
    from mpc_cores.small import SmallCore
    from verif.fuzz.kinds import Family, Kind

    assert isinstance(load(k.soak), SoakSpace), k.soak
    fam = load(k.fuzz)
    assert isinstance(fam, Family) and issubclass(fam.adapter, Kind) and fam.violations, k.fuzz
    assert isinstance(load(fam.tb), type), fam.tb
    s = k.small_core()
    assert isinstance(s, SmallCore) and s.case.count("/") == 1, s
    assert k.design(s.problem(), **s.overrides).name
    for f in (k.docs_page, k.lpf):
        assert (REPO / f).is_file(), f"CORE={name}: no {f}"
    assert set(k.spec_rules) <= set(k.spec_section), f"CORE={name}: own spec rules it does not read"


# Cross-kind studies of 004 (the methods compared on one problem): they import the kinds' packages by design.
STUDIES = {"mpc_cores.methods", "mpc_cores.methods_table"}


def test_shared_modules_do_not_import_a_kinds_package():
    """A kind's facts live with the kind: no module of mpc_cores outside a kind's package imports one (the registry
    loads them by name), except the cross-kind studies (STUDIES)"""
    kind_pkgs = {f"mpc_cores.{n}" for n in ("fgm", "admm", "dgp", "minres", "ipm")}
    assert {f"mpc_cores.{load_name}" for load_name in kind_pkgs_of_registry()} <= kind_pkgs
    g = _graph()
    bad = {}
    for m, deps in g.items():
        if m.split(".")[0] != "mpc_cores" or m in STUDIES or any(m == k or m.startswith(k + ".") for k in kind_pkgs):
            continue
        hit = sorted(d for d in deps if any(d == k or d.startswith(k + ".") for k in kind_pkgs))
        if hit:
            bad[m] = hit
    assert not bad, bad


def kind_pkgs_of_registry() -> set[str]:
    """the packages of the registry's kinds (mpc_cores/<package>/kind.py)"""
    return {registry.get(n).model_fn.split(".")[1] for n in registry.names()}


# Makefile help lines that name kinds, "(kinds: a, b, ...)": the registry's kinds with that part
MAKE_KIND_LISTS = {
    "##v CORE:": lambda k: True,
    "##v TOL:": lambda k: k.tol_fn is not None,
    "##v PROBLEMS:": lambda k: "problems" in k.overrides,
    "##v LANES:": lambda k: "lanes" in k.overrides,
    "##v FORMAT, LATENCY:": lambda k: "format" in k.overrides,
    "## c:": lambda k: k.c_fn is not None,
    "## split:": lambda k: k.split_fn is not None,
    "## demo:": lambda k: k.has_demo,
}


def test_makefile_help_names_the_registry_kinds():
    """Every kind list in `make help` is the registry's kinds with that part, in registry order."""
    import re

    text = (REPO / "Makefile").read_text()
    for head, has in MAKE_KIND_LISTS.items():
        line = next((ln for ln in text.splitlines() if ln.startswith(head)), None)
        assert line is not None, f"Makefile: no help line {head}"
        m = re.search(r"\(kinds: ([a-z0-9, ]+)\)", line)
        assert m, f"Makefile: {head} names no (kinds: ...)"
        want = [n for n, k in registry.kinds().items() if has(k)]
        assert m[1].split(", ") == want, f"Makefile {head} lists {m[1]}; the registry: {', '.join(want)}"
