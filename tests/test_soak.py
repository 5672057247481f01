"""`make soak` in short: 100 random solves per core kind on a random configuration of each kind, word for word
against the golden models in Verilator, with no mismatch and no hang; the report and its JSON; a hang and a
mismatch classified as such; every kind's random space mostly accepted by its design flow.

One configuration per kind keeps the Verilator builds (most of the time) to four; they stay under build/tests/soak
(the same seed draws the same configurations: a second run reuses them)."""
from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from conftest import case_params
from mpc_cores import registry
from mpc_cores.errors import DesignError, SpecError
from mpc_cores.flow import REPO
from mpc_cores.kind import load
from mpc_cores.problem import problem_from_dict
from mpc_cores.soak.report import totals
from mpc_cores.soak.run import out_dir, run, simulate

BUILD = REPO / "build" / "tests" / "soak"
SOLVES, PER_CONFIG, SEED = 100, 100, 7


@pytest.fixture(scope="module")
def soaked(tmp_path_factory):
    """kind -> (Soak, report folder), each kind soaked once on first use."""
    done = {}

    def get(name):
        if name not in done:
            out = tmp_path_factory.mktemp(f"soak_{name}")
            done[name] = run(name, SOLVES, SEED, PER_CONFIG, out, keep_builds=True, build=BUILD), out
        return done[name]
    return get


# the splitting methods on the ADMM datapath (ama, vucondat) run ADMM's soak with their method set; their RTL is in
# the ADMM suite (tests/conftest.py ADMM_CASES), so the short soak runs once for the datapath
SOAKED = [n for n in registry.names() if registry.get(n).generator_main != "admm.AdmmMain" or n == "admm"]


# `make test` soaks the FGM datapath (the hang and mismatch test below uses its run); the other kinds' short soaks,
# whose RTL their own suites check word for word, run with `make test-slow` (and `make soak`)
SLOW = {"minres", "ipm", "dgp", "admm"}


@pytest.mark.parametrize("name", case_params(SOAKED, SLOW))
def test_short_soak(name, soaked):
    s, out = soaked(name)
    t = totals(s)
    failed = [(o.index, o.status, o.reason[:300]) for o in s.outcomes if o.failed]
    assert not failed, failed
    assert t["solves"] >= SOLVES and t["simulated"] >= 1
    assert t["mismatch"] == t["hang"] == t["error"] == 0
    rec = json.loads((out / f"{name}.json").read_text())
    assert rec["finished"] and rec["seed"] == SEED and rec["totals"]["solves"] == t["solves"]
    assert len(rec["configurations"]) == t["configurations"] and rec["space"]
    for c in rec["configurations"]:   # a configuration's spec and design keywords, and its seed, are kept
        assert {"spec", "design"} <= set(c["config"]) and c["seed"] // 10**6 == SEED
    md = (out / f"{name}.md").read_text()
    assert f"# Soak: {name}" in md and "## Random space" in md and "## Failures" in md and "\nNone.\n" in md
    assert f"| {t['configurations']} | {t['simulated']} | {t['refused']} | {t['solves']} | 0 | 0 | 0 |" in md


def test_hang_and_mismatch_are_reported(soaked):
    """The first FGM configuration again: with a simulated-time limit far below its solves' cycles it is a hang;
    with its golden model's data changed (one coefficient of A) a mismatch."""
    s, _ = soaked("fgm")
    kind = registry.get("fgm")
    o = dataclasses.replace(next(x for x in s.outcomes if x.status == "passed"))
    out = out_dir(BUILD, kind, o)
    core = json.loads((out / "core.json").read_text())
    simulate(kind, o, core, 20, BUILD, keep=True, timeout_ms=0.002)
    assert o.status == "hang" and "SimTimeoutError" in o.reason and o.solves == 0
    cfg_text = (out / "config.json").read_text()
    cfg = json.loads(cfg_text)
    cfg["A"][0][0] += 1 << (cfg["frac_bits"] - 2)
    try:
        (out / "config.json").write_text(json.dumps(cfg))
        simulate(kind, o, core, 20, BUILD, keep=True)
    finally:
        (out / "config.json").write_text(cfg_text)
    assert o.status == "mismatch" and "!= model" in o.reason and o.solves == 0


@pytest.mark.parametrize("name", registry.names())
def test_random_space_mostly_accepted(name):
    """Most random configurations of each kind are designs its flow accepts (a refusal is not a failure, but a
    space of refusals soaks nothing)."""
    kind = registry.get(name)
    space = load(kind.soak)
    ok = 0
    for i in range(30):
        cfg = space.draw(np.random.default_rng(1000 + i))
        try:
            load(kind.design_fn)(problem_from_dict(cfg.spec), **cfg.design)
            ok += 1
        except (DesignError, SpecError):
            pass
    assert ok >= 27, f"{name}: {ok} of 30 random configurations accepted"
