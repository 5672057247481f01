"""The interface every core kind implements, so that the command line, the make targets, the generation flow, the
tables and the benchmark iterate over the registry (mpc_cores.registry) instead of branching on names.

A core kind provides, in its own subpackage mpc_cores/<kind>/ and its Scala package src/main/scala/<kind>/:

  name, title          CORE=<name> and a one-line description
  spec_section         the keys of the spec's `solver:` section it reads (documentation and refusals)
  spec_rules           the rules of its own `solver:` keys, those no other kind reads (the shared ones are
                       mpc_cores.schema.SHARED_SOLVER); the schema is assembled from them
  overrides            the command-line overrides it accepts (P, frac_bits, lat_add, ...)
  generator_main       the Scala object sbt runs: `<main> <config.json> <outDir> [...]`, writing the SV, hw.json
                       and the SystemRDL register description
  design(problem, **o) the design flow: a design object with .name, .P and .write_config(path)
  core_json(d, hw)     core.json from the design and the generator's hw.json (checked against each other)
  design_report(d, c)  the design report (text), with the generated core's facts when c is given
  golden_model(cfg)    the bit-exact model of a generated core, from its config.json
  testbench            the cocotb module of verif/ with its scenarios, `cycle_test` among them (the cycle contract)
  bench                the module of mpc_bench with its section of the benchmark
  small                its small core (mpc_cores.small.SmallCore), for the per-kind protocol suites (fuzz,
                       registers, assertions) and a case of its RTL suite; mpc_cores.<name>.kind:small by default
  docs_page, lpf       its reference page (docs/<name>.md) and the clock constraints of the core as a top level
                       (constraints/<name>_core.lpf), by default
  fuzz                 its protocol-fuzz family (verif.fuzz.kinds.Family: adapter, testbench class, the protocol
                       violations forced into it), verif.<name>.fuzz:FAMILY by default
  soak                 its random configurations and testbench knobs for `make soak` (mpc_cores.soak.space.SoakSpace)
  constraints          the spec's constraint sections it enforces (of SECTIONS); a spec with any other is refused
  facts(d)             report module's facts(d): iterations, cycles per solve, multipliers, words (mpc_cores.check)
  certificate(d)       optional: the guarantees of a design, printed by `make design` after its report
  controllers(d)       optional: the optimal (float64) and golden-model controllers of the closed loop and the
                       reference schedule's holdability, for `make demo` with the RTL (None: no demo)
  rtl_controller(dut, problem)  optional: async, the closed loop's RTL side inside cocotb (the testbench driver,
                       reset, and a controller recording `.words` in the golden controller's layout); without it
                       mpc_cores.closedloop_tb drives a fixed-point core (FGM) through mpc_cores.driver.TB
  holdable             the closed-loop testbench's default reference holdability (mpc_cores.closedloop)
  c_fn(d, out_dir)     optional: `make c`, the portable C99 solvers of a design (bit-exact fixed point and float,
                       mpc_cores.csrc), returning the paths written (None: the kind has no C solver)
  split_fn(d, out_dir) optional: `make split`, the heterogeneous split of 004: the hardware block of the
                       linear-system step and the C that calls it, returning (paths written, report text)
  driver, answer_status_word  whether `make verilog` writes the C driver (mpc_cores.cdriver), and whether an
                       answer ends with a status word after z

Modules are named by strings and imported on use, so the registry imports no core package and no package
imports the testbenches or the benchmark.
"""
from __future__ import annotations

import importlib
from dataclasses import dataclass, field

from mpc_cores.errors import DesignError

# the spec's constraint sections beyond the input box, which every kind enforces
SECTIONS = ("input_rate", "soft_states", "hard_states")


def load(ref: str):
    """`package.module:attribute` (or a module name alone) -> the object."""
    mod, _, attr = ref.partition(":")
    obj = importlib.import_module(mod)
    for a in attr.split(".") if attr else ():
        obj = getattr(obj, a)
    return obj


@dataclass(frozen=True)
class CoreKind:
    """A core kind; the module references default to the layout's conventions for `name`: design function
    mpc_cores.<name>.design:design_<name>, report module mpc_cores.<name>.report, testbench verif.<name>.tb,
    benchmark section mpc_bench.<name>, generator main <name>.<Name>Main, soak space mpc_cores.<name>.soak:SOAK."""
    name: str
    title: str
    model_fn: str                  # "module:callable" taking the config.json dict
    generator_main: str = ""
    design_fn: str = ""            # "module:function"
    report_module: str = ""        # module with core_json(d, hw) and design_report(d, core=None)
    testbench: str = ""            # cocotb test module
    bench: str = ""                # benchmark section module
    soak: str = ""                 # "module:attribute", the SoakSpace of `make soak`
    fuzz: str = ""                 # "module:attribute", the protocol fuzz's Family (verif.fuzz.kinds)
    small: str = ""                # "module:function() -> mpc_cores.small.SmallCore", the per-kind suites' core
    docs_page: str = ""            # its reference page (docs/verification.md's template)
    lpf: str = ""                  # the nextpnr clock constraints of the core as a top level (make bench)
    spec_section: tuple[str, ...] = ()
    spec_rules: dict = field(default_factory=dict, hash=False, compare=False)  # key -> mpc_cores.schema rule
    overrides: tuple[str, ...] = ("P", "frac_bits", "lat_add", "lat_mul", "rounding", "iterations", "target")
    controllers_fn: str | None = None  # "module:function(design) -> (optimal, golden, holdable)" for the demo
    tol_fn: str | None = None      # "module:function(kind, spec_path, tol, overrides, out)": `make design TOL=...`
    cycle_test: str = "cycle_contract"  # the testbench's cocotb test that measures the cycle contract
    certificate_fn: str | None = None  # "module:function(design) -> text" printed after the design report
    rtl_controller_fn: str | None = None  # "module:async function(dut, problem) -> (tb, controller)", tb reset
    c_fn: str | None = None        # "module:function(design, out_dir) -> list of paths": `make c`
    split_fn: str | None = None    # "module:function(design, out_dir) -> (paths, report)": `make split`
    constraints: tuple[str, ...] = ()  # the constraint sections of SECTIONS the core enforces
    driver: bool = False           # `make verilog` writes the C driver (mpc_cores.cdriver): fixed-point stream words
    demo_steps: tuple[int, int] = (60, 20)  # `make demo`'s closed loop: steps, and steps a reference holds
    holdable: float = 0.9          # the closed loop's references: the share of the input box their steady state needs
    answer_status_word: bool = False  # an answer ends with a status word after z (the driver reads it)

    def __post_init__(self):
        n = self.name
        for attr, default in (("generator_main", f"{n}.{n.capitalize()}Main"),
                              ("design_fn", f"mpc_cores.{n}.design:design_{n}"),
                              ("report_module", f"mpc_cores.{n}.report"), ("testbench", f"verif.{n}.tb"),
                              ("bench", f"mpc_bench.{n}"), ("soak", f"mpc_cores.{n}.soak:SOAK"),
                              ("fuzz", f"verif.{n}.fuzz:FAMILY"), ("small", f"mpc_cores.{n}.kind:small"),
                              ("docs_page", f"docs/{n}.md"), ("lpf", f"constraints/{n}_core.lpf")):
            if not getattr(self, attr):
                object.__setattr__(self, attr, default)

    def design(self, problem, **overrides):
        refuse_sections(problem, self.name, self.constraints)
        return load(self.design_fn)(problem, **{k: v for k, v in overrides.items() if k in self.overrides})

    def facts(self, design) -> dict:
        return load(self.report_module).facts(design)

    def core_json(self, design, hw: dict) -> dict:
        return load(self.report_module).core_json(design, hw)

    def design_report(self, design, core: dict | None = None) -> str:
        return load(self.report_module).design_report(design, core)

    def small_core(self):
        """Its small core (mpc_cores.small.SmallCore)."""
        return load(self.small)()

    def golden_model(self, cfg: dict):
        return load(self.model_fn)(cfg)

    @property
    def has_demo(self) -> bool:
        return self.controllers_fn is not None

    def controllers(self, design):
        return load(self.controllers_fn)(design)

    async def rtl_controller(self, dut, problem):
        return await load(self.rtl_controller_fn)(dut, problem)


def refuse_sections(problem, kind: str, enforced: tuple[str, ...]) -> None:
    """A spec with a constraint section the core does not enforce is refused, naming the section: a core never
    drops a constraint (docs/spec.md lists the kinds that enforce each section)."""
    extra = [k for k in SECTIONS if getattr(problem, k, None) is not None and k not in enforced]
    if extra:
        raise DesignError(f"CORE={kind} enforces the input box{''.join(' and ' + e for e in enforced)} only: the "
                          f"spec has {' and '.join(extra)}, which it would not enforce (the kinds that do: "
                          f"docs/spec.md#constraint-sections)")
