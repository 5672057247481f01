"""The command line behind the make targets: `mpc-cores <command>` or `python -m mpc_cores <command>`.

  design   design report of CORE for PROBLEM; with --tol (kinds with certified designs), the certified spec
  verilog  SystemVerilog, core.json, SystemRDL and its exports, FuseSoC core file into --out
  c        portable C99 solvers into --out: bit-exact fixed point and float (mpc_cores.csrc; no sbt, no Java)
  demo     the closed loop with the RTL (Verilator) on the bundled example
  table2   closed-loop cost tables (mpc_bench.tables)
  bench    benchmark report (mpc_bench)
  soak     random configurations against the golden model in Verilator, report in docs/soak/ (mpc_cores.soak)
  gallery  every kind on every plant of examples/ through its design flow and check, into docs/gallery.md
  test     the verification suite (pytest on tests/ of a source checkout)

Every kind of the registry (mpc_cores.registry) is available through --core; refusals are one line
`error: <rule>: <values>` with exit status 2: the options and the spec are checked (mpc_cores.schema) before any
numerics run.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from mpc_cores import registry
from mpc_cores.errors import DesignError, GeneratorError, SpecError
from mpc_cores.flow import REPO
from mpc_cores.schema import check_override, check_size

OVERRIDES = ("P", "frac_bits", "lat_add", "lat_mul", "rounding", "iterations", "format", "latency", "target",
             "problems", "lanes", "early_exit", "exit_tol", "multiplexed")


def refuse(msg: str) -> None:
    """The refusal: one line on stderr (a message spanning lines, e.g. a long array, is joined), exit status 2."""
    msg = " ".join(line.strip() for line in str(msg).splitlines() if line.strip())
    print(f"error: {msg}", file=sys.stderr)
    sys.exit(2)


class _Parser(argparse.ArgumentParser):
    """argparse's own errors (unknown option, missing value) as refusals too."""

    def error(self, message):
        refuse(message)


def _overrides(a, kind) -> dict:
    """The overrides given, each checked by its rule (mpc_cores.schema.check_override) and converted."""
    ov = {k: getattr(a, k, None) for k in OVERRIDES}
    ov = {k: v for k, v in ov.items() if v not in (None, "")}
    bad = sorted(set(ov) - set(kind.overrides))
    if bad:
        refuse(f"CORE={kind.name} takes the overrides {', '.join(kind.overrides)}: got {', '.join(bad)}")
    try:
        return {k: check_override(kind, k, v) for k, v in ov.items()}
    except SpecError as e:
        refuse(str(e))


def _load(path, kind, ov: dict):
    """The spec at `path`; an override of the dense cores' row units P is held to the multiplier limit."""
    from mpc_cores.problem import load_spec

    p = load_spec(path)
    if "P" in ov and "P" in kind.spec_section:
        check_size(p.N, p.nx, p.nu, p.ny, len(p.soft_states.indices) if p.soft_states else 0,
                   p.input_rate is not None, ov["P"])
    return p


def _kind(a):
    try:
        return registry.get(a.core)
    except KeyError as e:
        refuse(e.args[0])


def _design(a, check: bool = True):
    """(kind, design, check line): the design checked (mpc_cores.check) unless the kind has no closed-loop model or
    --no-check; a failing check is refused."""
    from mpc_cores.check import checked_design

    kind = _kind(a)
    ov = _overrides(a, kind)
    try:
        p = _load(a.problem, kind, ov)
        gap = check_override(kind, "gap", a.gap) if getattr(a, "gap", None) not in (None, "") else None
        cycles = check_override(kind, "cycles", a.cycles) if getattr(a, "cycles", None) not in (None, "") else None
        if not check or getattr(a, "no_check", False):
            return kind, kind.design(p, **ov), "Check: skipped (--no-check, CHECK=0)"
        if not kind.has_demo:
            return kind, kind.design(p, **ov), (f"Check: CORE={kind.name} has no closed loop of its own (make test "
                                                f"checks it against its golden model)")
        d, res = checked_design(kind, p, ov, gap, cycles)
        return kind, d, res.line()
    except (DesignError, SpecError) as e:
        refuse(str(e))


def cmd_design(a) -> None:
    """Design report; with --tol, choose the design with guarantees and write the spec `make verilog` takes."""
    if a.tol is None:
        kind, d, line = _design(a)
        print(kind.design_report(d))
        print(line)
        if kind.certificate_fn:
            from mpc_cores.kind import load
            print(load(kind.certificate_fn)(d))
        return
    kind = _kind(a)
    if kind.tol_fn is None:
        with_tol = [k.name for k in registry.kinds().values() if k.tol_fn]
        refuse(f"CORE={kind.name}: TOL (certified design) is available for {', '.join(with_tol)} only: run "
               f"`make design CORE={kind.name}` without TOL")
    from mpc_cores.kind import load

    ov = _overrides(a, kind)
    try:
        tol = check_override(kind, "tol", a.tol)
        _load(a.problem, kind, ov)
        load(kind.tol_fn)(kind, a.problem, tol, ov, a.out)
    except (DesignError, SpecError) as e:
        refuse(str(e))


def cmd_verilog(a) -> None:
    from mpc_cores.flow import generate
    from mpc_cores.progress import stages

    kind, d, line = _design(a)
    out = Path(a.out or f"build/{kind.name}_{d.name}_p{d.P}")
    try:
        with stages(["elaborate (sbt) and export"], f"verilog {kind.name}") as step:
            step("elaborate (sbt) and export")
            core = generate(kind, [(d, out)])[0]
    except GeneratorError as e:
        refuse(str(e))
    print(kind.design_report(d, core))
    print(line)
    files = [core["sv"], "core.json"] + [core[k] for k in ("rdl", "header", "regmap_doc", "ipxact",
                                                           "ipxact_component", "fusesoc_core") if core.get(k)]
    files += core.get("driver", [])
    print("wrote " + ", ".join(str(out / f) for f in files))


def cmd_c(a) -> None:
    from mpc_cores.kind import load

    kind = _kind(a)
    if kind.c_fn is None:
        with_c = [k.name for k in registry.kinds().values() if k.c_fn]
        refuse(f"CORE={kind.name}: C solvers are generated for the cores {', '.join(with_c)}")
    kind, d, line = _design(a)
    out = Path(a.out or f"build/{kind.name}_{d.name}_p{d.P}")
    print(line)
    try:
        files = load(kind.c_fn)(d, out)
    except DesignError as e:
        refuse(str(e))
    print("wrote " + ", ".join(str(f) for f in files))


def cmd_split(a) -> None:
    from mpc_cores.kind import load

    kind = _kind(a)
    if kind.split_fn is None:
        with_split = [k.name for k in registry.kinds().values() if k.split_fn]
        refuse(f"CORE={kind.name}: the heterogeneous split is generated for the cores {', '.join(with_split)}")
    kind, d, line = _design(a)
    out = Path(a.out or f"build/{kind.name}_{d.name}_p{d.P}_split")
    print(line)
    try:
        files, report = load(kind.split_fn)(d, out)
    except (DesignError, GeneratorError) as e:
        refuse(str(e))
    print(report)
    print("wrote " + ", ".join(str(f) for f in files))


def cmd_demo(a) -> None:
    from mpc_cores.demo import DemoError, run_demo

    kind, d, line = _design(a)
    if not kind.has_demo:
        with_demo = [k.name for k in registry.kinds().values() if k.has_demo]
        refuse(f"CORE={kind.name}: the closed-loop demo runs the cores {', '.join(with_demo)}; "
               f"`make test` checks CORE={kind.name} against its golden model")
    print(kind.design_report(d))
    print(line)
    try:
        steps, hold = kind.demo_steps
        table = run_demo(kind, d, Path(a.problem), Path(a.out), a.steps or steps, a.hold or hold, a.seed)
    except (DemoError, GeneratorError) as e:
        refuse(str(e))
    print(table)
    print(f"\nwrote {Path(a.out) / 'report.md'}, {Path(a.out) / 'closed_loop.png'}, {Path(a.out) / 'core'}")


def _forward(module: str, argv: list[str]) -> None:
    from mpc_cores.kind import load

    load(module).main(argv)


def cmd_test(rest: list[str]) -> None:
    import subprocess

    tests = REPO / "tests"
    if not tests.is_dir():
        refuse(f"the test suite lives in a source checkout: no {tests}")
    sys.exit(subprocess.call([sys.executable, "-m", "pytest", str(tests), "-q", *rest], cwd=REPO))


def main(argv=None) -> None:
    argv = list(sys.argv[1:] if argv is None else argv)
    kinds = registry.names()

    def who(opt: str) -> str:
        """the kinds that take override `opt`"""
        return ", ".join(n for n, k in registry.kinds().items() if opt in k.overrides)

    ap = _Parser(prog="mpc-cores", description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    for name, what in (("design", "design report (with --tol: certified design)"),
                       ("verilog", "generate a core"), ("c", "portable C99 solvers (bit-exact fixed point, float)"),
                       ("split", "heterogeneous split: the linear-system step's hardware block and the C around it"),
                       ("demo", "closed loop with the RTL")):
        s = sub.add_parser(name, help=what)
        s.add_argument("--core", default="fgm", help=f"core kind: {', '.join(kinds)}")
        s.add_argument("--problem", default=str(REPO / "examples/masses.yaml"))
        # the overrides are text here, checked and converted by their rules (mpc_cores.schema)
        s.add_argument("--P")
        s.add_argument("--frac-bits", dest="frac_bits")
        s.add_argument("--lat-add", dest="lat_add")
        s.add_argument("--lat-mul", dest="lat_mul")
        s.add_argument("--rounding", help="truncate or nearest")
        s.add_argument("--iterations")
        s.add_argument("--format", help=f"float format ({who('format')}): binary32, binary16 or e<E>m<M>, e.g. "
                                        "e8m17")
        s.add_argument("--latency", help=f"float operator latencies ({who('latency')}): compact (fewest cycles) or "
                                         "fast (150 MHz on the LFE5U-85F)")
        s.add_argument("--target", help=f"FPGA family ({who('target')}): generic, ecp5 or xilinx7 (the fixed-point "
                       "cores' multipliers; the float cores' memories from DP16KD with their output register)")
        s.add_argument("--problems", help=f"K_p, problems interleaved on the row units ({who('problems')}): 1 to 16")
        s.add_argument("--lanes", help=f"multipliers per row unit ({who('lanes')}): a row's dot product in "
                                       "ceil(columns / lanes) chunks; 'fit': the fewest chunks whose products fit "
                                       "the LFE5U-85F's 156 MULT18X18D")
        s.add_argument("--early-exit", dest="early_exit", help=f"{who('early_exit')}: build the exit test (true or false): a solve "
                       "ends when two iterations in a row move no word of z by EXIT_TOL or more, else at IMAX")
        s.add_argument("--exit-tol", dest="exit_tol", help=f"{who('exit_tol')}: the exit test's tolerance in the units of u "
                       "(EXIT_TOL's reset value; builds the test)")
        s.add_argument("--multiplexed", help=f"{who('multiplexed')}: parallel multiplexed MPC (true or false): each "
                       "channel solves one input's single-input problem, the closed loop keeps the plan")
        s.add_argument("--out")
        s.add_argument("--gap", help="design check target: closed-loop cost at most this many percent above the "
                                     "optimum; the flow chooses the iteration count (default: the spec's check.gap)")
        s.add_argument("--cycles", help="cycles per solve the iteration count may reach (default: check.cycles)")
        s.add_argument("--no-check", dest="no_check", action="store_true",
                       help="emit without the design check (golden model against the optimum)")
        if name == "design":
            s.add_argument("--tol", help="target ||z_fixed - z*||_2 over the state box")
        if name == "demo":
            steps = ", ".join(f"{n} {k.demo_steps[0]}" for n, k in registry.kinds().items() if k.has_demo)
            hold = ", ".join(f"{n} {k.demo_steps[1]}" for n, k in registry.kinds().items() if k.has_demo)
            s.add_argument("--steps", type=int, default=None, help=f"closed-loop steps (default: the kind's: {steps})")
            s.add_argument("--hold", type=int, default=None, help=f"steps a reference holds (default: {hold})")
            s.add_argument("--seed", type=int, default=0)
    for name, what in (("table2", "closed-loop cost tables (options: see `mpc-cores table2 --help`)"),
                       ("bench", "benchmark report (options: see `mpc-cores bench --help`)"),
                       ("soak", "random configurations against the golden model (see `mpc-cores soak --help`)"),
                       ("gallery", "every kind on every plant of examples/ into docs/gallery.md (see --help)"),
                       ("methods", "the methods of 004 compared in float64 (see `mpc-cores methods --help`)"),
                       ("test", "the verification suite (pytest options follow)")):
        sub.add_parser(name, help=what, add_help=False)
    if argv and argv[0] in ("table2", "bench", "soak", "gallery", "methods", "test"):
        cmd, rest = argv[0], argv[1:]
        if cmd == "test":
            return cmd_test(rest)
        return _forward({"table2": "mpc_bench.tables", "bench": "mpc_bench.bench", "soak": "mpc_cores.soak.run",
                         "gallery": "mpc_bench.gallery", "methods": "mpc_cores.methods_table"}[cmd], rest)
    a = ap.parse_args(argv)
    if a.cmd == "demo" and not a.out:
        a.out = "build/demo"
    {"design": cmd_design, "verilog": cmd_verilog, "c": cmd_c, "split": cmd_split, "demo": cmd_demo}[a.cmd](a)


if __name__ == "__main__":
    main()
