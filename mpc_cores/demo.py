"""`make demo`: generate a core for a problem and run it in a closed loop with its Verilator model, driven through
its AXI interfaces, beside the optimal controller (float64, OSQP) and the bit-exact golden model."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from mpc_cores.closedloop import reference_schedule, run_closed_loop
from mpc_cores.flow import generate
from mpc_cores.progress import stages
from mpc_cores.sim import run_cocotb


class DemoError(RuntimeError):
    """The RTL closed loop failed or disagrees with the golden model."""


def run_demo(kind, d, spec: Path, out: Path, steps: int, hold: int, seed: int) -> str:
    """The closed loop of `kind`'s core for design `d`; writes report.md, closed_loop.png and the core into `out`
    and returns the report's table. Raises DemoError when the RTL fails or its words differ from the model's."""
    p = d.problem
    out = Path(out)
    result = out / "closed_loop_rtl.json"
    result.unlink(missing_ok=True)
    with stages(["generate (sbt)", "optimal and golden loops", "RTL loop (Verilator)"], "demo") as step:
        step("generate (sbt)")
        core = generate(kind, [(d, out / "core")])[0]
        optimal, golden, holdable = kind.controllers(d)
        refs = reference_schedule(p, steps, hold, seed, holdable=holdable)
        x0 = np.zeros(p.nx)
        step("optimal and golden loops")
        t_opt = run_closed_loop(p, optimal, x0, refs)
        t_fix = run_closed_loop(p, golden, x0, refs)
        # a design's conventional counterpart (the multiplexed interior-point core's), its golden model on the same
        # references
        conv = getattr(d, "conventional", lambda: None)()
        beside = [] if conv is None else [(f"conventional MPC: golden model, {conv.label()}",
                                           run_closed_loop(p, kind.controllers(conv)[1], x0, refs),
                                           kind.facts(conv)["cycles"])]
        step("RTL loop (Verilator)")
        tests, failed = run_cocotb(out / "core" / core["sv"], core["module"], "mpc_cores.closedloop_tb", out / "sim",
                                   {"CORE_OUT": str((out / "core").resolve()), "CL_SPEC": str(Path(spec).resolve()),
                                    "CL_STEPS": str(steps), "CL_HOLD": str(hold), "CL_SEED": str(seed),
                                    "CL_HOLDABLE": str(holdable), "CL_RESULT": str(result.resolve())})
    print(f"\nClosed loop: {steps} steps of {p.Ts} s, references changing every {hold} steps, x0 = 0")
    if tests != 1 or failed or not result.exists():
        raise DemoError(f"the RTL closed loop failed: see {out / 'sim' / 'sim.log'}")
    rtl = json.loads(result.read_text())
    same = rtl["words"] == golden.words
    u_rtl = np.array(rtl["u"])

    def pct(c):
        return 100.0 * (c - t_opt.cost) / t_opt.cost

    viol = float(np.max(np.maximum(u_rtl - p.umax, p.umin - u_rtl)))
    lines = [
        "",
        "| controller | closed-loop cost | above optimum |",
        "|---|---|---|",
        f"| float64 OSQP (optimal) | {t_opt.cost:.6f} | 0 % |",
        *(f"| {label} | {t.cost:.6f} | {pct(t.cost):.4f} % |" for label, t, _ in beside),
        f"| golden model, {d.label()} | {t_fix.cost:.6f} | {pct(t_fix.cost):.4f} % |",
        f"| RTL (Verilator, AXI) | {rtl['cost']:.6f} | {pct(rtl['cost']):.4f} % |",
        "",
        f"RTL words equal the golden model's in all {steps} steps: {'yes' if same else 'NO'}",
        f"max |u_rtl - u_optimal| = {np.max(np.abs(u_rtl - t_opt.u)):.3g}; input bound violation {max(viol, 0):.3g}",
        f"status after the run: {', '.join(k for k, v in rtl['status'].items() if v) or 'clear'}",
    ]
    cps = core.get("cycles_per_solve")
    if core.get("multiplexed"):
        rounds = getattr(golden.mux, "rounds_run", 0)
        lines.append(f"latency per sample: {core['latency_cycles_per_sample']} cycles per round of the {core['inputs']} "
                     f"copies (this loop ran {rounds} rounds in {steps} samples: one per sample, more at a reference "
                     f"change and at the first)" +
                     "".join(f"; {label.split(':')[0]}: {cyc} cycles per sample" for label, _, cyc in beside))
    elif cps is not None:
        per_it = f" ({core['cycles_per_iteration']} per iteration)" if "cycles_per_iteration" in core else ""
        # at the clocks of the core's paper (002: 400 and 230 MHz; core.json may name others)
        clocks = core.get("reference_clocks_mhz", [400, 230])
        lines.append(f"latency: {cps} cycles per solve{per_it} = " +
                     ", ".join(f"{cps / f:.3f} us at {f} MHz" for f in clocks) +
                     " (the clocks of the core's paper; the Fmax this build places at is the bench's: docs/bench/)")
        its = getattr(golden, "iterations", None)
        if core.get("early_exit") and its:   # the exit test: the iterations the loop's solves ran
            cyc = [core["solve_overhead_cycles"] + i * core["cycles_per_iteration"] for i in its]
            lines.append(f"exit test (EXIT_TOL {core['exit_tol']} LSB): iterations per step median {np.median(its):g}, "
                         f"max {max(its)} of IMAX {core['iterations']}; cycles median {np.median(cyc):g}, max {max(cyc)}")
    table = "\n".join(lines)
    (out / "report.md").write_text(kind.design_report(d, core) + "\n" + table + "\n")
    plot(out / "closed_loop.png", p, t_opt, np.array(rtl["x"]), u_rtl, refs)
    if not same:
        k = next((i for i, (a, b) in enumerate(zip(rtl["words"], golden.words)) if a != b),
                 min(len(rtl["words"]), len(golden.words)))
        got = rtl["words"][k] if k < len(rtl["words"]) else None
        exp = golden.words[k] if k < len(golden.words) else None
        raise DemoError(f"the RTL and the golden model disagree: first at step {k}: RTL words {got}, model {exp}")
    return table


def plot(path, p, t_opt, x_rtl, u_rtl, refs) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    T = len(refs)
    t = np.arange(T + 1) * (p.Ts or 1.0)
    fig, ax = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    y_rtl = x_rtl @ p.C.T if p.C is not None else x_rtl
    y_opt = t_opt.x @ p.C.T if p.C is not None else t_opt.x
    for i in range(y_rtl.shape[1]):
        (line,) = ax[0].plot(t, y_rtl[:, i], label=f"y{i} RTL")
        ax[0].plot(t, y_opt[:, i], "k:", lw=0.8)
        if p.ny:
            ax[0].step(t[:-1], refs[:, i], "--", where="post", lw=0.8, color=line.get_color())
    ax[0].set_ylabel("outputs (dotted: optimal,\ndashed: reference)")
    for i in range(u_rtl.shape[1]):
        ax[1].step(t[:-1], u_rtl[:, i], where="post")
    ax[1].axhline(float(np.max(p.umax)), color="r", lw=0.8)
    ax[1].axhline(float(np.min(p.umin)), color="r", lw=0.8)
    ax[1].set_ylabel("inputs (RTL)")
    ax[1].set_xlabel("time [s]")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
