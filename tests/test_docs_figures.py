"""Every measured figure the README and the reference docs quote comes from a benchmark report kept in docs/bench/:
a clock, time or latency written with a decimal point (217.2 MHz, 0.48 us, 7.68 ns; round numbers are targets and
limits) in README.md or docs/*.md appears in one of the reports. docs/history/ tells how figures were reached and is
not checked."""
from __future__ import annotations

import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
FIGURE = re.compile(r"(?<![\w.])(\d[\d,]*\.\d+)\s*(MHz|µs|us|ns|ms)\b")


def test_quoted_figures_are_in_a_bench_report():
    reports = "\n".join(p.read_text() for p in sorted((REPO / "docs/bench").glob("*.md")))
    numbers = set(re.findall(r"(?<![\d.])\d[\d,]*(?:\.\d+)?(?![\d])", reports))
    assert len(numbers) > 100
    missing = []
    for page in [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]:
        for i, line in enumerate(page.read_text().splitlines(), 1):
            for m in FIGURE.finditer(line):
                if m.group(1) not in numbers and m.group(1).replace(",", "") not in numbers:
                    missing.append(f"{page.relative_to(REPO)}:{i}: {m.group(0)}")
    assert not missing, "figures in no report under docs/bench:\n" + "\n".join(missing)
