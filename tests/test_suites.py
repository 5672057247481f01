"""No kind of the registry is left out of the per-kind protocol suites: tests/test_fuzz.py, tests/test_regmap.py and
tests/test_assertions.py run every kind of mpc_cores.registry, or the kind is excluded from that suite with a reason
(conftest.SUITE_EXCLUSIONS); the fuzz and the assertion tests find its adapter (CoreKind.fuzz,
verif/<kind>/fuzz.py), and each kind has a violation forced into it. Cheap: no core is generated."""
from __future__ import annotations

import re
import subprocess
import sys

import pytest

import test_assertions
import test_fuzz
import test_regmap
from conftest import SUITE_EXCLUSIONS
from mpc_cores import registry
from mpc_cores.flow import REPO
from verif.fuzz import kinds
from verif.fuzz.violations import MESSAGES

SUITES = {"fuzz": test_fuzz.KINDS, "regmap": test_regmap.KINDS, "assertions": test_assertions.KINDS}


@pytest.mark.parametrize("suite", SUITES)
def test_every_kind_runs_or_has_a_reason(suite):
    ran = list(SUITES[suite])
    excluded = {k: why for (s, k), why in SUITE_EXCLUSIONS.items() if s == suite}
    assert len(set(ran)) == len(ran), f"{suite}: a kind twice: {ran}"
    assert not set(ran) & set(excluded), f"{suite}: excluded and run: {set(ran) & set(excluded)}"
    missing = set(registry.names()) - set(ran) - set(excluded)
    assert not missing, f"{suite}: registry kinds neither run nor excluded with a reason: {sorted(missing)}"
    assert set(ran) | set(excluded) == set(registry.names()), f"{suite}: kinds not in the registry"
    for k, why in excluded.items():
        assert isinstance(why, str) and why.strip(), f"{suite}: {k} excluded without a reason"


# the tests of each suite that run once per kind (their parameter ids start with the kind)
PER_KIND = {"fuzz": ("test_protocol_fuzz",),
            "regmap": ("test_outputs_named_in_core_json", "test_rdl_agrees_with_core_json",
                       "test_region_addresses_follow_the_documented_layout", "test_c_header_compiles_with_the_offsets",
                       "test_ipxact_names_the_registers", "test_regmap_doc", "test_readback_over_axi"),
            "assertions": ("test_assertions_outside_synthesis", "test_violation_stops_the_simulation")}
FILES = {"fuzz": "tests/test_fuzz.py", "regmap": "tests/test_regmap.py", "assertions": "tests/test_assertions.py"}


def test_collected_suites_run_every_kind():
    """What pytest collects (as `make test` selects it) runs each per-kind test on every kind not excluded."""
    p = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q", "-p", "no:cacheprovider",
                        *FILES.values()], cwd=REPO, capture_output=True, text=True)
    assert p.returncode == 0, p.stdout[-2000:] + p.stderr[-2000:]
    ran: dict[tuple[str, str], set[str]] = {}
    for line in p.stdout.splitlines():
        m = re.fullmatch(r"tests/test_(\w+)\.py::(\w+)\[([^\]-]+)[^\]]*\]", line.strip())
        if m:
            ran.setdefault((m[1], m[2]), set()).add(m[3])
    for suite, fns in PER_KIND.items():
        want = set(registry.names()) - {k for (s, k) in SUITE_EXCLUSIONS if s == suite}
        for fn in fns:
            got = ran.get((suite, fn), set())
            assert got == want, \
                f"{FILES[suite]}::{fn} runs {sorted(got)}, the registry less exclusions is {sorted(want)}"


@pytest.mark.parametrize("kind", test_fuzz.KINDS)
def test_fuzzed_kind_has_an_adapter(kind):
    f = kinds.family(kind)
    assert issubclass(f.adapter, kinds.Kind)


@pytest.mark.parametrize("kind", test_assertions.KINDS)
def test_every_kind_has_a_violation(kind):
    vs = kinds.family(kind).violations
    assert vs and set(vs) <= set(MESSAGES), (kind, vs)
    assert {(kind, v) for v in vs} <= set(test_assertions.VIOLATIONS)
