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


def test_kind_sources_are_its_package_its_imports_and_the_shared_blocks():
    """A kind's digest covers its Scala package, the kinds' packages it imports and every shared package, and no
    other kind's package: ama and vucondat share admm's sources, ipm includes minres (its linear solver)."""
    def pkgs(kind):
        return {f.parent.name for f in kind_sources(kind) if f.suffix == ".scala"}
    shared = pkgs("fgm") - {"fgm"}
    assert {"bus", "shell", "mem", "fixed"} <= shared and not shared & {"admm", "dgp", "minres", "ipm"}
    assert pkgs("admm") == shared | {"admm"} and kind_sources("ama") == kind_sources("admm")
    assert pkgs("ipm") == shared | {"ipm", "minres"} and pkgs("dgp") == shared | {"dgp"}
    assert kind_digest("ama") == kind_digest("vucondat") != kind_digest("fgm")


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
