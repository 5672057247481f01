"""The soak reports of docs/soak/ against today's generator sources: each report records the commit and the digest
of the generator sources it ran (mpc_cores.soak.report.revision); a report whose digest differs from today's, that
has none (written before the field) or that is missing is stale. Stale reports are named in a warning
(StaleSoakReport, in pytest's warnings summary); they do not fail the suite."""
from __future__ import annotations

import json
import warnings

from mpc_cores.soak.report import kind_digest, kind_sources, revision, staleness, write
from mpc_cores.soak.run import DOCS, Soak, soaked_kinds


class StaleSoakReport(UserWarning):
    """A soak report of docs/soak/ that does not describe today's generator sources."""


def test_stale_soak_reports_are_named():
    stale = staleness(DOCS)
    assert set(stale) <= set(soaked_kinds())
    for kind, why in stale.items():
        warnings.warn(StaleSoakReport(f"docs/soak/{kind}.json is stale: {why}; `make soak CORE={kind}` renews it"))


def test_report_records_what_it_ran(tmp_path):
    """A report (of a soak with no configurations) records the commit, the generator digest and whether the tree was
    dirty; `staleness` finds it current, and stale once its digest is another or missing."""
    s = Soak("fgm", 1, 0, 1, source=revision("fgm"))
    write(s, tmp_path, finished=True)
    rec = json.loads((tmp_path / "fgm.json").read_text())
    assert rec["generator_digest"] == kind_digest("fgm") and isinstance(rec["dirty"], bool)
    assert rec["commit"] and rec["dirty"] == bool(rec["uncommitted"])
    assert f"generator digest {rec['generator_digest'][:12]}" in (tmp_path / "fgm.md").read_text()
    stale = staleness(tmp_path, ["fgm", "admm"])
    assert stale == {"admm": "no report"}
    rec["generator_digest"] = "0" * 64
    (tmp_path / "fgm.json").write_text(json.dumps(rec))
    assert staleness(tmp_path, ["fgm"])["fgm"].startswith("generator sources changed since the soak")
    del rec["generator_digest"]
    (tmp_path / "fgm.json").write_text(json.dumps(rec))
    assert staleness(tmp_path, ["fgm"])["fgm"].startswith("no digest recorded")


def test_kind_sources_are_its_package_and_the_blocks_it_names():
    """A kind's digest covers its Scala package and, transitively, the files defining the classes and objects its
    files name, and no others: the fixed-point kinds leave out the floating-point units and the other kinds'
    packages; ama and vucondat share admm's sources; ipm takes minres (its linear solver) and the float units."""
    from mpc_cores.soak.report import SCALA

    def rel(kind):
        return {f.relative_to(SCALA).as_posix() for f in kind_sources(kind) if f.suffix == ".scala"}
    every = {f.relative_to(SCALA).as_posix() for f in SCALA.rglob("*.scala")}
    for kind, pkg in (("fgm", "fgm"), ("admm", "admm"), ("dgp", "dgp"), ("minres", "minres"), ("ipm", "ipm")):
        own = {f for f in every if f.startswith(pkg + "/")}
        assert own <= rel(kind) and "shell/SolverRegs.scala" in rel(kind) and "gen/Emit.scala" in rel(kind)
    for kind in ("fgm", "admm", "dgp"):
        assert not {f.split("/")[0] for f in rel(kind)} & {"float", "minres", "ipm"}, kind
        assert {"fixed/FixedOps.scala", "linalg/DotProductTree.scala"} <= rel(kind)
    assert not {f.split("/")[0] for f in rel("fgm")} & {"admm", "dgp"}
    assert {"float/FMul.scala", "float/FAdd.scala", "linalg/FDotProduct.scala"} <= rel("minres")
    assert rel("minres") < rel("ipm") and not {f for f in rel("minres") if f.startswith("ipm/")}
    assert kind_sources("ama") == kind_sources("admm") and kind_sources("fgm")[-1].name == "build.sbt"
    assert kind_digest("ama") == kind_digest("vucondat") != kind_digest("fgm")


def test_kind_sources_skip_names_in_comments(tmp_path, monkeypatch):
    """A name in a comment does not pull its file in; a name in code does, and what that file names in turn."""
    import mpc_cores.soak.report as report
    pkg = tmp_path / report.registry.kinds()["fgm"].generator_main.split(".")[0]
    other = tmp_path / "blk"
    pkg.mkdir()
    other.mkdir()
    (pkg / "Core.scala").write_text("package fgm\n// Unused is only mentioned\nclass Core { val a = Used(1) }\n")
    (other / "Used.scala").write_text("package blk\n/* Unused */\ncase class Used(x: Int) { val d = Deep }\n")
    (other / "Deep.scala").write_text("package blk\nobject Deep\n")
    (other / "Unused.scala").write_text("package blk\nclass Unused\n")
    monkeypatch.setattr(report, "SCALA", tmp_path)
    got = {f.name for f in report.kind_sources("fgm")}
    assert got == {"Core.scala", "Used.scala", "Deep.scala", "build.sbt"}


def test_soak_all_runs_every_kind_in_turn(monkeypatch, tmp_path, capsys):
    """`make soak-all` (run_all, its soaks replaced): every kind with a soak space in registry order, at the given
    solves; a kind the design flow stops is reported and the next one runs; the result says whether all passed."""
    import mpc_cores.soak.run as soak_run
    from mpc_cores.errors import DesignError

    ran = []

    def fake(name, solves, seed, per_config, out, keep, max_failures):
        ran.append((name, solves, seed))
        if name == "ipm":
            raise DesignError("refused 50 configurations in a row")
        return Soak(name, seed, solves, 1)

    monkeypatch.setattr(soak_run, "run", fake)
    assert not soak_run.run_all(123, 5, out=tmp_path)
    assert ran == [(k, 123, 5) for k in soaked_kinds()]
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == len(ran) and lines[0].startswith("soak fgm: 0 configurations")
    assert any(ln.startswith("soak ipm: stopped: refused 50") for ln in lines)
    monkeypatch.setattr(soak_run, "run", lambda name, *a: Soak(name, 1, 1, 1))
    assert soak_run.run_all(1, out=tmp_path, kinds=["fgm", "dgp"])
