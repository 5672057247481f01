"""The examples gallery (mpc_bench.gallery): every plant of examples/ loads, cites its source and is in
docs/gallery.md; a fast subset of plant x kind pairs runs through the design flow and its check."""
from __future__ import annotations

import re

import pytest

from mpc_bench.gallery import EXAMPLES, markdown, plants, run_pair
from mpc_cores import registry
from mpc_cores.flow import REPO
from mpc_cores.problem import load_spec

# (plant, kind, outcome): a usable pair, a refused section and a pair that fails its check
SUBSET = [("masses", "fgm", "usable"), ("masses_rate_soft", "dgp", "refused"), ("afm_like", "ipm", "fails check")]


def test_the_gallery_has_the_plants_and_each_cites_its_source():
    names = {p.stem for p in plants()}
    assert len(names) >= 6
    for p in plants():
        head = p.read_text().split("\n", 1)[0]
        assert head.startswith("#"), f"{p.name}: the header comment with the source of the numbers comes first"
        load_spec(p)


def test_the_gallery_report_covers_every_plant_and_kind():
    text = (REPO / "docs" / "gallery.md").read_text()
    header = next(ln for ln in text.splitlines() if ln.startswith("| plant | sections |"))
    assert [c.strip() for c in header.strip("|").split("|")][2:] == list(registry.names())
    for p in plants():
        assert re.search(rf"^\| {re.escape(load_spec(p).name)} \|", text, re.M), f"{p.stem} is not in docs/gallery.md"


@pytest.mark.parametrize("plant,kind,outcome", SUBSET)
def test_a_subset_of_pairs(plant, kind, outcome):
    row = run_pair(str(EXAMPLES / f"{plant}.yaml"), kind, gap=1.0, samples=8)
    assert row["outcome"] == outcome, row
    if outcome == "refused":
        assert "would not enforce" in row["why"]
    else:
        assert row["cycles"] > 0 and "gap" in row
    if outcome == "usable":
        assert abs(row["gap"]) <= 1.0 and all(r <= 1e-3 for _, r in row["violations"].values())
    md = markdown([row], 1.0, 20_000, 1.0)
    assert f"| {row['plant']} | {kind} | {outcome}" in md
