"""The design check: before a flow emits a core, the core's golden model runs against the MPC problem of the spec
solved to optimality (mpc_cores.mpc_qp: every constraint section, OSQP with polishing, feasibility by an LP).

- Sampled states: `check.samples` states x (and references r, previous inputs u_prev) drawn uniformly from the
  boxes the core accepts; per sample the golden model's first input u0 from a cold start, and its suboptimality
  (V(u0) - V*) / V*, V(u0) the optimal horizon cost with u_0 fixed to u0 (infinite when no plan meets the hard
  constraints after u0), V* the optimum. An answer with a word that is not finite (NaN or infinite, a float
  core's iterate run off) counts as an infinite suboptimality and fails the check.
- The closed-loop scenario of the spec's `check:` section: x0, `steps` samples, a reference drawn every `hold`
  samples (mpc_cores.closedloop.reference_schedule); the golden model in the loop (warm-started as the core is)
  beside the optimal controller. It reports the cost gap, the worst violation of each constraint class (input box,
  input rate, hard states; soft states for information) in absolute terms and as a fraction of the constraint's
  range, divergence, and the solves the model flagged (a saturated datapath word, an answer not converged).

A design fails its check when the loop diverges, a hard constraint is violated by more than `check.violation` of
its range, or a solve was flagged; with a target (`check.gap`, GAP=), also when the loop's cost gap or the median
sampled suboptimality exceeds it. `checked_design` then chooses the iteration count (Imax, I_MR) that meets the
target within the budget of `check.cycles` cycles per solve, or refuses in one line naming the numbers.
"""
from __future__ import annotations

import asyncio
from dataclasses import dataclass, field

import numpy as np

from mpc_cores.closedloop import Controller, closed_loop, reference_schedule
from mpc_cores.errors import DesignError
from mpc_cores.mpc_qp import Infeasible, MpcQP
from mpc_cores.problem import MpcProblem

HARD = ("input box", "input rate", "hard states")


class CheckFailed(DesignError):
    """The design's check failed; the message names the numbers; `design` and `result` are the last tried."""

    def __init__(self, msg: str, design=None, result: CheckResult | None = None):
        super().__init__(msg)
        self.design, self.result = design, result


class OptimalController(Controller):
    """The MPC problem with every section solved to optimality (mpc_cores.mpc_qp); keeps the applied input."""
    name = "optimal"

    def __init__(self, problem: MpcProblem, qp: MpcQP | None = None):
        self.p = problem
        self.qp = qp or MpcQP(problem)
        self.u_prev = np.zeros(problem.nu)

    async def step(self, x, r):
        u = self.qp.solve(x, r if self.p.ny else None, self.u_prev).u[0]
        self.u_prev = u
        return u


@dataclass
class CheckResult:
    kind: str
    facts: dict
    gap: float                       # closed-loop cost above the optimal loop's, percent
    violations: dict                 # class -> (worst absolute, worst as a fraction of the range)
    diverged: bool
    flagged: dict                    # what the model flagged -> solves
    subopt: list = field(default_factory=list)   # sampled suboptimality, percent (inf: u0 leaves the feasible set)
    sample_violations: dict = field(default_factory=dict)  # the sampled u0's input box and rate, as `violations`
    infeasible_samples: int = 0      # sampled states from which no plan meets the hard constraints
    nonfinite_samples: int = 0       # sampled states whose u0 has a word that is not finite (NaN or infinite)
    steps: int = 0
    outside: int = 0                 # loop steps whose state or reference lay outside the box the core accepts
    target: float | None = None
    tol: float = 1e-3
    scenario_error: str = ""
    loop_iterations: list = field(default_factory=list)  # iterations per loop step, when they vary (an exit test)

    @property
    def subopt_median(self) -> float:
        return float(np.median(self.subopt)) if self.subopt else float("nan")

    @property
    def subopt_worst(self) -> float:
        return float(np.max(self.subopt)) if self.subopt else float("nan")

    def failures(self) -> list[str]:
        out = []
        if self.scenario_error:
            out.append(self.scenario_error)
        if self.diverged:
            out.append("the closed loop diverges")
        for where, viol in (("", self.violations), ("sampled u0: ", self.sample_violations)):
            for c in HARD:
                if c in viol and viol[c][1] > self.tol:
                    a, r = viol[c]
                    out.append(f"{where}{c} violated by {a:.3g} ({100 * r:.2g} % of its range > "
                               f"{100 * self.tol:.2g} %)")
        out += [f"{what} in {k} of {self.steps} solves" for what, k in self.flagged.items() if k]
        if self.nonfinite_samples:
            out.append(f"sampled u0 not finite (NaN or infinite) in {self.nonfinite_samples} of {len(self.subopt)} "
                       f"sampled states")
        if self.target is not None:
            if not abs(self.gap) <= self.target:
                out.append(f"closed-loop cost {_pct(self.gap)} against the optimal MPC's, beyond the target "
                           f"{self.target:g} %")
            if not self.subopt_median <= self.target:
                out.append(f"median sampled suboptimality {_pct(self.subopt_median)} > target {self.target:g} %")
        return out

    @property
    def ok(self) -> bool:
        return not self.failures()

    def line(self) -> str:
        f = self.facts
        viol = ", ".join(f"{c} {a:.3g} ({100 * r:.2g} %)" for c, (a, r) in self.violations.items())
        flags = "".join(f", {what} in {k} solves" for what, k in self.flagged.items() if k)
        if self.outside:
            flags += f", the state or reference outside the accepted box (saturated at the core) in {self.outside} steps"
        sv = ", ".join(f"{c} {a:.3g} ({100 * r:.2g} %)" for c, (a, r) in self.sample_violations.items() if a > 0)
        samples = (f"{len(self.subopt)} sampled states: suboptimality median {_pct(self.subopt_median)}, worst "
                   f"{_pct(self.subopt_worst)}" + (f", u0 outside {sv}" if sv else "")
                   + (f" ({self.infeasible_samples} infeasible states skipped)" if self.infeasible_samples else "")
                   + (f", u0 not finite in {self.nonfinite_samples}" if self.nonfinite_samples else ""))
        loop = (self.scenario_error or f"closed loop ({self.steps} steps): cost {_pct(self.gap)} against the optimum"
                f"{', DIVERGES' if self.diverged else ''}; worst violation {viol or 'none (input box only)'}{flags}")
        target = f"; target {self.target:g} %" if self.target is not None else ""
        verdict = "passes" if self.ok else "FAILS"
        its = ""
        if self.loop_iterations:
            v = np.asarray(self.loop_iterations)
            its = (f"; the exit test (EXIT_TOL {f['exit_tol']}): iterations per loop step median {np.median(v):g}, "
                   f"max {v.max()} ({f['cycles_of'](float(np.median(v))):g} and {f['cycles_of'](int(v.max()))} "
                   f"cycles)")
        return (f"Check ({verdict}{target}): {loop}; {samples}; {f['iterations_text']}, {f['cycles']} cycles per "
                f"solve{' at most' if its else ''}{its}")


def _pct(v: float) -> str:
    return f"{v:+.3g} %" if np.isfinite(v) else "inf"


def scenario(problem: MpcProblem) -> tuple[np.ndarray, np.ndarray]:
    """(x0, references) of the spec's closed-loop scenario: x0 from `check.x0`, else the centre of the state box
    for a tracking problem and, for a regulator, a point halfway to a corner of it (signs from the seed)."""
    c = problem.check
    mid, half = (problem.xmin + problem.xmax) / 2, (problem.xmax - problem.xmin) / 2
    if c.x0 is not None:
        x0 = np.array(c.x0, dtype=float)
    elif problem.ny:
        x0 = mid.copy()
    else:
        x0 = mid + 0.5 * half * np.random.default_rng(c.seed).choice([-1.0, 1.0], problem.nx)
    try:
        refs = reference_schedule(problem, c.steps, c.hold, c.seed, holdable=0.9)
    except ValueError:
        refs = reference_schedule(problem, c.steps, c.hold, c.seed, holdable=0.0)
    return x0, refs


def worst(v, lo, hi) -> tuple[float, float]:
    """(largest violation of lo <= v <= hi, largest as a fraction of hi - lo) over the rows of v"""
    over = np.maximum(0.0, np.maximum(v - hi, lo - v))
    return float(over.max(initial=0.0)), float((over / (hi - lo)).max(initial=0.0))


def _violations(p: MpcProblem, X: np.ndarray, U: np.ndarray) -> dict:
    """class -> (worst absolute violation, worst as a fraction of the constraint's range) along a trajectory."""
    out = {"input box": worst(U, p.umin, p.umax)}
    if p.input_rate is not None:
        dU = np.diff(np.vstack([np.zeros((1, p.nu)), U]), axis=0)
        out["input rate"] = worst(dU, p.input_rate.dumin, p.input_rate.dumax)
    if p.hard_states is not None:
        H = p.hard_states
        out["hard states"] = worst(X[1:, list(H.indices)], H.xmin, H.xmax)
    if p.soft_states is not None:
        S = p.soft_states
        out["soft states"] = worst(X[1:, list(S.indices)], S.xmin, S.xmax)
    return out


def _diverged(p: MpcProblem, X: np.ndarray) -> bool:
    mid, half = (p.xmin + p.xmax) / 2, (p.xmax - p.xmin) / 2
    return bool(not np.all(np.isfinite(X)) or np.any(np.abs(X - mid) > 10 * half))


def _golden(kind, d, warm: bool | None = None):
    if not kind.has_demo:
        raise CheckFailed(f"CORE={kind.name} has no closed-loop model to check")
    g = kind.controllers(d)[1]
    if warm is not None:
        g.warm = warm
    return g


async def _samples(kind, d, qp: MpcQP, rng) -> tuple[list, int, dict, int]:
    """(suboptimality per feasible sample, infeasible samples, the u0's worst input-box and rate violations, the
    samples whose u0 is not finite)"""
    p = qp.p
    g = _golden(kind, d, warm=False)
    subopt, infeasible, nonfinite, U, dU = [], 0, 0, [], []
    for _ in range(p.check.samples):
        x = rng.uniform(p.xmin, p.xmax)
        r = rng.uniform(p.rmin, p.rmax) if p.ny else np.zeros(0)
        up = rng.uniform(p.umin, p.umax) if p.input_rate is not None else np.zeros(p.nu)
        try:
            best = qp.solve(x, r if p.ny else None, up).cost
        except Infeasible:
            infeasible += 1
            continue
        if hasattr(g, "u_prev"):
            g.u_prev = up.copy()
        u0 = np.asarray(await g.step(x, r), dtype=float)
        if not np.all(np.isfinite(u0)):
            nonfinite += 1
            subopt.append(float("inf"))
            continue
        U.append(u0)
        dU.append(u0 - up)
        try:
            cost = qp.solve(x, r if p.ny else None, up, u0=u0).cost
        except Infeasible:
            cost = float("inf")
        subopt.append(100.0 * (cost - best) / max(best, 1e-12))
    viol = {"input box": worst(np.array(U), p.umin, p.umax)} if U else {}
    if U and p.input_rate is not None:
        viol["input rate"] = worst(np.array(dU), p.input_rate.dumin, p.input_rate.dumax)
    return subopt, infeasible, viol, nonfinite


def check_design(kind, d, target: float | None = None) -> CheckResult:
    """The check of design d of `kind` (module docstring); target: the gap in percent (None: the spec's)."""
    p = d.problem
    c = p.check
    qp = MpcQP(p)
    x0, refs = scenario(p)
    res = CheckResult(kind=kind.name, facts=kind.facts(d), gap=float("nan"), violations={}, diverged=False,
                      flagged={}, steps=len(refs), target=c.gap if target is None else target, tol=c.violation)
    try:
        opt = asyncio.run(closed_loop(p, OptimalController(p, qp), x0, refs))
    except Infeasible as e:
        res.scenario_error = f"the scenario is infeasible: {e}"
        opt = None
    g = _golden(kind, d)
    with np.errstate(all="ignore"):
        traj = asyncio.run(closed_loop(p, g, x0, refs))
    res.diverged = _diverged(p, traj.x)
    res.loop_iterations = list(getattr(g, "iterations", None) or []) if "cycles_of" in res.facts else []
    res.outside = int(np.sum(np.any((traj.x[:-1] < p.xmin) | (traj.x[:-1] > p.xmax), axis=1)
                             | np.any((traj.r < p.rmin) | (traj.r > p.rmax), axis=1)))
    res.violations = _violations(p, traj.x, traj.u)
    if opt is not None:
        res.gap = 100.0 * (traj.cost - opt.cost) / max(opt.cost, 1e-12)
    res.flagged = {"a saturated datapath word": int(getattr(g, "overflow_steps", 0)),
                   "an answer flagged not converged": int(getattr(g, "not_converged", 0))}
    res.subopt, res.infeasible_samples, res.sample_violations, res.nonfinite_samples = asyncio.run(
        _samples(kind, d, qp, np.random.default_rng(c.seed + 1)))
    return res


def refusal(kind, d, res: CheckResult) -> str:
    return (f"design check of CORE={kind.name} on {d.problem.name} ({res.facts['iterations_text']}, "
            f"{res.facts['cycles']} cycles per solve): " + "; ".join(res.failures()))


def checked_design(kind, problem: MpcProblem, overrides: dict, target: float | None = None,
                   budget: int | None = None):
    """(design, check) of `kind` for the problem: without a target, the design as asked, refused (CheckFailed) when
    its check fails; with one (argument or `check.gap`), and no iteration count fixed by the overrides, the smallest
    count that meets it within `budget` cycles per solve (argument or `check.cycles`): doubling (or halving) from
    the design's count, then bisecting to within 1/16 of it."""
    target = problem.check.gap if target is None else target
    budget = problem.check.cycles if budget is None else budget
    if target is not None and "exit_tol" in kind.overrides and "exit_tol" not in overrides:
        d = kind.design(problem, **overrides)
        if getattr(d, "early_exit", False):
            # the exit test's tolerance left to the flow: the iteration count for the worst case with the test off,
            # then the largest tolerance that keeps the target
            d, res = checked_design(kind, problem, {**overrides, "exit_tol": 0}, target, budget)
            return _exit_search(kind, problem, {**overrides, "frac_bits": d.b, "iterations": d.iterations}, target,
                                (d, res))
    try:
        return _checked_count(kind, problem, overrides, target, budget)
    except CheckFailed as first:
        # Precision: a fixed-point kind whose word format the overrides leave free gets FRAC_STEPS more fraction
        # bits before it is refused (an ill-conditioned plant's iterates can stall on the quantisation floor at the
        # default format, which no iteration count cures); the smallest format that meets the target wins.
        b0 = getattr(first.design, "b", None)
        if target is None or b0 is None or "frac_bits" in overrides or "frac_bits" not in kind.overrides:
            raise
        for step in FRAC_STEPS:
            try:
                return _checked_count(kind, problem, {**overrides, "frac_bits": b0 + step}, target, budget)
            except CheckFailed:
                continue
            except DesignError:
                break
        raise


#: fraction bits added, in turn, to a fixed-point design whose check fails at its default format
FRAC_STEPS = (1, 2, 4)


def _checked_count(kind, problem: MpcProblem, overrides: dict, target: float | None, budget: int):
    d = kind.design(problem, **overrides)
    res = check_design(kind, d, target)
    if target is None or "iterations" in overrides or "iterations" not in kind.overrides:
        if not res.ok:
            raise CheckFailed(refusal(kind, d, res), d, res)
        return d, res
    tried = {res.facts["iterations"]: (d, res)}

    def at(i: int):
        if i not in tried:
            di = kind.design(problem, **overrides, iterations=i)
            tried[i] = (di, check_design(kind, di, target))
        return tried[i]

    def cycles(i: int) -> int:
        return kind.facts(kind.design(problem, **overrides, iterations=i))["cycles"]

    i0 = res.facts["iterations"]
    if res.ok:                       # halve while the target holds
        lo, hi = 0, i0
        while hi > 1 and at(hi // 2)[1].ok:
            hi //= 2
        lo = hi // 2
    else:                            # double until it holds or the budget ends
        lo, hi = i0, None
        while hi is None:
            i = 2 * lo
            if i > 65535 or cycles(i) > budget:
                i = _largest(lo, min(i, 65536), lambda j: cycles(j) <= budget)   # the last count within it
                if i == lo or not at(i)[1].ok:
                    if i > lo:
                        d, res = at(i)
                    raise CheckFailed(refusal(kind, d, res) + f"; no iteration count up to {i} meets the target "
                                      f"within the budget of {budget} cycles per solve (CYCLES=, check.cycles)", d, res)
            if at(i)[1].ok:
                hi = i
            else:
                lo, (d, res) = i, at(i)
    while hi - lo > max(1, hi // 16):
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if at(mid)[1].ok else (mid, hi)
    d, res = tried[hi]
    if res.facts["cycles"] > budget:
        # the loop need not improve with every iteration (a warm-started dual method can meet the target at one
        # iteration per sample and miss it at a few): the counts 1, 2, 4, ... within the budget, the smallest that
        # passes
        fits = [i for i in _powers(hi) if cycles(i) <= budget]
        for i in fits:
            if at(i)[1].ok:
                return tried[i]
    return d, res


def _exit_search(kind, problem: MpcProblem, overrides: dict, target: float, off):
    """The design with the largest exit tolerance 2^k LSB (k from 1 to b - 1, bisected) whose check meets the
    target, given the checked design `off` with the test off; with none, the test at its default tolerance if that
    passes, else off."""
    one = 2.0 ** -off[0].b
    tried = {}

    def at(k: int):
        if k not in tried:
            d = kind.design(problem, **overrides, exit_tol=(1 << k) * one)
            tried[k] = (d, check_design(kind, d, target))
        return tried[k]
    if not at(1)[1].ok:
        return off
    k = _largest(1, off[0].b, lambda j: at(j)[1].ok)
    return tried[k]


def _largest(lo: int, hi: int, ok) -> int:
    """the largest i in [lo, hi) with ok(i), ok(lo) holding and ok monotone (bisection)"""
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (mid, hi) if ok(mid) else (lo, mid)
    return lo


def _powers(top: int) -> list[int]:
    """1, 2, 4, ... below top"""
    return [1 << k for k in range(max(0, top - 1).bit_length()) if 1 << k < top]


__all__ = ["CheckFailed", "CheckResult", "OptimalController", "check_design", "checked_design", "scenario"]
