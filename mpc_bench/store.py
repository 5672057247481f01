"""The bench's record of Yosys and nextpnr results, kept in the repository (docs/bench/tool-results.jsonl).

Synthesis and place and route are deterministic: the same SystemVerilog, script, constraints, options, seed and tool
versions give the same cells, Fmax and critical path on any machine. mpc_bench.tools keys every step by a digest of
exactly these inputs (its build-folder cache uses the same keys); this store keeps, per key, what the bench reads
from the step's outputs: the cell counts and memory mapping of a Yosys run, the parsed report of a nextpnr run (or
{"seed", "unrouted_s"}: not routed within that time limit, mpc_bench.tools.route_limit_s). A
bench run takes a step's result from here when the key matches and records every result it obtains, so the place
and route of an unchanged core is done once, and a full run on a fresh clone redoes only what changed. The report's
header says how many results came from the store. A run with --no-store neither reads nor writes it; changed inputs
(a new generator output, another tool version) have another key, and the entry is not used.

One JSON object per line: {"key", "step" (yosys_ecp5, yosys_xc7, nextpnr), "core" (the bench's tag, for a reader),
"seed" (nextpnr), "result"}. `harvest` records the finished steps of an earlier (even interrupted) run's folder:

    python -m mpc_bench.store [build/bench] [--store docs/bench/tool-results.jsonl]
"""
from __future__ import annotations

import argparse
import json
import threading
from pathlib import Path

from mpc_cores.flow import REPO

PATH = REPO / "docs/bench/tool-results.jsonl"


class Store:
    """The entries of one store file, read once; get() counts the reuses, put() appends what is new."""

    def __init__(self, path: Path):
        self.path = Path(path)
        self.lock = threading.Lock()
        self.entries: dict[str, dict] = {}
        self.reused = self.recorded = 0
        if self.path.exists():
            for line in self.path.read_text().splitlines():
                if line.strip():
                    e = json.loads(line)
                    self.entries[e["key"]] = e

    def get(self, key: str) -> dict | None:
        with self.lock:
            e = self.entries.get(key)
            if e is not None:
                self.reused += 1
            return None if e is None else e["result"]

    def peek(self, key: str) -> dict | None:
        """The result under `key`, not counted as taken."""
        e = self.entries.get(key)
        return None if e is None else e["result"]

    def has(self, key: str) -> bool:
        return key in self.entries

    def put(self, key: str, step: str, core: str, result: dict, seed: int | None = None) -> None:
        e = {"key": key, "step": step, "core": core, **({} if seed is None else {"seed": seed}), "result": result}
        line = json.dumps(e, sort_keys=True)
        with self.lock:
            old = self.entries.get(key)
            if old is not None and _sans_label(old) == _sans_label(json.loads(line)):
                return      # the same result (the core's label may differ: a harvest names it by its folder)
            self.entries[key] = json.loads(line)
            self.recorded += 1
            self.path.parent.mkdir(parents=True, exist_ok=True)
            if old is None:
                with self.path.open("a") as f:
                    f.write(line + "\n")
            else:   # a different result under a known key: the tools are not deterministic, or the file was edited
                self.path.write_text("".join(json.dumps(v, sort_keys=True) + "\n" for v in self.entries.values()))

    def summary(self) -> str:
        return (f"{self.reused} Yosys/nextpnr result(s) taken from {_shown(self.path)} (same input digest), "
                f"{self.recorded} recorded there")


def _sans_label(e: dict) -> dict:
    return {k: v for k, v in e.items() if k != "core"}


_active: Store | None = None


def use(path: Path | None) -> Store | None:
    """Make `path` the store of this process (None: no store, the default outside a bench run)."""
    global _active
    _active = None if path is None else Store(path)
    return _active


def active() -> Store | None:
    return _active


def holds(key: str) -> bool:
    """Whether this process's store (if any) has a result under `key`."""
    return _active is not None and _active.has(key)


def _shown(p: Path) -> str:
    try:
        return str(Path(p).resolve().relative_to(REPO))
    except ValueError:
        return str(p)


def harvest(root: Path, st: Store) -> int:
    """Record the finished Yosys and nextpnr steps found under `root` (a bench output folder): every step folder
    whose key file matches its outputs. Returns how many entries were new or changed."""
    from mpc_bench.parsers import parse_memory_mapping, parse_nextpnr_report, parse_yosys_stat
    from mpc_bench.harness import core_cells

    before = st.recorded
    for kf in sorted(Path(root).rglob("yosys.key")):
        d = kf.parent
        stat, ylog = d / "stat.txt", d / "yosys.log"
        if d.name not in ("ecp5", "xc7") or not (stat.exists() and ylog.exists()):
            continue
        text = stat.read_text()
        cells = core_cells(text) if (d / "harness.v").exists() else parse_yosys_stat(text)
        st.put(kf.read_text(), f"yosys_{d.name}", d.parent.name,
               {"cells": cells, "mem": parse_memory_mapping(ylog.read_text())})
    for kf in sorted(Path(root).rglob("nextpnr*.key")):
        d, sfx = kf.parent, kf.stem[len("nextpnr"):]
        report = d / f"nextpnr_report{sfx}.json"
        if not report.exists():
            continue
        seed = int(sfx[2:]) if sfx.startswith("_s") else 1
        st.put(kf.read_text(), "nextpnr", d.parent.name,
               dict(parse_nextpnr_report(json.loads(report.read_text())), seed=seed), seed=seed)
    for mf in sorted(Path(root).rglob("nextpnr*.unrouted")):     # runs stopped at their time limit
        r = json.loads(mf.read_text())
        st.put(r.pop("key"), "nextpnr", mf.parent.parent.name, r, seed=r["seed"])
    return st.recorded - before


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(prog="python -m mpc_bench.store", description=__doc__.split("\n\n")[0])
    ap.add_argument("root", nargs="?", default=str(REPO / "build/bench"), help="a bench output folder")
    ap.add_argument("--store", default=str(PATH))
    a = ap.parse_args(argv)
    if not Path(a.root).is_dir():
        raise SystemExit(f"error: {a.root}: not a folder (the --out of a bench run)")
    st = Store(Path(a.store))
    n = harvest(Path(a.root), st)
    print(f"{n} result(s) recorded in {a.store} ({len(st.entries)} in all)")


if __name__ == "__main__":
    main()
