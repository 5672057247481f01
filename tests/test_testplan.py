"""The testplan (verif/testplan.py): every test it names exists (a `[kind]` of a per-kind suite is a registry kind),
every test of the RTL suites is named in it, and docs/verification.md holds it as rendered."""
from __future__ import annotations

import ast

from mpc_cores import registry
from mpc_cores.flow import REPO
from verif import testplan

BEGIN, END = "<!-- testplan: rendered from verif/testplan.py -->", "<!-- /testplan -->"


def _tests(path) -> set[str]:
    tree = ast.parse(path.read_text())
    return {n.name for n in tree.body if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef)) and
            n.name.startswith("test_")}


def test_every_named_test_exists():
    missing = []
    for kind, feature, node in testplan.entries():
        path, _, func = node.partition("::")
        func, _, param = func.partition("[")
        f = REPO / path
        if not f.exists() or func not in _tests(f):
            missing.append(node)
        if param and param.rstrip("]") not in registry.names():
            missing.append(f"{node}: not a kind")
    assert not missing, missing
    assert set(testplan.KINDS) == set(registry.names())


def test_every_rtl_test_is_in_the_plan():
    named = {node.split("[")[0] for _, _, node in testplan.entries()}
    unmapped = [f"tests/{f}::{t}" for f in testplan.RTL_FILES for t in sorted(_tests(REPO / "tests" / f))
                if f"tests/{f}::{t}" not in named]
    assert not unmapped, unmapped


def test_verification_md_holds_the_plan():
    text = (REPO / "docs/verification.md").read_text()
    assert BEGIN in text and END in text, "docs/verification.md has no testplan section"
    got = text.split(BEGIN, 1)[1].split(END, 1)[0].strip("\n") + "\n"
    assert got == testplan.render(), "docs/verification.md's testplan is stale: render verif/testplan.py into it"
