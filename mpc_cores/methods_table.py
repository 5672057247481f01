"""`make methods`: the comparison table of the splitting family (ADMM, AMA, Vu-Condat) and the dual gradient
projection, in float64, with and without acceleration and preconditioning (iterations in mpc_cores.methods).

Per example and variant:
  * iterations to 1e-3 and 1e-4 relative accuracy ||z_k - z*||_2 / max(||z*||_2, 1e-9), cold start, over random
    parameters w uniform in the accepted box (the same x and r for every method): the first k from which the error
    stays below the tolerance up to the cap (median and max; "> cap" when not reached). z* from OSQP at eps 1e-10
    (polished) on the QP the method solves: the sparse QP of mpc_cores.admm.problem with its soft / hard sets for the
    splitting family, the condensed DgpQP for the DGP. The z compared is the core's output: z (the projected
    iterate) for the splitting family, the averaged primal (plain) or the last z (accelerated) for the DGP.
  * the closed-loop cost at a fixed Imax relative to the OSQP closed loop on the same references (started as the
    cores start: the shifted (y, z, nu) for the splitting family, the design's default for the DGP: the accelerated
    form from the last dual, the plain form cold);
  * cycles per iteration and multipliers of the hardware: design_admm (one datapath for the three splitting methods),
    design_dgp (plain and accelerated forms); accelerated splitting variants are float only.
Writes methods.md (a table per example, dated) and methods.json; one progress line per variant on stderr.
"""
from __future__ import annotations

import argparse
import datetime
import json
import sys
import time
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from mpc_cores.admm.control import AdmmOsqpController, admm_references, parameters
from mpc_cores.admm.design import design_admm
from mpc_cores.admm.problem import BOX, build_admm_qp, solve_soft_qp_osqp
from mpc_cores.closedloop import run_closed_loop
from mpc_cores.dgp.control import DgpOsqpController
from mpc_cores.dgp.design import design_dgp
from mpc_cores.dgp.problem import dgp_qp, solve_osqp
from mpc_cores.methods import (METHOD_NAMES, RESTART, SPLITTING, DgpFloatController, SplitController, Tracker,
                               dgp_precondition, dgp_run, ruiz_pow2, split_run, split_setup, splitting_problem)
from mpc_cores.problem import MpcProblem, load_spec
from mpc_cores.quiet import c_output_silenced

REPO = Path(__file__).resolve().parents[1]
EXAMPLES = ("examples/masses_rate_soft.yaml", "examples/masses_state.yaml")
TOLS = (1e-3, 1e-4)
VIOLATION_TOL = 1e-6     # a closed loop's hard-constraint violation above this is shown next to its cost


@dataclass
class Config:
    states: int = 20          # random parameters per example
    cap: int = 5000           # iterations run per variant (reported as "> cap" when not reached)
    imax: tuple = (40, 10)    # iterations per solve in the closed loops (the first is the table's main column)
    steps: int = 40           # closed-loop steps
    hold: int = 10            # steps per reference
    seed: int = 1
    design_sizing: int | None = None   # design_admm's sizing_solves (None: its default); the cycles do not depend on it
    restart: dict = field(default_factory=dict)   # method -> restart scheme, overriding mpc_cores.methods.RESTART

    def restart_of(self, method: str) -> str:
        return "gradient" if method == "dgp" else self.restart.get(method, RESTART[method])

    @classmethod
    def quick(cls) -> "Config":
        return cls(states=5, cap=1000, steps=20, hold=10, design_sizing=4)


def active_steps(qp, W, tol: float = 1e-7) -> dict:
    """Per constraint kind, the number of parameters w (rows of W) whose optimum (OSQP) has a constraint of that
    kind active anywhere on the horizon."""
    p = qp.problem
    nd = qp.N * qp.nu
    idx = np.arange(qp.n)
    in_stage = (idx - nd) % (qp.nx + qp.ns)
    box = qp.kind == BOX
    kinds = {"rate": box & (idx < nd), "input": box & (idx >= nd) & (in_stage >= p.nx) & (in_stage < qp.nx),
             "state": box & (idx >= nd) & (in_stage < p.nx)}
    out = {k: 0 for k in (*kinds, "soft")}
    for w in W:
        with c_output_silenced():
            z = solve_soft_qp_osqp(qp, w, eps=1e-10)
        at = box & ((z <= qp.lo + tol) | (z >= qp.hi - tol))
        for k, m in kinds.items():
            out[k] += bool(np.any(at & m))
        if qp.ns:
            out["soft"] += bool(np.any(np.abs(z[qp.soft_x] - qp.soft_c) >= qp.soft_r - tol))
    out["steps"] = len(W)
    return out


def loop_violation(p: MpcProblem, traj) -> float:
    """Largest violation of the hard constraints along a closed loop: the applied inputs against the input box, the
    plant's states against `hard_states` (the soft state limits are in the cost)."""
    u = np.asarray(traj.u, dtype=float)
    v = float(np.max(np.maximum(u - p.umax, p.umin - u), initial=0.0))
    hs = p.hard_states
    if hs is not None:
        x = np.asarray(traj.x, dtype=float)[:, list(hs.indices)]
        v = max(v, float(np.max(np.maximum(x - hs.xmax, hs.xmin - x), initial=0.0)))
    return max(v, 0.0)


def dgp_applies(p: MpcProblem) -> bool:
    """The DGP takes input and hard state constraints only (mpc_cores.dgp.design)."""
    return p.input_rate is None and p.soft_states is None


def _stats(its: list, cap: int) -> dict:
    v = np.array([np.inf if i is None else i for i in its], dtype=float)
    med = float(np.median(v))
    return {"median": None if not np.isfinite(med) else med,
            "max": None if not np.isfinite(v.max()) else int(v.max()), "reached": int(np.isfinite(v).sum()),
            "of": len(v), "cap": cap, "all": [None if i is None else int(i) for i in its]}


def _fmt_it(s: dict) -> str:
    f = lambda x: f"> {s['cap']}" if x is None else f"{x:g}"  # noqa: E731
    return f"{f(s['median'])} / {f(s['max'])}"


def _hardware_admm(p: MpcProblem, cfg: Config) -> dict:
    kw = {} if cfg.design_sizing is None else {"sizing_solves": cfg.design_sizing}
    # (explicit: a spec written for the DGP, masses_state, sets `accelerated: true` and `lanes` for its own core;
    # the splitting methods' hardware is the papers' one row per cycle)
    p = replace(p, solver={k: v for k, v in p.solver.items() if k != "lanes"})
    d = design_admm(p, accelerated=False, **kw)
    acc = {m: design_admm(p, method=m, accelerated=True, **kw) for m in SPLITTING}
    return {"cycles": int(d.cycles_per_iteration), "multipliers": int(d.multipliers), "rho_vec": d.rho_vec,
            "label": f"design_admm: n_A = {d.n}, P = {d.P}, l_A = {d.lat_add}, l_M = {d.lat_mul}",
            "acc": {m: {"cycles": int(a.cycles_per_iteration), "multipliers": int(a.multipliers)}
                    for m, a in acc.items()}}


def _hardware_dgp(p: MpcProblem) -> dict:
    out = {}
    for acc in (False, True):
        d = design_dgp(p, accelerated=acc)
        out[acc] = {"cycles": int(d.cycles_per_iteration), "multipliers": int(d.multipliers),
                    "warm": bool(d.warm_start), "label": f"design_dgp: n = {d.n}, m = {d.m}, lanes = {d.lanes}"}
    return out


def study_example(p0: MpcProblem, cfg: Config, log=sys.stderr) -> dict:
    """Every variant on one problem: rows of the table and the facts of the example."""
    p = splitting_problem(p0)
    qp = build_admm_qp(p)
    rng = np.random.default_rng(cfg.seed)
    W = rng.uniform(qp.wlo, qp.whi, size=(cfg.states, qp.nw))
    with c_output_silenced():
        Zs = np.array([solve_soft_qp_osqp(qp, w, eps=1e-10) for w in W])
    hw = _hardware_admm(p, cfg)
    x0 = np.zeros(p0.nx)
    # references anywhere in 80 % of their box (no holdability filter, as the ADMM tables): the input box binds
    refs = admm_references(p0, cfg.steps, cfg.hold, cfg.seed)
    holdable = 0.0
    opt_traj = run_closed_loop(p0, AdmmOsqpController(qp), x0, refs)
    opt = opt_traj.cost

    def loops(make) -> dict:
        """(cost, violation) of the closed loop per Imax (nan when a run breaks down)"""
        out = {}
        for imax in cfg.imax:
            with np.errstate(all="ignore"):
                try:
                    tr = run_closed_loop(p0, make(imax), x0, refs)
                    out[imax] = (float(tr.cost), loop_violation(p0, tr))
                except (RuntimeError, FloatingPointError, ValueError):
                    out[imax] = (float("nan"), float("nan"))
        return out
    info = {"name": p0.name, "n_A": qp.n, "nw": qp.nw, "states": cfg.states, "cap": cfg.cap, "imax": cfg.imax,
            "steps": cfg.steps, "hold": cfg.hold, "holdable": holdable, "seed": cfg.seed,
            "augmented_rate": p0.input_rate is None, "loop_opt": {"splitting": opt}, "hardware_admm": hw["label"],
            "loop_active": active_steps(qp, parameters(opt_traj)), "soft": bool(qp.ns)}
    sc = ruiz_pow2(qp)
    info["ruiz"] = {"D_log2": {str(k): int(c) for k, c in zip(*np.unique(sc.d, return_counts=True))},
                    "E_log2": {str(k): int(c) for k, c in zip(*np.unique(sc.e, return_counts=True))}, "cost_log2": sc.c}
    rows = []

    def add(method, acc, pre, step, track, loop_cost, opt_cost, cycles, mults, hardware, secs):
        its = {f"{t:g}": _stats(track.iterations(t), cfg.cap) for t in TOLS}
        m4 = its[f"{TOLS[-1]:g}"]["median"]
        pcts = {str(k): (100.0 * (c - opt_cost) / opt_cost if np.isfinite(c) else None)
                for k, (c, _) in loop_cost.items()}
        row = {"example": p0.name, "method": method, "name": METHOD_NAMES[method], "accelerated": acc,
               "preconditioned": pre, "step": step, "iterations": its, "final_error_max": float(track.final.max()),
               "loop_cost": {str(k): c for k, (c, _) in loop_cost.items()}, "loop_cost_opt": opt_cost,
               "loop_cost_pct": pcts,
               "loop_violation": {str(k): v for k, (_, v) in loop_cost.items()},
               "cycles_per_iteration": cycles, "multipliers": mults, "hardware": hardware,
               "cycles_to_tol": None if (cycles is None or m4 is None) else m4 * cycles,
               "restart": cfg.restart_of(method) if acc else None, "seconds": secs}
        rows.append(row)
        if log is not None:
            loop = ", ".join(f"Imax {k}: {_loop_cell(v, row['loop_violation'][k])}" for k, v in pcts.items())
            print(f"{p0.name:<17} {METHOD_NAMES[method]:<9} {'acc' if acc else 'plain':<5} "
                  f"{'precond' if pre else '-':<7}  1e-3 {_fmt_it(its['0.001']):<15} 1e-4 {_fmt_it(its['0.0001']):<15} "
                  f"loop {loop} ({secs:.1f} s)", file=log, flush=True)

    for method in SPLITTING:
        for pre in (False, True):
            for acc in (False, True):
                st = split_setup(qp, method, hw["rho_vec"], precondition=pre, accelerated=acc)
                t0 = time.perf_counter()
                tr = Tracker(Zs, TOLS)
                with np.errstate(all="ignore"):
                    split_run(st, W, cfg.cap, acc, track=tr, restart=cfg.restart_of(method))
                cost = loops(lambda imax: SplitController(st, imax, acc, restart=cfg.restart_of(method)))  # noqa: B023
                # on the core: every plain variant, and the accelerated ones with the core's restart scheme
                # (accelerated: true; AMA gradient, ADMM and Vu-Condat residual)
                core_acc = acc and cfg.restart_of(method) == RESTART[method]
                hard = ("float only" if acc and not core_acc else
                        "core" + (", accelerated: true" if acc else "") + (", precondition: true" if pre else ""))
                hws = hw["acc"][method] if core_acc else hw
                add(method, acc, pre, st.step_label, tr, cost, opt, hws["cycles"] if hard != "float only" else None,
                    hws["multipliers"] if hard != "float only" else None, hard, time.perf_counter() - t0)

    if dgp_applies(p0):
        dq = dgp_qp(p0)
        Wd = np.hstack([W[:, : p0.nx], W[:, p0.nx + p0.nu:]])          # the same x and r, no u_prev
        Zd = np.array([solve_osqp(dq, w, eps=1e-10)[0] for w in Wd])
        dopt = run_closed_loop(p0, DgpOsqpController(dq), x0, refs).cost
        info["loop_opt"]["dgp"] = dopt
        hd = _hardware_dgp(p0)
        info["hardware_dgp"] = hd[True]["label"]
        info["dgp_warm"] = {"plain": hd[False]["warm"], "accelerated": hd[True]["warm"]}
        dqp, e = dgp_precondition(dq)
        info["dgp_rows_log2"] = {str(k): int(c) for k, c in zip(*np.unique(e, return_counts=True))}
        for pre, q in ((False, dq), (True, dqp)):
            for acc in (False, True):
                t0 = time.perf_counter()
                tr = Tracker(Zd, TOLS)
                dgp_run(q, Wd, cfg.cap, acc, track=tr)
                # warm start as the DGP core's default for the form (plain: cold, accelerated: warm)
                cost = loops(lambda imax: DgpFloatController(q, imax, acc, warm=hd[acc]["warm"]))  # noqa: B023
                add("dgp", acc, pre, "L = 1", tr, cost, dopt, hd[acc]["cycles"], hd[acc]["multipliers"],
                    "core" if not pre else "core, scaled data", time.perf_counter() - t0)
    return {"info": info, "rows": rows}


def run(examples, cfg: Config, log=sys.stderr) -> dict:
    """The study over [(problem), ...]."""
    res = {"date": datetime.date.today().isoformat(), "config": asdict(cfg), "tolerances": list(TOLS),
           "restart": {m: cfg.restart_of(m) for m in (*SPLITTING, "dgp")}, "examples": []}
    for p in examples:
        res["examples"].append(study_example(p, cfg, log))
    return res


def _pct(v) -> str:
    if v is None:
        return "diverged"
    return "0.0000 %" if abs(v) < 5e-5 else f"{v:+.4f} %"


def _loop_cell(pct, viol) -> str:
    """the cost above the OSQP loop's, and the largest violation of the hard constraints when there is one"""
    s = _pct(pct)
    return s if viol is None or not viol > VIOLATION_TOL else f"{s} (violation {viol:.3g})"


def _cell(v, fmt="{:g}") -> str:
    return "-" if v is None else fmt.format(v)


def markdown(res: dict) -> str:
    cfg = res["config"]
    out = [f"# Splitting methods and dual gradient projection ({res['date']})", "",
           f"float64; relative accuracy ||z - z*||_2 / max(||z*||_2, 1e-9) over {cfg['states']} random parameters "
           f"(seed {cfg['seed']}), cold start, at most {cfg['cap']} iterations; closed loop: {cfg['steps']} steps from "
           f"x0 = 0, references every {cfg['hold']} steps, Imax = {' or '.join(map(str, cfg['imax']))} per solve, the "
           "cores' start (splitting family: warm, the previous (y, z, nu) shifted; DGP: the design's default), cost "
           "above the OSQP loop's. Restart: "
           + ", ".join(f"{METHOD_NAMES[k]} {v}" for k, v in res["restart"].items()) + ".", ""]
    for ex in res["examples"]:
        info = ex["info"]
        out += [f"## {info['name']}", ""]
        extra = (" The spec has no input_rate: the splitting family solves it with |du| <= umax - umin and a zero rate "
                 "weight (the same inputs as the DGP's QP)." if info["augmented_rate"] else "")
        loops = ", ".join(f"{k} {v:.6g}" for k, v in info["loop_opt"].items())
        la = info["loop_active"]
        act = ", ".join(f"{k} {la[k]}" for k in ("input", "rate", "state", "soft") if k != "soft" or info["soft"])
        out += [f"n_A = {info['n_A']}; OSQP closed-loop cost: {loops}; steps of that loop whose optimum has an active "
                f"constraint (of {la['steps']}): {act}."
                + extra, f"Hardware: {info['hardware_admm']}"
                + (f"; {info['hardware_dgp']}; DGP closed-loop start: "
                   + ", ".join(f"{k} {'warm' if v else 'cold'}" for k, v in info["dgp_warm"].items())
                   if "hardware_dgp" in info else "; DGP not applicable (it takes "
                   "input and hard state constraints only).") + "", ""]
        loopcols = "".join(f" closed loop, Imax = {k} |" for k in cfg["imax"])
        out += ["| method | accel. | precond. | steps | it. to 1e-3 (median / max) | it. to 1e-4 (median / max) |"
                + loopcols + " cycles / it. | multipliers | cycles to 1e-4 (median) |",
                "|---" * (9 + len(cfg["imax"])) + "|"]
        for r in ex["rows"]:
            its = r["iterations"]
            hw = r["hardware"]
            cyc = "float only" if hw == "float only" else _cell(r["cycles_per_iteration"], "{:d}")
            mul = "float only" if hw == "float only" else _cell(r["multipliers"], "{:d}")
            pct = "".join(f" {_loop_cell(r['loop_cost_pct'][str(k)], r['loop_violation'][str(k)])} |"
                          for k in cfg["imax"])
            yn = lambda b: "yes" if b else "no"  # noqa: E731
            out.append(f"| {r['name']} | {yn(r['accelerated'])} | {yn(r['preconditioned'])} "
                       f"| {r['step']} | {_fmt_it(its['0.001'])} | {_fmt_it(its['0.0001'])} |{pct} {cyc} | {mul} | "
                       f"{_cell(r['cycles_to_tol'], '{:.0f}')} |")
        ru = info["ruiz"]
        out += ["", f"Ruiz factors (log2: count): D {ru['D_log2']}, E {ru['E_log2']}, cost 2^{ru['cost_log2']}"
                + (f"; DGP rows {info['dgp_rows_log2']}" if "dgp_rows_log2" in info else "") + ".", ""]
    return "\n".join(out) + "\n"


def _plain(v):
    if isinstance(v, dict):
        return {str(k): _plain(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    if isinstance(v, np.ndarray):
        return _plain(v.tolist())
    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, float) and not np.isfinite(v):
        return None
    return v


def write(res: dict, out: Path) -> tuple[Path, Path]:
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    md, js = out / "methods.md", out / "methods.json"
    md.write_text(markdown(res))
    js.write_text(json.dumps(_plain(res), indent=1) + "\n")
    return md, js


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="mpc-cores methods", description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="build/reports", help="output folder (methods.md, methods.json)")
    ap.add_argument("--quick", action="store_true", help="5 states, cap 1000, 20 closed-loop steps")
    ap.add_argument("--examples", nargs="+", default=list(EXAMPLES), help="spec files")
    ap.add_argument("--states", type=int)
    ap.add_argument("--cap", type=int)
    ap.add_argument("--imax", type=int, nargs="+", help="closed-loop iterations per solve (default 40 10)")
    ap.add_argument("--restart", nargs="+", default=[], metavar="METHOD=SCHEME",
                    help="restart scheme of an accelerated splitting method (residual, residual-back, gradient, none), "
                         f"default {', '.join(f'{k}={v}' for k, v in RESTART.items())}")
    args = ap.parse_args(argv)
    cfg = Config.quick() if args.quick else Config()
    for k in ("states", "cap"):
        if getattr(args, k) is not None:
            setattr(cfg, k, int(getattr(args, k)))
    if args.imax:
        cfg.imax = tuple(int(v) for v in args.imax)
    for item in args.restart:
        m, _, scheme = item.partition("=")
        if m not in SPLITTING or scheme not in ("residual", "residual-back", "gradient", "none"):
            ap.error(f"--restart {item!r}: expected METHOD=SCHEME with METHOD in {SPLITTING} and SCHEME one of "
                     "residual, residual-back, gradient, none")
        cfg.restart[m] = scheme
    t0 = time.perf_counter()
    probs = [load_spec(Path(e) if Path(e).exists() else REPO / e) for e in args.examples]
    res = run(probs, cfg)
    res["seconds"] = time.perf_counter() - t0
    md, js = write(res, Path(args.out))
    print(f"wrote {md} and {js} ({res['seconds']:.0f} s)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
