"""Command line behind the Makefile targets: `python -m verif.cli verilog|design|demo ...`."""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from verif.flow import REPO, GeneratorError


def _overrides(a) -> dict:
    ov = {}
    for k in ("P", "frac_bits", "lat_add", "lat_mul", "rounding", "iterations"):
        v = getattr(a, k, None)
        if v not in (None, ""):
            ov[k] = v
    return ov


CORES = ("fgm", "admm", "minres")


def _design(a):
    from verif.admm.design import design_admm
    from verif.fgm.design import DesignError, design_fgm
    from verif.problem import SpecError, load_spec

    if a.core not in CORES:
        sys.exit(f"error: CORE={a.core}: the cores are {', '.join(CORES)}")
    if a.core == "minres":
        from verif.minres.design import design_minres
        try:
            return design_minres(load_spec(a.problem), **_overrides(a))
        except (DesignError, SpecError) as e:
            sys.exit(f"error: {e}")
    try:
        return (design_fgm if a.core == "fgm" else design_admm)(load_spec(a.problem), **_overrides(a))
    except (DesignError, SpecError) as e:
        sys.exit(f"error: {e}")


def _flow(core: str):
    """(generate, design_report) of a core."""
    from verif import flow

    if core == "admm":
        from verif.admm.report import design_report
        return flow.generate_admm, design_report
    if core == "minres":
        from verif.minres.report import design_report
        return flow.generate_minres, design_report
    from verif.fgm.report import design_report
    return flow.generate_fgm, design_report


def cmd_design(a) -> None:
    """Design report; with --tol, choose frac_bits and Imax with guarantees and write the spec `make verilog` takes."""
    import yaml

    from verif.fgm.certify import certificate_report, certify, design_for_tolerance
    from verif.fgm.design import DesignError
    from verif.fgm.report import design_report
    from verif.problem import SpecError, load_spec

    if a.tol is None:
        d = _design(a)
        if a.core == "minres":
            print(_flow("minres")[1](d))
            return
        if a.core == "admm":
            print(_flow("admm")[1](d))
            return
        print(design_report(d))
        print(certificate_report(d, certify(d, None)))
        return
    if a.core != "fgm":
        sys.exit(f"error: CORE={a.core}: TOL (certified design) is available for the FGM core only; 002 gives no "
                 "bound on the ADMM multipliers (IV-C2): run `make design CORE=admm` without TOL")
    try:
        p = load_spec(a.problem)
        d, cert, log = design_for_tolerance(p, a.tol, **_overrides(a))
    except (DesignError, SpecError) as e:
        sys.exit(f"error: {e}")
    print(design_report(d))
    print(certificate_report(d, cert, log))
    spec = yaml.safe_load(Path(a.problem).read_text())
    spec.setdefault("name", p.name)
    spec["solver"] = dict(spec.get("solver") or {}, frac_bits=d.b, iterations=d.iterations, P=d.P,
                          lat_add=d.lat_add, lat_mul=d.lat_mul, rounding=d.rounding, tol=float(a.tol))
    out = Path(a.out or f"build/design/{p.name}_tol{a.tol:g}.yaml")
    out.parent.mkdir(parents=True, exist_ok=True)
    header = (f"# Designed by `make design TOL={a.tol:g}` from {a.problem}: frac_bits and iterations certified by\n"
              f"# eq. (7) and eq. (20) of 002 for ||z_fixed - z*||_2 <= {a.tol:g} over the state box (cold start).\n")
    out.write_text(header + yaml.safe_dump(spec, sort_keys=False))
    print(f"wrote {out}  (next: make verilog PROBLEM={out})")


def cmd_verilog(a) -> None:
    d = _design(a)
    generate, design_report = _flow(a.core)
    out = Path(a.out or f"build/{a.core}_{d.name}_p{d.P}")
    try:
        core = generate([(d, out)])[0]
    except GeneratorError as e:
        sys.exit(f"error: {e}")
    print(design_report(d, core))
    print(f"wrote {out / core['sv']}, {out / 'core.json'}, {out / core['header']}")


def cmd_demo(a) -> None:
    if a.core != "fgm":
        sys.exit(f"error: CORE={a.core}: the demo runs the FGM core; the ADMM closed loop in Verilator is in "
                 "`make test` (tests/test_admm_rtl.py)")
    from verif.closedloop import FixedController, OsqpController, reference_schedule, run_closed_loop
    from verif.fgm.report import design_report
    from verif.flow import generate_fgm
    from verif.sim import run_cocotb

    d = _design(a)
    p = d.problem
    out = Path(a.out)
    core = generate_fgm([(d, out / "core")])[0]
    print(design_report(d))
    refs = reference_schedule(p, a.steps, a.hold, a.seed)
    x0 = np.zeros(p.nx)
    print(f"\nClosed loop: {a.steps} steps of {p.Ts} s, references changing every {a.hold} steps, x0 = 0")
    t_opt = run_closed_loop(p, OsqpController(p), x0, refs)
    golden = FixedController(d)
    t_fix = run_closed_loop(p, golden, x0, refs)
    result = out / "closed_loop_rtl.json"
    result.unlink(missing_ok=True)
    tests, failed = run_cocotb(out / "core" / core["sv"], core["module"], "verif.closedloop_tb", out / "sim",
                               {"CORE_OUT": str((out / "core").resolve()), "CL_SPEC": str(Path(a.problem).resolve()),
                                "CL_STEPS": str(a.steps), "CL_HOLD": str(a.hold), "CL_SEED": str(a.seed),
                                "CL_RESULT": str(result.resolve())})
    if tests != 1 or failed or not result.exists():
        sys.exit(f"error: the RTL closed loop failed: see {out / 'sim' / 'sim.log'}")
    rtl = json.loads(result.read_text())
    same = rtl["words"] == golden.words
    u_rtl = np.array(rtl["u"])
    pct = lambda c: 100.0 * (c - t_opt.cost) / t_opt.cost  # noqa: E731
    umin, umax = p.umin, p.umax
    viol = float(np.max(np.maximum(u_rtl - umax, umin - u_rtl)))
    lines = [
        "",
        f"| controller | closed-loop cost | above optimum |",
        f"|---|---|---|",
        f"| float64 OSQP (optimal) | {t_opt.cost:.6f} | 0 % |",
        f"| golden model, b = {d.b}, Imax = {d.iterations} | {t_fix.cost:.6f} | {pct(t_fix.cost):.4f} % |",
        f"| RTL (Verilator, AXI) | {rtl['cost']:.6f} | {pct(rtl['cost']):.4f} % |",
        "",
        f"RTL words equal the golden model's in all {a.steps} steps: {'yes' if same else 'NO'}",
        f"max |u_rtl - u_optimal| = {np.max(np.abs(u_rtl - t_opt.u)):.3g}; input bound violation {max(viol, 0):.3g}",
        f"status after the run: {', '.join(k for k, v in rtl['status'].items() if v) or 'clear'}",
        f"latency: {core['cycles_per_solve']} cycles per solve ({core['cycles_per_iteration']} per iteration) = "
        f"{core['cycles_per_solve'] / 400:.3f} us at 400 MHz, {core['cycles_per_solve'] / 230:.3f} us at 230 MHz",
    ]
    report = design_report(d) + "\n" + "\n".join(lines) + "\n"
    print("\n".join(lines))
    (out / "report.md").write_text(report)
    _plot(out / "closed_loop.png", p, t_opt, np.array(rtl["x"]), u_rtl, refs)
    print(f"\nwrote {out / 'report.md'}, {out / 'closed_loop.png'}, {out / 'core'}")
    if not same:
        sys.exit("error: the RTL and the golden model disagree")


def _plot(path, p, t_opt, x_rtl, u_rtl, refs) -> None:
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


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(prog="python -m verif.cli")
    sub = ap.add_subparsers(dest="cmd", required=True)
    for name in ("design", "verilog", "demo"):
        s = sub.add_parser(name)
        s.add_argument("--core", default="fgm")
        s.add_argument("--problem", default=str(REPO / "examples/masses.yaml"))
        s.add_argument("--P", type=int)
        s.add_argument("--frac-bits", dest="frac_bits", type=int)
        s.add_argument("--lat-add", dest="lat_add", type=int)
        s.add_argument("--lat-mul", dest="lat_mul", type=int)
        s.add_argument("--rounding", choices=["truncate", "nearest"])
        s.add_argument("--iterations", type=int)
        s.add_argument("--out")
        if name == "design":
            s.add_argument("--tol", type=float, help="target ||z_fixed - z*||_2 over the state box")
        if name == "demo":
            s.add_argument("--steps", type=int, default=60)
            s.add_argument("--hold", type=int, default=20)
            s.add_argument("--seed", type=int, default=0)
    a = ap.parse_args(argv)
    if a.cmd == "demo" and not a.out:
        a.out = "build/demo"
    {"design": cmd_design, "verilog": cmd_verilog, "demo": cmd_demo}[a.cmd](a)


if __name__ == "__main__":
    main()
