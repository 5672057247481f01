"""The interface of one core kind's part of the benchmark, and the steps the driver runs on it.

Each core kind has its section in the module its registry entry names (`bench`, e.g. mpc_bench.fgm): a class
`Section` derived from `Section` below. The driver (mpc_bench.bench) loads the module of every kind, lets each add
its command-line options, makes one section per kind selected by --cores and runs them through `run_sections`:

  Section.add_arguments(ap)   the kind's command-line options (added for every kind, before parsing)
  Section(run)                one per selected kind; reads its options from run.args (configure)
  plan()                      designs and cores (self.cores); refusals go to self.error
  prepare_software()          the software baselines' problems, before any hardware job
  time_software(half)         software timing, "before" and "after" the hardware jobs
  (generation)                the driver elaborates self.cores (mpc_bench.tools.generate);
                              generation_failed(e) says what a failure means for the kind
  jobs() -> [Job]             the tool steps on the generated cores; the jobs of all kinds run on one pool,
                              wave by wave
  finish()                    self.rows: one record per core, the CSV rows and the source of every table

and for the outputs (mpc_bench.report, mpc_bench.plots): csv_name, log_text(), run_text(info), summary_md(),
fmax_rows() with label/eq and fmax_note() (the shared table of cores pipelined for Fmax), section_md() (the
kind's part of report.md), appendix_md() (a self-contained part after the shared tables), console_summary(),
plots(plt, out), plot_fmax(ax). Every hook has a default that contributes nothing, so a kind implements what it
has. Adding a kind takes its mpc_bench/<kind>.py and its registry line.
"""
from __future__ import annotations

import argparse
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from mpc_bench.tools import Job, generate, hardware_revision, run_jobs


@dataclass
class Run:
    """What the sections of one bench run share: the parsed options, the output folder, the log and `info`, the
    run's facts for the report (date, machine, quick, xilinx, jobs, errors, sw_seconds, revision, runtime_s, and
    what each section adds for its line of the report's header)."""
    args: argparse.Namespace
    out: Path
    log: Callable[[str], None]
    info: dict


class Section:
    name = ""                    # the core kind (registry name)
    label = ""                   # its name in tables ("FGM")
    eq: int | None = None        # the equation of its cycles per iteration, for the table of pipelined cores
    appendix = False             # True: a self-contained part after the shared tables (own step times and errors)
    plot_files: tuple = ()       # the PNG files its plots() writes (named in the report)

    def __init__(self, run: Run | None = None):
        self.run = run
        self.cores: list = []
        self.rows: list[dict] = []
        self.sw: dict | None = None
        self.errors: list[str] = []
        self.elapsed = 0.0       # seconds of the run spent on this kind (its steps and its share of the job waves)
        if run is not None:
            self.configure(run.args)

    @staticmethod
    def add_arguments(ap: argparse.ArgumentParser) -> None:
        """The kind's command-line options."""

    def configure(self, a: argparse.Namespace) -> None:
        """Read the kind's options (and add what the report's header says about them to self.run.info)."""

    def restore(self, cores: list, rows: list[dict], sw: dict | None) -> Section:
        """The section with results at hand (no run): for the report alone."""
        self.cores, self.rows, self.sw = cores, rows, sw
        return self

    @property
    def csv_name(self) -> str:
        return f"{self.name}.csv"

    def log(self, msg: str) -> None:
        if self.run is not None:
            self.run.log(msg)

    def error(self, msg: str) -> None:
        """A failed step: listed in the report (the shared list and the kind's own)."""
        self.errors.append(msg)
        if self.run is not None:
            self.run.info["errors"].append(msg)

    # ------------------------------------------------------------------------------------- steps

    def plan(self) -> None:
        pass

    def prepare_software(self) -> None:
        pass

    def time_software(self, half: str) -> None:
        pass

    def generation_failed(self, e: Exception) -> None:
        raise SystemExit(f"error: generating the cores failed: {e}")

    def jobs(self) -> list[Job]:
        return []

    def finish(self) -> None:
        pass

    # ------------------------------------------------------------------------------------- outputs

    def log_text(self) -> str:
        return ""

    def run_text(self, info: dict) -> str | None:
        return None

    def summary_md(self) -> list[str]:
        return []

    def fmax_rows(self) -> list[dict]:
        return []

    def fmax_note(self) -> str | None:
        return None

    def section_md(self) -> list[str]:
        return []

    def appendix_md(self) -> list[str]:
        return []

    def console_summary(self) -> list[str]:
        return []

    def plots(self, plt, out: Path) -> list[Path]:
        return []

    def plot_fmax(self, ax) -> tuple[list[int], list, list[tuple]] | None:
        """Draw the kind's cores on the Fmax-vs-P plot: (P values drawn, Fmax targets of its rows, reference lines
        (MHz, colour, label)), or None when it has nothing there."""
        return None


def ints(s: str | None, default: tuple) -> tuple:
    """A comma-separated option as a tuple of ints (the default when not given)."""
    return tuple(int(v) for v in s.split(",")) if s else default


def _timed(sec: Section, step: str, *args):
    t = time.perf_counter()
    try:
        return getattr(sec, step)(*args)
    finally:
        sec.elapsed += time.perf_counter() - t


def run_sections(sections: list[Section], run: Run) -> None:
    """The steps of the benchmark on the sections, in this order: plan, software problems, software timing,
    generation, the tool jobs of all sections (wave by wave, `run.args.jobs` in parallel, longest first),
    software timing again, records."""
    for sec in sections:
        _timed(sec, "plan")
    # Software timing while none of the bench's own jobs run: before them and again after them.
    for sec in sections:
        _timed(sec, "prepare_software")
    for sec in sections:
        _timed(sec, "time_software", "before")
    run.info["revision"] = hardware_revision()
    for sec in sections:
        t = time.perf_counter()
        try:
            generate(sec.cores, run.log)
        except Exception as e:  # the generator's own message says what it refused
            sec.generation_failed(e)
        sec.elapsed += time.perf_counter() - t
    jobs = []
    for sec in sections:
        for job in _timed(sec, "jobs"):
            job.owner = sec
            jobs.append(job)
    for wave in sorted({j.wave for j in jobs}):
        batch = [j for j in jobs if j.wave == wave]
        t0 = time.perf_counter()
        for job, msg in run_jobs(batch, run.args.jobs, run.log):
            job.owner.error(msg)
        for sec in sections:
            ends = [j.finished for j in batch if j.owner is sec and j.finished is not None]
            if ends:
                sec.elapsed += max(ends) - t0
    for sec in sections:
        _timed(sec, "time_software", "after")
    for sec in sections:
        _timed(sec, "finish")
