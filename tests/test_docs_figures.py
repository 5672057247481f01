"""Every measured figure the README and the reference docs quote comes from the full `make bench` report,
docs/bench/latest.md (a copy of the newest docs/bench/<date>-full.md): a clock, time or latency written with a
decimal point (217.2 MHz, 0.48 us, 7.68 ns; round numbers are targets and limits) in README.md or docs/*.md appears
in it. docs/history/ tells how figures were reached and is not checked."""
from __future__ import annotations

import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
FIGURE = re.compile(r"(?<![\w.])(\d[\d,]*\.\d+)\s*(MHz|µs|us|ns|ms)\b")


def test_latest_is_the_newest_full_run():
    latest = (REPO / "docs/bench/latest.md").read_text()
    full = sorted((REPO / "docs/bench").glob("*-full.md"))
    assert full, "no full make bench report in docs/bench"
    assert latest == full[-1].read_text(), f"docs/bench/latest.md is not {full[-1].name}"
    assert re.search(r"^Run: full\b", latest, re.M)


def test_quoted_figures_are_in_the_full_report():
    report = (REPO / "docs/bench/latest.md").read_text()
    numbers = set(re.findall(r"(?<![\d.])\d[\d,]*(?:\.\d+)?(?![\d])", report))
    assert len(numbers) > 100
    missing = []
    for page in [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]:
        for i, line in enumerate(page.read_text().splitlines(), 1):
            for m in FIGURE.finditer(line):
                if m.group(1) not in numbers and m.group(1).replace(",", "") not in numbers:
                    missing.append(f"{page.relative_to(REPO)}:{i}: {m.group(0)}")
    assert not missing, "figures not in the full report docs/bench/latest.md:\n" + "\n".join(missing)
