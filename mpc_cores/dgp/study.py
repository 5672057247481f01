"""The DGP core on examples/masses_state.yaml: the plain and the accelerated form of iteration (35) of 003, each with
a cold and a warm start, in closed loop with the bit-exact golden model, and the guarantee of the plain form.

closed_loop_study  the four combinations and the accelerated form's shifted warm start (warm_shift) on one
                   reference schedule (mpc_cores.closedloop.reference_schedule,
                   x0 = 0): per combination the iterations to the stopping test (median, p90, max; over all steps
                   and over the constrained steps, those whose QP has an active row at the optimum; the solves that
                   ran to Imax without it), the largest V(z) - V* and constraint violation of the returned solutions
                   (against OSQP on the same QP: the parameter words the core used, after its input saturation, in
                   real units, so the design's eps_V and eps_g apply as they are) and the closed-loop cost relative
                   to the loop of the OSQP controller and to OSQP fed the saturated parameters.
guarantee          the plain form from y = 0 (Corollary 1 of 003) on random states of the accepted box (references
                   random in the reference box): does the averaged primal meet the eps_V and eps_g the design was
                   made for, once the test (32c) holds?
dual_box_check     (14) of 003 at the vertices of the box of w = (x, r): does the design's dual box d bound y*, and
                   how does the accelerated form do where y* lies outside the projection box [0, alpha d]?

`python -m mpc_cores.dgp.study` prints them as plain-text tables, the loop study for the demo's references
(holdable 0.9) and for references whose steady-state input may leave the input box (holdable 0, the input rows
active in most steps); progress on stderr, one line per combination. The full run takes about 3.5 minutes of CPU
time, most of it the plain form (about 1 ms per iteration of the model).
"""
from __future__ import annotations

import argparse
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mpc_cores.closedloop import reference_schedule, run_closed_loop
from mpc_cores.dgp.control import DgpFixedController, DgpOsqpController, HOLDABLE
from mpc_cores.dgp.design import ALPHA, DgpDesign, design_dgp
from mpc_cores.dgp.model import DgpFixed, DgpResult
from mpc_cores.dgp.problem import objective, solve_osqp, violation
from mpc_cores.fixed import quantize
from mpc_cores.problem import MpcProblem, load_spec

SPEC = Path(__file__).resolve().parents[2] / "examples" / "masses_state.yaml"
IMAX_PLAIN = 5000


def masses_state() -> MpcProblem:
    return load_spec(SPEC)


ACTIVE = 1e-7     # a row is active at the optimum when its dual (scaled problem) exceeds this


def accuracy(d: DgpDesign, w_words: np.ndarray, z_words: np.ndarray,
             eps: float = 1e-9) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(V(z) - V*, violation, active) per row, real units, of the answers z_words (S x n) to the parameter words
    w_words (S x nw, inside the accepted box): V* from OSQP on the same (unquantised) QP, the violation
    ||[A z - b]+||_inf of the unscaled rows (the scaled one divided by sigma), active (S x 2): an input row / a state
    row is active at the optimum (its OSQP dual > ACTIVE)."""
    qp = d.qp
    one = float(1 << d.b)
    dV = np.zeros(len(w_words))
    vi = np.zeros(len(w_words))
    act = np.zeros((len(w_words), 2), dtype=bool)
    for i, (ww, zw) in enumerate(zip(w_words, z_words)):
        w = np.asarray(ww, dtype=float) / one
        z = np.asarray(zw, dtype=float) / one
        zs, yp, ym, st = solve_osqp(qp, w, eps=eps)
        if st != "solved":
            raise RuntimeError(f"OSQP: {st} at w = {w.tolist()}")
        dV[i] = objective(qp, z, w) - objective(qp, zs, w)
        vi[i] = violation(qp, z, w) / qp.sigma
        a = yp + ym > ACTIVE
        act[i] = a[: qp.n_input_rows].any(), a[qp.n_input_rows:].any()
    return dV, vi, act


def iteration_stats(it: np.ndarray) -> dict:
    it = np.asarray(it)
    return {"median": float(np.median(it)), "p90": float(np.percentile(it, 90)), "max": int(it.max())}


# ---------------------------------------------------------------------------
# closed loop


class SaturatedOsqpController(DgpOsqpController):
    """OSQP to optimality on the state and reference clipped into the core's accepted box, as the core's input
    saturation does: the loop a core with an exact solver would run."""
    name = "osqp-sat"

    def __init__(self, d: DgpDesign, eps: float = 1e-10):
        super().__init__(d.qp, eps)
        p = d.problem
        self.lo = np.concatenate([p.xmin, p.rmin])
        self.hi = np.concatenate([p.xmax, p.rmax])

    async def step(self, x, r):
        w = np.clip(np.concatenate([x, r]), self.lo, self.hi)
        nx = len(x)
        return self.solve(w[:nx], w[nx:])[: self.nu]


@dataclass
class Combination:
    accelerated: bool
    warm: bool
    imax: int
    iterations: np.ndarray      # per step
    met: np.ndarray             # per step: the stopping test held (else the solve ran to Imax)
    active: np.ndarray          # per step: a constraint row is active at the optimum of the step's QP
    state_active: int           # steps with a state row active at the optimum
    dV: np.ndarray              # per step, V(z) - V* (real units)
    viol: np.ndarray            # per step, constraint violation (real units)
    cost: float                 # closed-loop cost
    cost_opt: float             # the OSQP loop's
    cost_sat: float             # the loop of OSQP on the saturated parameters (SaturatedOsqpController)
    sat_steps: int
    overflow_steps: int
    seconds: float
    eps_g: float
    eps_V: float
    shift: bool = False         # the shifted warm start (warm_shift)

    @property
    def label(self) -> str:
        return (f"{'accelerated' if self.accelerated else 'plain'}, {'warm' if self.warm else 'cold'}"
                + (", shifted" if self.shift else ""))

    @property
    def imax_hits(self) -> int:
        return int(np.sum(~self.met))

    @property
    def cost_pct(self) -> float:
        return 100.0 * (self.cost - self.cost_opt) / self.cost_opt

    @property
    def cost_sat_pct(self) -> float:
        return 100.0 * (self.cost - self.cost_sat) / self.cost_sat

    def stats(self, constrained: bool = False) -> dict | None:
        it = self.iterations[self.active] if constrained else self.iterations
        return iteration_stats(it) if len(it) else None


@dataclass
class LoopStudy:
    steps: int
    hold: int
    seed: int
    holdable: float
    cost_opt: float
    cost_sat: float
    combos: list[Combination]
    design: dict                # accelerated -> DgpDesign


def closed_loop_study(steps: int = 100, hold: int = 5, seed: int = 1, holdable: float = HOLDABLE,
                      imax_plain: int = IMAX_PLAIN, imax_accelerated: int | None = None,
                      problem: MpcProblem | None = None, log=sys.stderr) -> LoopStudy:
    """The four combinations (plain / accelerated x cold / warm) and the accelerated form's shifted warm start
    (warm_shift) on one reference schedule (x0 = 0, a new reference every `hold` steps,
    mpc_cores.closedloop.reference_schedule with `holdable`); imax_accelerated None: the design's iterations."""
    p = problem or masses_state()
    designs = {acc: design_dgp(p, accelerated=acc) for acc in (False, True)}
    shifted = design_dgp(p, accelerated=True, warm_shift=True)
    refs = reference_schedule(p, steps, hold, seed, holdable=holdable)
    x0 = np.zeros(p.nx)
    t_opt = run_closed_loop(p, DgpOsqpController(designs[True].qp), x0, refs)
    t_sat = run_closed_loop(p, SaturatedOsqpController(designs[True]), x0, refs)
    combos = []
    for acc, warm, shift in ((False, False, False), (False, True, False), (True, False, False), (True, True, False),
                             (True, True, True)):
        d = shifted if shift else designs[acc]
        imax = int(imax_plain if not acc else (imax_accelerated or d.iterations))
        t0 = time.perf_counter()
        g = DgpFixedController(d, imax=imax, warm=warm)
        tr = run_closed_loop(p, g, x0, refs)
        dV, vi, act = accuracy(d, np.array(g.w), np.array(g.z))
        c = Combination(accelerated=acc, warm=warm, imax=imax, iterations=np.array(g.iterations),
                        met=np.array(g.met), active=act.any(axis=1), state_active=int(act[:, 1].sum()),
                        dV=dV, viol=vi, cost=tr.cost, cost_opt=t_opt.cost,
                        cost_sat=t_sat.cost, sat_steps=g.sat_steps, overflow_steps=g.overflow_steps,
                        seconds=time.perf_counter() - t0, eps_g=d.eps_g, eps_V=d.eps_V, shift=shift)
        combos.append(c)
        if log is not None:
            s = c.stats()
            print(f"  {c.label}: {steps} steps, iterations median {s['median']:g}, max {s['max']}, "
                  f"{c.seconds:.1f} s", file=log, flush=True)
    return LoopStudy(steps=steps, hold=hold, seed=seed, holdable=holdable, cost_opt=t_opt.cost,
                     cost_sat=t_sat.cost, combos=combos, design=designs)


def _its(st: dict | None) -> str:
    if st is None:
        return f"{'-':>6} {'-':>7} {'-':>5}"
    return f"{st['median']:>6g} {st['p90']:>7.1f} {st['max']:>5}"


def loop_table(s: LoopStudy) -> str:
    head = (f"{'combination':<27} {'Imax':>5} | {'median':>6} {'p90':>7} {'max':>5} | {'steps':>5} {'median':>6} "
            f"{'p90':>7} {'max':>5} | {'Imax hits':>9} | {'max V-V*':>9} {'>eps_V':>6} {'max viol':>9} {'>eps_g':>6} | "
            f"{'vs OSQP':>8} {'vs sat.':>8}")
    sub = (f"{'':<27} {'':>5} | {'iterations, all steps':<20} | {'constrained steps: iterations':<26} | {'':>9} | "
           f"{'returned solutions (real units)':<33} | {'loop cost'}")
    lines = [sub, head, "-" * len(head)]
    for c in s.combos:
        lines.append(f"{c.label:<27} {c.imax:>5} | {_its(c.stats())} | {int(c.active.sum()):>5} "
                     f"{_its(c.stats(True))} | {c.imax_hits:>9} | {c.dV.max():>9.2e} {int(np.sum(c.dV > c.eps_V)):>6} "
                     f"{c.viol.max():>9.2e} {int(np.sum(c.viol > c.eps_g)):>6} | {c.cost_pct:>7.3f}% "
                     f"{c.cost_sat_pct:>7.3f}%")
    c0 = s.combos[0]
    lines += ["",
              f"{s.steps} steps, x0 = 0, a new reference every {s.hold} steps (reference_schedule, seed {s.seed}, "
              f"holdable {s.holdable:g}); eps_V = {c0.eps_V:g}, eps_g = {c0.eps_g:g} (real units).",
              "constrained steps: a row of the step's QP is active at the optimum (OSQP dual > "
              f"{ACTIVE:g}); the others need 1 iteration. Steps with a state row active: "
              + ", ".join(f"{c.label} {c.state_active}" for c in s.combos) + ".",
              f"loop cost relative to OSQP ({s.cost_opt:.6f}) and to OSQP on the parameters clipped into the accepted "
              f"box as the core's input saturation does (vs sat., {s.cost_sat:.6f}).",
              "steps with the state outside the accepted box (input saturation): "
              + ", ".join(f"{c.label} {c.sat_steps}" for c in s.combos)
              + "; data overflow: " + ", ".join(f"{c.label} {c.overflow_steps}" for c in s.combos) + "."]
    return "\n".join(lines)


# ---------------------------------------------------------------------------
# the guarantee of the plain form from y = 0


def random_parameters(d: DgpDesign, count: int, seed: int = 1) -> np.ndarray:
    """count parameter words, uniform in the accepted box of states and the reference box."""
    p = d.problem
    rng = np.random.default_rng(seed)
    lo = np.concatenate([p.xmin, p.rmin])
    hi = np.concatenate([p.xmax, p.rmax])
    return quantize(rng.uniform(lo, hi, (count, len(lo))), d.b)


def solve_cold(model: DgpFixed, W: np.ndarray, imax: int, first: int = 2500) -> DgpResult:
    """model.solve_batch(W, imax) from y = 0, computed in two rounds: all rows with Imax = min(first, imax), then
    the rows without the test again with imax (the solves are independent and deterministic, so the answers are
    those of one batch with imax; the second round runs on the few slow rows only)."""
    r = model.solve_batch(W, imax=min(first, imax))
    rest = np.flatnonzero(~r.met)
    if imax > first and rest.size:
        r2 = model.solve_batch(W[rest], imax=imax)
        for f in ("z", "iterations", "met", "sat", "overflow", "y"):
            getattr(r, f)[rest] = getattr(r2, f)
    return r


@dataclass
class Guarantee:
    states: int
    imax: int
    met: int                    # solves that met the test (32c) within imax
    iterations: np.ndarray
    dV: np.ndarray
    viol: np.ndarray
    eps_V: float
    eps_g: float
    nu_bound: float             # the iteration bound (26) of 003 (nominal case, alpha = 2)
    seconds: float
    constrained: int = 0        # solves with a row active at the optimum
    state_active: int = 0       # solves with a state row active at the optimum

    @property
    def holds(self) -> bool:
        return self.met == self.states and bool(np.all(self.dV <= self.eps_V)) and bool(np.all(self.viol <= self.eps_g))


def guarantee(states: int = 500, imax: int = 20000, seed: int = 1, problem: MpcProblem | None = None,
              design: DgpDesign | None = None) -> Guarantee:
    """The plain form, cold start (y = 0, where Corollary 1 of 003 bounds V - V*), on `states` random parameters
    of the accepted box, run to the test (32c) or imax: the worst V(zbar) - V* and violation against the design's
    eps_V and eps_g."""
    t0 = time.perf_counter()
    d = design or design_dgp(problem or masses_state(), accelerated=False)
    if d.accelerated:
        raise ValueError("the guarantee is that of the plain form (averaged primal): give a plain design")
    W = random_parameters(d, states, seed)
    r = solve_cold(DgpFixed(d), W, imax)
    Wc = np.clip(W, d.xlo, d.xhi)
    dV, vi, act = accuracy(d, Wc, r.z)
    a = d.analysis
    eg = d.eps_g * d.qp.sigma          # (26) on the scaled problem, L = 1, eps_z = eps_xi = 0, alpha = 2
    nu = a["D"] ** 2 * 4 / (2 * eg * 2 - 2 * eg) - 1
    return Guarantee(states=states, imax=imax, met=int(r.met.sum()), iterations=r.iterations, dV=dV, viol=vi,
                     constrained=int(act.any(axis=1).sum()), state_active=int(act[:, 1].sum()),
                     eps_V=d.eps_V, eps_g=d.eps_g, nu_bound=nu, seconds=time.perf_counter() - t0)


def guarantee_table(g: Guarantee) -> str:
    st = iteration_stats(g.iterations)
    return "\n".join([
        f"plain form, cold start (y = 0), {g.states} random states of the accepted box (references random in the "
        f"reference box), Imax = {g.imax}",
        f"  constraints:          a row active at the optimum in {g.constrained} solves, a state row in "
        f"{g.state_active}",
        f"  test (32c) met:       {g.met} of {g.states}",
        f"  iterations:           median {st['median']:g}, p90 {st['p90']:.0f}, max {st['max']} "
        f"(bound (26) of 003: {g.nu_bound:.3g})",
        f"  worst V(zbar) - V*:   {g.dV.max():.3e}  (eps_V = {g.eps_V:g}; best {g.dV.min():.3e})",
        f"  worst violation:      {g.viol.max():.7e}  (eps_g = {g.eps_g:g})",
        f"  guarantee holds:      {'yes' if g.holds else 'NO'}",
        f"  ({g.seconds:.0f} s)"])


# ---------------------------------------------------------------------------
# the dual box of (14)-(15) at the vertices of the parameter box


@dataclass
class DualBoxCheck:
    vertices: int               # vertices of the box of w = (x, r)
    above_d: int                # vertices with some y*_i > d_i (violating (14))
    above_box: int              # vertices with some y*_i > alpha d_i (y* outside the projection box)
    max_ratio: float            # max_i y*_i / d_i over the vertices
    met: int                    # of the above_box vertices: accelerated solves (cold, Imax) meeting the test
    worst_viol: float           # of the above_box vertices: the worst violation of the answers (real units)
    imax: int


def vertex_parameters(p: MpcProblem) -> np.ndarray:
    """The 2^nw vertices of the accepted box of w = (x, r) (real values)."""
    lo = np.concatenate([p.xmin, p.rmin])
    hi = np.concatenate([p.xmax, p.rmax])
    nw = len(lo)
    bits = (np.arange(1 << nw)[:, None] >> np.arange(nw)[None, :]) & 1
    return np.where(bits == 1, hi, lo)


def dual_box_check(d: DgpDesign, run: bool = True, eps: float = 1e-9) -> DualBoxCheck:
    """(14) of 003 asks d_i >= y*_i for every admissible parameter (Remark 1: uniform bounds), and the projection
    box [0, alpha d] must contain y* for (35) to converge to the QP's solution (the exact penalty (16)). The
    design flow samples y* at the vertices in x with random references and at random points: this checks y* at
    the 2^nw vertices of the box of w, and (run) solves those outside the projection box with the accelerated
    form of the design (cold, its Imax)."""
    qp = d.qp
    W = vertex_parameters(d.problem)
    ratio = np.zeros(len(W))
    out = np.zeros(len(W), dtype=bool)
    ad = ALPHA * d.d
    for i, w in enumerate(W):
        _, yp, ym, st = solve_osqp(qp, w, eps=eps)
        if st != "solved":
            raise RuntimeError(f"OSQP: {st} at the vertex w = {w.tolist()}")
        y = np.concatenate([yp, ym])
        ratio[i] = float(np.max(y / d.d))
        out[i] = bool(np.any(y > ad))
    met, worst, imax = 0, 0.0, 0
    if run and out.any():
        da = d if d.accelerated else design_dgp(d.problem, accelerated=True)
        imax = da.iterations
        Wq = quantize(W[out], da.b)
        r = DgpFixed(da).solve_batch(Wq, imax=imax)
        _, vi, _ = accuracy(da, Wq, r.z)
        met, worst = int(r.met.sum()), float(vi.max())
    return DualBoxCheck(vertices=len(W), above_d=int(np.sum(ratio > 1)), above_box=int(out.sum()),
                        max_ratio=float(ratio.max()), met=met, worst_viol=worst, imax=imax)


def dual_box_table(c: DualBoxCheck, d: DgpDesign) -> str:
    lines = [f"y* (OSQP) at the {c.vertices} vertices of the box of w = (x, r), against the design's d "
             f"(max d_i = {d.d.max():.4g}, alpha = {ALPHA:g}):",
             f"  y*_i > d_i for some i ((14) violated):           {c.above_d} vertices",
             f"  y*_i > alpha d_i (outside the projection box):   {c.above_box} vertices",
             f"  max_i y*_i / d_i:                                {c.max_ratio:.3f}"]
    if c.above_box and c.imax:
        lines.append(f"  accelerated form, cold, Imax = {c.imax}, on those: test met in {c.met} of {c.above_box}, "
                     f"worst violation {c.worst_viol:.3e} (eps_g = {d.eps_g:g})")
    return "\n".join(lines)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(prog="python -m mpc_cores.dgp.study", description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=100, help="closed-loop steps (default 100)")
    ap.add_argument("--hold", type=int, default=5, help="steps per reference (default 5)")
    ap.add_argument("--seed", type=int, default=1, help="reference schedule seed (default 1)")
    ap.add_argument("--holdable", type=float, nargs="+", default=[HOLDABLE, 0.0],
                    help=f"reference_schedule's holdable fraction, one loop study per value (default {HOLDABLE} 0: the "
                         f"demo's references, then references whose steady-state input may leave the input box)")
    ap.add_argument("--imax-plain", type=int, default=IMAX_PLAIN, help=f"Imax of the plain form (default {IMAX_PLAIN})")
    ap.add_argument("--imax-accelerated", type=int, default=None,
                    help="Imax of the accelerated form (default: the design's iterations)")
    ap.add_argument("--states", type=int, default=500, help="random states of the guarantee check (default 500)")
    ap.add_argument("--imax-guarantee", type=int, default=20000, help="Imax of the guarantee check (default 20000)")
    a = ap.parse_args(argv)
    p = masses_state()
    for i, hb in enumerate(a.holdable):
        print(f"closed loop, holdable {hb:g}, five combinations:", file=sys.stderr, flush=True)
        s = closed_loop_study(a.steps, a.hold, a.seed, hb, a.imax_plain, a.imax_accelerated, problem=p)
        if i == 0:
            d = s.design[True]
            print(f"DGP core on {d.problem.name}: n = {d.n}, {d.m} one-sided rows, p = {d.b} fraction bits ((36): "
                  f"{d.bits36}), r = {d.widths['data'] - d.b} integer bits ((37): plain {s.design[False].bits37}, "
                  f"accelerated {d.bits37}), eps_V = {d.eps_V:g}, eps_g = {d.eps_g:g}")
            print()
        print(f"Closed loop, golden model, references with holdable {hb:g}")
        print(loop_table(s))
        print()
    if a.states > 0:
        print(f"guarantee: {a.states} states...", file=sys.stderr, flush=True)
        print("Guarantee of the plain form (Corollary 1 of 003)")
        print(guarantee_table(guarantee(a.states, a.imax_guarantee)))
        print()
    print("vertices: dual box...", file=sys.stderr, flush=True)
    print("The dual box (14)-(15) of the design at the vertices of the parameter box")
    d = design_dgp(p, accelerated=True)
    print(dual_box_table(dual_box_check(d), d))


if __name__ == "__main__":
    main()
