"""What the sections of the QP solver cores of 002 (FGM, mpc_bench.fgm; ADMM, mpc_bench.admm) share: the core
record, the software baselines over one closed loop (timed half before and half after the hardware jobs), the
tool steps (cycle contract in Verilator, Yosys ECP5 with nextpnr, Yosys xc7), and their report's common cells
(resources, memories, Fmax and critical path, software solvers)."""
from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mpc_bench.baselines import SwCase, merge_software, time_software
from mpc_bench.parsers import ECP5_85F
from mpc_bench.report import _f, _table, latency_us, pnr_cells
from mpc_bench.section import Section
from mpc_bench.tools import Job, ToolResults, run_cycle_test, seeds_phrase, synth_ecp5_and_pnr, synth_xc7

# The clocks of Table III of 002 (Virtex-6, Spartan-6).
F_V6_MHZ, F_S6_MHZ = 400.0, 230.0
REFERENCE_CLOCKS = [(F_V6_MHZ, "tab:red", "002: Virtex-6 400 MHz"), (F_S6_MHZ, "tab:purple", "002: Spartan-6 230 MHz")]


@dataclass
class Core(ToolResults):
    kind: str                    # the core kind ("fgm", "admm")
    problem: str                 # spec name
    P: int
    b: int
    out: Path
    design: object               # what the generator elaborates
    imax: int                    # the spec's Imax: cycles per solve are reported there
    role: str = "sweep"          # "sweep": the paper's example at the spec's latencies; "fmax": pipelined for Fmax
    synth: bool = True           # False: cycles only (QUICK's masses ADMM core)

    @property
    def tag(self) -> str:
        la, lm = (getattr(self.design, k, self.core.get(k)) for k in ("lat_add", "lat_mul"))
        lat = f" lA={la} lM={lm}" if self.role == "fmax" else ""
        kp = getattr(self.design, "problems", 1)
        copies = f" x{self.copies} cores" if self.copies > 1 else ""
        return f"{self.kind.upper()} {self.problem} P={self.P}{f' Kp={kp}' if kp > 1 else ''} b={self.b}{lat}{copies}"

    @property
    def placeable(self) -> bool:
        """False when the core (its copies together) needs more multiplier blocks than the LFE5U-85F has whatever
        Yosys makes of its products (one block each at least)."""
        return self.design.multipliers * self.copies <= ECP5_85F["MULT18X18D"]

    @property
    def hierarchical(self) -> bool:
        """Whether Yosys keeps the hierarchy (for resources only); a kind's core class says when."""
        return False


def measure_cycles(c: Core, log) -> None:
    """Cycles per iteration and per solve of the core in Verilator (cocotb test cycle_contract)."""
    c.measured = run_cycle_test(c, "cycle_contract")[-1]
    log(f"{c.tag}: measured {c.measured['cycles_per_iteration']} cycles/iteration, "
        f"{c.measured['cycles_per_solve']} cycles/solve at Imax = {c.measured['iterations']} "
        f"({c.seconds['verilator']:.0f} s)")


class QpSection(Section):
    """A QP solver core of 002 over P and b: `designs` (b -> design of the sweep) feed the software case, every core
    gets its cycle contract measured, ECP5 synthesis with place and route where it fits, xc7 synthesis for the
    sweep; the software solvers' medians are set against the cores' latencies."""

    def __init__(self, run=None):
        self.designs: dict = {}
        self.case: SwCase | None = None
        self.halves: list = []
        super().__init__(run)

    def configure(self, a) -> None:
        self.quick = a.quick
        self.xilinx = not (a.quick or a.no_xilinx)
        self.repeats = a.repeats or (4 if a.quick else 6)
        self.design_dir = self.run.out / "designs"

    def software_case(self) -> SwCase:
        raise NotImplementedError

    def prepare_software(self) -> None:
        if not self.designs:
            return
        t = time.perf_counter()
        try:
            self.case = self.software_case()
        except Exception as e:
            self.error(f"{self.name.upper()} software loop: {e}")
            self.log(f"FAILED {self.name.upper()} software loop: {e}")
        self.run.info["sw_seconds"][f"{self.name} loop and references"] = time.perf_counter() - t

    def time_software(self, half: str) -> None:
        if self.case is None:
            return
        t, res = time.perf_counter(), None
        try:
            res = time_software(self.case, -(-self.repeats // 2), self.run.log)
        except Exception as e:
            self.error(f"{self.name.upper()} software timing: {e}")
            self.log(f"FAILED {self.name.upper()} software timing: {e}")
        key = f"{self.name} timing"
        self.run.info["sw_seconds"][key] = self.run.info["sw_seconds"].get(key, 0.0) + time.perf_counter() - t
        self.halves.append(res)

    def job_costs(self, c: Core) -> tuple[float, float, float]:
        """Rough seconds of (Verilator, Yosys ECP5 and nextpnr, Yosys xc7) on the core, for longest-first
        scheduling."""
        return (30, 60, 40)

    def jobs(self) -> list[Job]:
        log, out = self.run.log, []
        for c in self.cores:
            costs = self.job_costs(c)
            out.append(Job(costs[0], f"{c.tag} verilator", lambda c=c: measure_cycles(c, log)))
            if not c.synth:
                c.pnr_note = "not synthesised in QUICK"
                continue
            out.append(Job(costs[1], f"{c.tag} ecp5", lambda c=c: synth_ecp5_and_pnr(c, log)))
            if self.xilinx and c.role == "sweep":
                out.append(Job(costs[2], f"{c.tag} xc7", lambda c=c: synth_xc7(c, log)))
        return out

    def make_rows(self) -> list[dict]:
        raise NotImplementedError

    def finish(self) -> None:
        halves = self.halves + [None, None]
        merged = merge_software(halves[0], halves[1])
        self.sw = dict(merged, **self.case.meta) if merged and self.case is not None else None
        self.rows = self.make_rows()


def _core_latency(c: Core, cycles: int) -> float | None:
    return latency_us(cycles, c.pnr["fmax_mhz"]) if c.pnr else None


def _mem_name(mem: str, module: str) -> str:
    """'Top.bndRam_0.mem' or 'Top_mat0.mem' -> 'bndRam_0' or 'mat0'."""
    name = mem.removesuffix(".mem").split(".")[-1]
    return name.removeprefix(module + "_")


def _resource_cells(r: dict) -> list[str]:
    """mult. ours (Table I), MULT18X18D / DSP48E1, LUT4 / LUT, FF ECP5 / xc7."""
    return [f"{r['multipliers']} ({r['multipliers_table1']})",
            f"{_f(r.get('ecp5_MULT18X18D'), '{}')} / {_f(r.get('xc7_DSP48E1'), '{}')}",
            f"{_f(r.get('ecp5_LUT4'), '{}')} / {_f(r.get('xc7_LUT'), '{}')}",
            f"{_f(r.get('ecp5_FF'), '{}')} / {_f(r.get('xc7_FF'), '{}')}"]



def _mem_list(mems: dict[str, str], module: str) -> str:
    """'mat0 -> PDPW16KD, ...'; memories Yosys names after a source location (no RTL name) counted per kind."""
    named, unnamed = [], {}
    for k, v in sorted(mems.items()):
        name = _mem_name(k, module)
        if "$" in name:
            unnamed[v] = unnamed.get(v, 0) + 1
        else:
            named.append(f"{name} -> {v}")
    return ", ".join(named + [f"{n} unnamed -> {v}" for v, n in sorted(unnamed.items())])


def _memories(cores: list[Core]) -> list[str]:
    L = []
    for c in cores:
        if c.ecp5_mem or c.xc7_mem:
            e, x = _mem_list(c.ecp5_mem, c.module), _mem_list(c.xc7_mem, c.module)
            L.append(f"- {c.tag}: ECP5 {e or '-'}; xc7 {x or '-'}")
    return L


def _fmax_section(cores: list[Core], recs: list[dict], lpf: str) -> list[str]:
    tgt = next((r["fmax_target_mhz"] for r in recs if r["fmax_target_mhz"]), None)
    L = [f"Constraint from constraints/{lpf} (`--freq {_f(tgt, '{:g}')}`), {seeds_phrase(cores)}, "
         "`--lpf-allow-unconstrained`: the LPF sets the clock and the I/O standard (LVCMOS33) but no pin sites, "
         "so nextpnr places the AXI pins itself (the Fmax below is register to register; nextpnr-ecp5 has no I/O "
         "timing constraints). \"units in rows\": each row unit's multipliers and block RAMs pinned to a row of "
         "their own (mpc_bench.floorplan).", ""]
    body = []
    for c, r in zip(cores, recs):
        kp = getattr(c.design, "problems", 1)
        head = [c.problem, str(r["n"]), str(c.P) + (f", K_p = {kp}" if kp > 1 else "")
                + (", units in rows" if c.floorplan else ""), str(c.b)]
        body.append(head + pnr_cells(c, _f(r["ecp5_TRELLIS_COMB_pnr"], "{}") if c.pnr else "-"))
    L += _table(["problem", "n", "P", "b", "Fmax MHz", "TRELLIS_COMB", "critical path (register to register)",
                 "logic cells", "ns"], body)
    for c in cores:
        cp = (c.pnr or {}).get("critical_path")
        if cp and c.pnr["fmax_mhz"] < c.pnr["target_mhz"]:
            L += ["", f"{c.tag}: {c.pnr['fmax_mhz']:.1f} MHz, below the {c.pnr['target_mhz']:g} MHz constraint. "
                  f"Critical path {cp['from']} -> {cp['to']}, {cp['logic_levels']} logic cells ("
                  + ", ".join(f"{v} {k}" for k, v in cp["kinds"].items()) + "); RTL signals named on it: "
                  + ", ".join(cp["signals"]) + f"; longest net {cp['max_net'][1]} ({cp['max_net'][0]:.2f} ns). "
                  "Nets:", "", "    " + "\n    ".join(cp["nets"])]
    return L


def _software_solvers(sw: dict) -> list[str]:
    body = []
    for r in sw["solvers"]:
        it = f"{np.median(r.iters):.0f} / {max(r.iters)}" if r.iters else f"{sw['imax']} / {sw['imax']}"
        body.append([r.name, f"{r.median_us:.1f}", f"{np.percentile(r.times_us, 90):.1f}",
                     f"{r.times_us.max():.1f}", it, f"{r.u_err:.2e}", _f(r.u_err_median, "{:.2e}"), r.settings])
    return _table(["solver", "median us", "p90 us", "max us", "iterations median / max", "error max",
                   "error median", "settings"], body)


def _load_text(sw: dict) -> str:
    return (" (1-minute load average " + " and ".join(f"{v:.2f}" for v in sw["load"] if v is not None) + ")"
            if isinstance(sw.get("load"), list) else "")

