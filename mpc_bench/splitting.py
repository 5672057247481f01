"""The benchmark of the splitting methods that run on the ADMM core's datapath (004; `method` of
mpc_cores/admm/design.py): AMA (mpc_bench.ama) and Vu-Condat (mpc_bench.vucondat). Each generates the small ADMM
problem of mpc_bench.admm (input-rate limits and a soft state, n_A = 19) with its method at the Fmax latencies
(TARGET=ecp5, l_A = 2, l_M = 5), measures the cycle contract in Verilator (verif/admm/tb.py `cycle_contract`), and
in a full run synthesises it for the LFE5U-85F (Yosys) and places and routes it (nextpnr, three seeds): the part
it fits and the Fmax there. The ADMM section covers the method admm; the comparison of the methods' iterations
is `make methods` (mpc_cores.methods)."""
from __future__ import annotations

import dataclasses
import json

from mpc_bench.admm import FMAX_LAT, SMALL_ADMM, small_admm_problem
from mpc_bench.qp import Core, measure_cycles
from mpc_bench.report import _f, _table
from mpc_bench.section import Section
from mpc_bench.tools import FMAX_SEEDS, Job, cached_design, is_cached, seeds_text, synth_ecp5_and_pnr


class SplittingSection(Section):
    """One method of the splitting family on the ADMM datapath (subclasses set name, label and method)."""
    method = ""
    appendix = True

    def configure(self, a) -> None:
        self.quick = a.quick

    def log_text(self) -> str:
        return f"{self.label}: {SMALL_ADMM['name']} P = 1 ({'Verilator' if self.quick else 'Verilator, Yosys, nextpnr'})"

    def plan(self) -> None:
        from mpc_cores.admm.design import design_admm

        small = small_admm_problem()
        la, lm, tg = FMAX_LAT["lat_add"], FMAX_LAT["lat_mul"], FMAX_LAT["target"]
        d = cached_design(self.run.out / "designs", f"{self.method}_{small.name}_la{la}_lm{lm}_{tg}",
                          (self.method, json.dumps(SMALL_ADMM, sort_keys=True), la, lm, tg),
                          lambda: design_admm(small, method=self.method, **FMAX_LAT))
        self.cores.append(Core(self.name, small.name, 1, d.b,
                               self.run.out / "cores" / f"{self.method}_{small.name}_p1_b{d.b}_la{la}_lm{lm}_{tg}",
                               dataclasses.replace(d, P=1), d.iterations, role="fmax", synth=not self.quick,
                               pnr_seeds=FMAX_SEEDS))

    def jobs(self) -> list[Job]:
        log, out = self.run.log, []
        for c in self.cores:
            out.append(Job(30, f"{c.tag} verilator", lambda c=c: measure_cycles(c, log)))
            # QUICK: the ECP5 results only where a full run left them for the same SystemVerilog
            if c.synth or is_cached(c, "ecp5"):
                out.append(Job(600, f"{c.tag} ecp5", lambda c=c: synth_ecp5_and_pnr(c, log)))
        return out

    def finish(self) -> None:
        self.rows = []
        for c in self.cores:
            m, e, p = c.measured or {}, c.ecp5 or {}, c.pnr or {}
            self.rows.append({
                "method": self.method, "problem": c.problem, "n": c.core.get("n"), "P": c.P, "b": c.b,
                "lat_add": c.design.lat_add, "lat_mul": c.design.lat_mul, "target": c.design.target,
                "cycles_per_iteration": c.core.get("cycles_per_iteration"),
                "cycles_per_iteration_measured": m.get("cycles_per_iteration"),
                "multipliers": c.core.get("multipliers"), "ecp5_MULT18X18D": e.get("MULT18X18D"),
                "ecp5_LUT4": e.get("LUT4"), "ecp5_FF": e.get("FF"), "ecp5_DP16KD": e.get("DP16KD"),
                "fmax_mhz": p.get("fmax_mhz"), "fmax_seeds": p.get("fmax_seeds"),
                "fmax_seeds_text": seeds_text(p) if p else "", "pnr_note": c.pnr_note})

    def appendix_md(self) -> list[str]:
        if not self.rows:
            return []
        head = ["core", "L (core.json)", "L measured", "mult.", "MULT18X18D", "LUT4", "FF", "DP16KD",
                "Fmax LFE5U-85F (median of seeds)"]
        body = [[f"{r['method']} {r['problem']} n_A = {r['n']} P = {r['P']} b = {r['b']} l_A = {r['lat_add']} "
                 f"l_M = {r['lat_mul']} {r['target']}", str(r["cycles_per_iteration"]),
                 _f(r["cycles_per_iteration_measured"], "{}"), str(r["multipliers"]), _f(r["ecp5_MULT18X18D"], "{}"),
                 _f(r["ecp5_LUT4"], "{}"), _f(r["ecp5_FF"], "{}"), _f(r["ecp5_DP16KD"], "{}"),
                 (_f(r["fmax_mhz"], "{:.1f} MHz") + (f" ({r['fmax_seeds_text']})" if r["fmax_seeds_text"] else ""))
                 if r["fmax_mhz"] else
                 (r["pnr_note"] or "not placed")] for r in self.rows]
        return [f"## {self.label} on the ADMM datapath", "",
                f"The method `{self.method}` of the ADMM core (004; docs/methods.md compares the methods' "
                "iterations). The same datapath as ADMM: only the operand v and the matrices differ, so the cycles "
                "per iteration are ADMM's.", "", *_table(head, body), ""]

    def console_summary(self) -> list[str]:
        return [f"{self.label}: L = {r['cycles_per_iteration']} (measured {r['cycles_per_iteration_measured']}), "
                f"Fmax {_f(r['fmax_mhz'], '{:.1f} MHz')}" for r in self.rows]
