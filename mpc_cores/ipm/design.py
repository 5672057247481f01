"""Design of an interior-point core from an MPC problem: the Stage 1 programs (mpc_cores.ipm.program) on 2P slots,
the MINRES solver in its warm form (mpc_cores.minres.design, P problems per batch), I_NW and I_MR, the float
format, and the convergence tolerances, written to the config.json the generator (ipm.IpmMain) reads.

Defaults: I_NW = 8; I_MR the larger of 12 (the masses closed loop within 0.1 % of OSQP with the equilibration,
docs/ipm.md) and the smallest I_MR at which Stage 1 hides behind MINRES (a Newton iteration of 2P problems
takes two MINRES batches back to back, mpc_cores.ipm.timing), so that the added iterations cost no latency; P from
eq. (15) of 001 (the MINRES core's form); the float operators' latencies from a preset, compact (the float
library's defaults) or fast (150 MHz on the LFE5U-85F). Spec keys (solver section): ipm_P, ipm_newton, ipm_minres,
ipm_format, ipm_latency, ipm_mu_tol, ipm_res_tol, ipm_multiplexed.

Multiplexed (ipm_multiplexed: true; parallel multiplexed MPC, Algorithm 2 of 001): the core solves the m
single-input problems of mpc_cores.ipm.multiplexed.channel_problem, channel c the problem of input c mod m, each
with its own Stage 1 constant bank and MINRES coefficient table (the programs and the layout are one: every
channel's problem has the same sizes); the closed loop around the core keeps the plan and picks the copy
(mpc_cores.ipm.mux_loop).
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mpc_cores.errors import DesignError
from mpc_cores.kind import refuse_sections
from mpc_cores.float import vector as fv
from mpc_cores.ipm import stage1_config
from mpc_cores.ipm.program import Stage1, build
from mpc_cores.ipm.sparse import SparseMpc, sparse_mpc
from mpc_cores.ipm.timing import stage1_hidden
from mpc_cores.minres.schedule import schedule
from mpc_cores.minres.design import MinresDesign, design_minres

SIGMA, TAU, START, FLOOR = 0.1, 0.99, 1.0, 1e-2
I_NW, I_MR_ACCURACY = 8, 12
# multiplexed: a round's copies at a reference change start from the shifted plan's iterate; at I_MR = 12, 7 of the
# 292 answers of the masses design check's closed loop miss RES_TOL, at 20 none
I_MR_ACCURACY_MUX = 20
LATENCY = "compact"   # the float operators' latency preset (mpc_cores.minres.design.format_latencies)
MU_TOL, RES_TOL = 1e-3, 1e-1


@dataclass
class IpmDesign:
    name: str
    problem: object
    s: SparseMpc
    st1: Stage1
    md: MinresDesign       # P (0: eq. (15), resolved by the generator), iterations = the default I_MR
    i_nw: int
    mu_tol: float
    res_tol: float
    lat_cmp: int = 1
    banks: list = None     # multiplexed: per input, its channel problem's Stage1 (constants); st1 is banks[0]

    @property
    def multiplexed(self) -> bool:
        return bool(self.banks)

    @property
    def P(self) -> int:
        return self.md.P

    @property
    def i_mr(self) -> int:
        return self.md.iterations

    @property
    def fmt(self):
        return self.md.fmt

    @property
    def format(self) -> str:
        return self.md.format

    @property
    def lat(self) -> dict:
        """Stage 1 latencies: the MINRES operators' (one float library) and the comparator's"""
        m = self.md.lat
        return {"add": m["lat_add"], "mul": m["lat_mul"], "div": m["lat_div"], "sqrt": m["lat_sqrt"],
                "cmp": self.lat_cmp}

    def conventional(self):
        """A multiplexed design's conventional counterpart (the full problem, the same format, latencies, target and
        I_NW; P and I_MR the flow's), which `make demo` runs beside it; None for a conventional design."""
        if not self.multiplexed:
            return None
        return design_ipm(self.problem, format=self.format, latency=self.md.latency, target=self.md.target,
                          newton=self.i_nw, multiplexed=False)

    def label(self) -> str:
        return (("multiplexed (Algorithm 2), " if self.multiplexed else "") +
                f"{self.format} ({self.md.latency} latencies, target {self.md.target}), I_NW = {self.i_nw}, "
                f"I_MR = {self.i_mr}")

    def word(self, v: float) -> int:
        return int(fv.encode(self.fmt, np.array([v]))[0])

    def config(self) -> dict:
        p = self.problem
        st1 = stage1_config.config(self.st1, self.name, slots=2, lat=self.lat, exp_w=self.fmt.expW,
                                   man_w=self.fmt.manW, target=self.md.target, banks=self.banks)
        mux = {"multiplexed": True, "inputs": p.nu} if self.multiplexed else {}
        return {"core": "ipm", "name": self.name, "n": p.nx, "m": 1 if self.multiplexed else p.nu,
                "ny": 0 if self.multiplexed else p.ny, "i_nw": self.i_nw,
                "mu_tol": self.word(self.mu_tol), "res_tol": self.word(self.res_tol),
                "sigma": SIGMA, "tau": TAU, "hard_states": p.hard_states is not None, "stage1": st1,
                "minres": self.md.config(), **mux}

    def write_config(self, path) -> None:
        Path(path).write_text(json.dumps(self.config()))


def design_ipm(problem, P: int | None = None, iterations: int | None = None, newton: int | None = None,
               lat_add: int | None = None, lat_mul: int | None = None, format: str | None = None,
               name: str | None = None, latency: str | None = None, target: str | None = None,
               multiplexed: bool | None = None, **_ignored) -> IpmDesign:
    from mpc_cores.ipm.kind import KIND

    refuse_sections(problem, KIND.name, KIND.constraints)
    solver = problem.solver or {}
    s = sparse_mpc(problem)
    if len(s.bounded) == 0:
        raise DesignError("the interior-point core needs at least one boxed variable: got no input or state box")
    fmt = format if format not in (None, "") else solver.get("ipm_format", "binary32")
    i_nw = int(newton or solver.get("ipm_newton", I_NW))
    if not 1 <= i_nw <= 65535:
        raise DesignError(f"I_NW (newton) must be in [1, 65535]: got {i_nw}")
    P = P if P is not None else solver.get("ipm_P", 0)
    mux = multiplexed if multiplexed is not None else solver.get("ipm_multiplexed", False)
    if not isinstance(mux, bool):
        raise DesignError(f"ipm_multiplexed must be true or false: got {mux!r}")
    chans, banks = None, None
    if mux:
        if problem.nu < 2:
            raise DesignError(f"multiplexed MPC needs at least two inputs (one channel per input): got m={problem.nu}")
        from mpc_cores.ipm.multiplexed import channel_problem
        chans = [channel_problem(problem, i) for i in range(problem.nu)]
        banks = [build(sparse_mpc(c), SIGMA, TAU, True, START, FLOOR, multiplexed=True) for c in chans]
        if any(b.programs != banks[0].programs for b in banks):   # the MAX of the preconditioner in every bank
            banks = [build(sparse_mpc(c), SIGMA, TAU, True, START, FLOOR, multiplexed=True, force_max=True)
                     for c in chans]
        s = sparse_mpc(chans[0])
    md = design_minres(chans[0] if mux else problem, P=P, iterations=1, lat_add=lat_add, lat_mul=lat_mul,
                       format=fmt, name=name, warm=True, latency=latency or solver.get("ipm_latency", LATENCY),
                       target=target, channels=chans)
    st1 = banks[0] if mux else build(s, SIGMA, TAU, True, START, FLOOR)
    d = IpmDesign(name or problem.name, problem, s, st1, md, i_nw, float(solver.get("ipm_mu_tol", MU_TOL)),
                  float(solver.get("ipm_res_tol", RES_TOL)), banks=banks)
    try:   # the engine's rules (an ACC of more than lat_add terms, ...): a refusal, not a traceback
        stage1_config.check(st1.programs, [[int(t) for t in tab] for tab in st1.tables], d.lat)
    except ValueError as e:
        raise DesignError(f"the Stage 1 programs break a rule of the engine: {e} (the {s.n_ineq} box "
                          f"inequalities are summed by ACC)") from None
    if mux and md.P == 0:   # every input's copy in one MINRES batch: P at least m (eq. (15) otherwise)
        md.P = max(planned_core(d, 1)["P"], problem.nu)
    i_mr = iterations or solver.get("ipm_minres") or max(I_MR_ACCURACY_MUX if mux else I_MR_ACCURACY, hiding_imr(d))
    if not 1 <= int(i_mr) <= 65535:
        raise DesignError(f"I_MR (iterations) must be in [1, 65535]: got {i_mr}")
    md.iterations = int(i_mr)
    return d


def stage1_cycles(d: IpmDesign) -> dict:
    """cycles of each Stage 1 program without stream stalls (mpc_cores.ipm.isa.cycles)"""
    return d.st1.cycles(d.lat)


def planned_core(d: IpmDesign, i_mr: int) -> dict:
    """What mpc_cores.ipm.timing needs of core.json, from the design (the MINRES schedule of
    mpc_cores.minres.schedule, checked against the generator's when core.json is written)."""
    L = d.md.layout
    sch = schedule(L.N, L.M, d.md.pattern.K, d.md.lat, d.md.P, True)
    return {"P": sch["P"], "N": L.N, "stage1_cycles": stage1_cycles(d), "i_nw": d.i_nw, "iterations": i_mr,
            "minres_batch_cycles_imax0": sch["batch_cycles_imax0"], "cycles_per_iteration": sch["cycles_per_iteration"]}


def hiding_imr(d: IpmDesign) -> int:
    """The smallest I_MR at which Stage 1 hides behind MINRES: with 2P problems in flight a Newton iteration takes
    2 (I_MR + 1) P S cycles, MINRES's batches back to back (mpc_cores.ipm.timing.stage1_hidden)."""
    i_mr = 1
    while not stage1_hidden(planned_core(d, i_mr)):
        i_mr += 1
    return i_mr
