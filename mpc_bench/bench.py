"""Benchmark report of the solver cores (`make bench`, `make bench QUICK=1`, `mpc-cores bench`): cycles in
Verilator, Yosys resources, nextpnr Fmax, latency against the papers, and software on this CPU, for every core
kind of the registry selected by --cores.

This is the driver. Each core kind has its section in the module its registry entry names (mpc_cores.registry,
`bench`): mpc_bench.fgm (masses over P and b, and cores pipelined for Fmax), mpc_bench.admm (masses_rate_soft over
P and b, and a small problem for Fmax) and mpc_bench.minres (masses over P, and a small problem for Fmax); their
interface and the order of the steps are in mpc_bench.section. The tools and their cache are mpc_bench.tools, the
record of Yosys and nextpnr results kept in the repository (reused on the same inputs) mpc_bench.store,
the software baselines mpc_bench.baselines and mpc_bench.baselines_minres, the outputs mpc_bench.report and
mpc_bench.plots. A full run of both fgm and dgp ends with the scaling sweep (mpc_bench.scaling) at their placed clocks.

Writes report.md, one CSV per kind (fgm.csv, admm.csv, minres.csv, ..., scaling.csv) and PNG plots into the output
folder (build/bench), and copies report.md to docs/bench/<YYYY-MM-DD>-<full|quick|kinds>.md; a full run of every
kind also to docs/bench/latest.md, the report the docs quote.

    python -m mpc_bench.bench [--quick] [--out build/bench] [--jobs 2] [--cores fgm,admm,minres] [--P 1,2,4,8]
                              [--b 12,16] [--admm-P 1,2,4,8] [--admm-b 18,16] [--admm-small-P 1,2] [--no-xilinx]
                              [--scaling auto|on|off] [--docs docs/bench | --no-docs] [--store F | --no-store]
"""
from __future__ import annotations

import argparse
import datetime
import sys
import time
from pathlib import Path

from mpc_bench import report, store
from mpc_bench.section import Run, run_sections
from mpc_bench.tools import Log
from mpc_cores import registry
from mpc_cores.flow import REPO
from mpc_cores.kind import load


def section_classes() -> dict[str, type]:
    """Core kind -> its Section class, in registry order."""
    return {name: load(kind.bench).Section for name, kind in registry.kinds().items()}


def report_md(cores: list, fgm: list[dict], admm: list[dict], sw: dict, info: dict) -> str:
    """report.md from FGM and ADMM results at hand, without a run: the cores of both kinds, their records and their
    software timings by kind."""
    rows = {"fgm": fgm, "admm": admm}
    sections = [cls().restore([c for c in cores if c.kind == name], rows[name], sw.get(name))
                for name, cls in section_classes().items() if name in rows]
    return report.report_md(sections, info)


def wants_scaling(option: str, quick: bool, selected: set) -> bool:
    """Whether the run ends with the scaling sweep: --scaling on, or auto in a full run of both fgm and dgp"""
    return option == "on" or (option == "auto" and not quick and {"fgm", "dgp"} <= selected)


def main(argv=None) -> None:
    classes = section_classes()
    ap = argparse.ArgumentParser(prog="python -m mpc_bench.bench", description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true",
                    help="FGM P = 1, b = 16; ADMM masses P = 1 (cycles only), small problem P = 1; MINRES P = 1 "
                         "(cycles and software only); no Xilinx; shorter loops")
    ap.add_argument("--out", default=str(REPO / "build/bench"))
    ap.add_argument("--jobs", type=int, default=2, help="parallel simulation/synthesis/place-and-route jobs")
    ap.add_argument("--cores", default=",".join(classes),
                    help=f"which cores to benchmark ({', '.join(classes)})")
    for cls in classes.values():
        cls.add_arguments(ap)
    ap.add_argument("--no-xilinx", action="store_true", help="skip synth_xilinx")
    ap.add_argument("--scaling", choices=("auto", "on", "off"), default="auto",
                    help="the scaling sweep (mpc_bench.scaling) after the sections, at their placed clocks; auto: "
                         "in a full run that selects both fgm and dgp")
    ap.add_argument("--repeats", type=int, default=None,
                    help="replays of the loop per software solver, half before and half after the jobs")
    ap.add_argument("--docs", default=str(REPO / "docs/bench"),
                    help="where the dated copy of report.md and latest.md go (default docs/bench)")
    ap.add_argument("--no-docs", action="store_true", help="no copy of report.md under --docs")
    ap.add_argument("--store", default=str(store.PATH),
                    help="the record of Yosys and nextpnr results by input digest (mpc_bench.store), read and extended "
                         "by the run (default docs/bench/tool-results.jsonl)")
    ap.add_argument("--no-store", action="store_true", help="run every uncached tool step, record nothing")
    a = ap.parse_args(argv)

    t_start = time.perf_counter()
    selected = {k.strip() for k in a.cores.split(",") if k.strip()}
    if not selected <= set(classes):
        sys.exit(f"error: --cores {a.cores}: expected some of {', '.join(classes)}")
    out = Path(a.out).resolve()     # the tools run in per-core folders
    (out / "cores").mkdir(parents=True, exist_ok=True)
    log = Log()
    info = {"date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
            "machine": report.machine(), "quick": a.quick, "xilinx": not (a.quick or a.no_xilinx), "jobs": a.jobs,
            "errors": [], "sw_seconds": {}, "kinds": sorted(selected), "complete": selected == set(classes)}
    st = store.use(None if a.no_store else Path(a.store))
    run = Run(a, out, log, info)
    sections = [cls(run) for name, cls in classes.items() if name in selected]
    if wants_scaling(a.scaling, a.quick, selected):
        from mpc_bench import scaling
        sections.append(scaling.Section(run, sections))
    m = info["machine"]
    log("; ".join([f"bench on {m['cpu']}, {m['cores']} cores"] + [t for t in (s.log_text() for s in sections) if t]
                  + [f"Xilinx synthesis {'on' if info['xilinx'] else 'off'}"]))

    run_sections(sections, run)
    info["runtime_s"] = time.perf_counter() - t_start
    info["store"] = st.summary() if st is not None else "no result store (--no-store)"
    if st is not None:
        log(info["store"])
    path = report.write_outputs(out, sections, info, log)
    if not a.no_docs:
        dated = report.publish(path, Path(a.docs), info)
        log(f"copied the report to {dated}" + (f" and {dated.parent / 'latest.md'}"
                                                 if report.report_kind(info) == "full" else ""))

    for s in sections:
        lines = s.console_summary()
        if lines and not s.appendix:
            print("\n" + "\n".join(lines))
    fast = report.fmax_entries(sections)
    if fast:
        print("\nFmax with pipelining\n" + "\n".join(report.fmax_table(fast)))
    for s in sections:
        lines = s.console_summary()
        if lines and s.appendix:
            print("\n" + "\n".join(lines))
    print(f"\n{'QUICK' if a.quick else 'full'} bench: {info['runtime_s'] / 60:.1f} min")
    if info["errors"]:
        print("\nfailed steps:\n  " + "\n  ".join(info["errors"]))
        sys.exit(1)


if __name__ == "__main__":
    main()
