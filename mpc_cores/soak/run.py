"""`make soak CORE=<kind> SOLVES=<solves>`: random configurations of a core kind, each designed, generated and run in
Verilator against its bit-exact golden model, word for word, over many random solves with random idle and
backpressure; a report under docs/soak/ (mpc_cores.soak.report).

What is random per kind comes from the kind (CoreKind.soak, a SoakSpace in mpc_cores/<kind>/soak.py): how to draw
a configuration, which test of its testbench checks random solves and with which knob. Configuration i of seed s
is drawn from its own seed s * 10^6 + i, which also seeds the testbench (CORE_SEED): that number and the solves
reproduce a configuration (`--config-seed`). A configuration the design flow or the generator refuses is counted
as refused; one whose test fails is a mismatch (an assertion: a word, a flag, a count) or a hang (the simulated-time
limit, CORE_TIMEOUT_MS, set to several times the solves' expected cycles).
"""
from __future__ import annotations

import argparse
import json
import math
import shutil
import time
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mpc_cores import registry
from mpc_cores.errors import DesignError, GeneratorError, SpecError
from mpc_cores.flow import REPO, generate
from mpc_cores.kind import load

BUILD = REPO / "build" / "soak"
DOCS = REPO / "docs" / "soak"
CONFIG_SEEDS = 10**6       # configuration i of seed s: s * CONFIG_SEEDS + i
CLOCK_NS = 10              # the testbenches' clock period
TIMEOUT_MARGIN = 4         # the simulated-time limit over the solves' expected cycles
TIMEOUT_BASE_MS = 2        # plus this, for reset and register set-up
MAX_REFUSED = 50           # refusals in a row that end a soak (the random space does not fit the design flow)


@dataclass
class Outcome:
    """A configuration and what became of it: passed, mismatch, hang, error (the simulation ended otherwise),
    refused (by the design flow) or refused_generator."""
    index: int
    seed: int
    config: dict                     # spec and design keywords (mpc_cores.soak.space.Config)
    summary: dict                    # sizes, sets and options in a report row
    status: str = "pending"
    solves: int = 0                  # solves checked word for word
    requested: int = 0
    module: str = ""
    reason: str = ""                 # the refusal or the failure's message
    detail: str = ""                 # the failure's whole text (traceback)
    sim_ms: float = 0.0              # simulated time
    cycles: int = 0                  # simulated clock cycles
    timeout_ms: int = 0
    seconds: float = 0.0             # wall time of generation, build and simulation
    log: str = ""

    @property
    def failed(self) -> bool:
        return self.status in ("mismatch", "hang", "error")


@dataclass
class Soak:
    kind: str
    seed: int
    requested: int
    per_config: int
    build: Path = BUILD              # generated cores and Verilator builds: <build>/<kind>/c<seed>
    outcomes: list[Outcome] = field(default_factory=list)
    started: float = field(default_factory=time.time)
    source: dict = field(default_factory=dict)   # what it runs (mpc_cores.soak.report.revision, at the start)


def config_seed(seed: int, i: int) -> int:
    return seed * CONFIG_SEEDS + i


def draw(kind, cseed: int, index: int) -> tuple[Outcome, object | None]:
    """Configuration `cseed` and its design (None when the design flow refuses it)."""
    from mpc_cores.problem import problem_from_dict

    cfg = load(kind.soak).draw(np.random.default_rng(cseed))
    cfg.spec["name"] = f"s{cseed}"
    o = Outcome(index, cseed, {"spec": cfg.spec, "design": cfg.design}, cfg.summary())
    try:
        return o, load(kind.design_fn)(problem_from_dict(cfg.spec), **cfg.design)
    except (DesignError, SpecError) as e:
        o.status, o.reason = "refused", str(e)
        return o, None


def generate_all(kind, jobs: list[tuple[Outcome, object]], build: Path) -> dict[int, dict]:
    """Generate the designs in one generator run; a configuration the generator refuses is marked and left out
    (the generator builds the others, which a second run stamps). Returns index -> core.json."""
    jobs = list(jobs)
    while jobs:
        try:
            cores = generate(kind, [(d, out_dir(build, kind, o)) for o, d in jobs])
            return {o.index: c for (o, _), c in zip(jobs, cores)}
        except GeneratorError as e:
            msg = str(e)
            refused = [(o, d) for o, d in jobs
                       if f"REFUSED {(out_dir(build, kind, o) / 'config.json').resolve()}:" in msg]
            if not refused:
                raise
            for o, _ in refused:
                line = next(ln for ln in msg.splitlines() if str(out_dir(build, kind, o).resolve()) in ln)
                o.status, o.reason = "refused_generator", line.split(": ", 1)[1]
            jobs = [j for j in jobs if j not in refused]
    return {}


def out_dir(build: Path, kind, o: Outcome) -> Path:
    return Path(build) / kind.name / f"c{o.seed}"


def _result(xml: Path, test: str) -> tuple[str, str, str, float]:
    """(status, the failure's message, its whole text, simulated ms) of `test` in cocotb's results file."""
    for tc in ET.parse(xml).getroot().iter("testcase"):
        if tc.get("name") != test:
            continue
        props = {p.get("name"): p.get("value") for p in tc.iter("property")}
        sim_ms = float(props.get("sim_time_duration") or 0) / 1e6
        bad = tc.find("failure") if tc.find("failure") is not None else tc.find("error")
        if bad is None:
            return "passed", "", "", sim_ms
        text = "\n".join(filter(None, (bad.get("message"), bad.text))).strip()
        kind = "hang" if "SimTimeoutError" in text else "mismatch" if "AssertionError" in text else "error"
        lines = [ln.strip() for ln in text.splitlines() if ln.strip()]
        err = [ln for ln in lines if ln.startswith(("AssertionError", "cocotb.", "SimTimeoutError"))]
        return kind, (err or lines or ["no message"])[0], text[-4000:], sim_ms
    return "error", f"no result for {test} in {xml}", "", 0.0


def simulate(kind, o: Outcome, core: dict, solves: int, build: Path, keep: bool,
             timeout_ms: float | None = None) -> None:
    """Run the kind's random-solve test on configuration `o` for about `solves` solves (generated under `build`);
    fills in the outcome. The simulated-time limit: TIMEOUT_MARGIN times the solves' expected cycles, or
    `timeout_ms`."""
    from mpc_cores.quiet import c_output_silenced
    from mpc_cores.sim import run_cocotb

    space = load(kind.soak)
    out = out_dir(build, kind, o)
    count = max(1, math.ceil(solves / space.per_count(core)))
    o.requested = solves
    o.timeout_ms = timeout_ms or TIMEOUT_BASE_MS + math.ceil(TIMEOUT_MARGIN * solves * space.cycles_per_solve(core)
                                                             * CLOCK_NS / 1e6)
    o.module = core["module"]
    measure = out / "soak.jsonl"
    measure.unlink(missing_ok=True)
    env = {"CORE_OUT": str(out), space.count_knob: str(count), "CORE_MEASURE": str(measure),
           "CORE_SEED": str(o.seed), "CORE_TIMEOUT_MS": str(o.timeout_ms)}
    try:
        with c_output_silenced():
            run_cocotb(out / core["sv"], core["module"], kind.testbench, out / "sim", env, testcase=space.test)
        o.status, o.reason, o.detail, o.sim_ms = _result(out / "sim" / "results.xml", space.test)
    except (Exception, SystemExit) as e:   # the Verilator build or the simulator itself failed
        o.status, o.reason = "error", f"{type(e).__name__}: {e}".splitlines()[0]
    o.cycles = round(o.sim_ms * 1e6 / CLOCK_NS)
    rec = [json.loads(ln) for ln in measure.read_text().splitlines()] if measure.exists() else []
    o.solves = sum(r.get(space.measured, 0) for r in rec if r.get("test") == space.test)
    if o.status == "passed" and not keep:
        for d in ("sim", "sim-waves"):   # the Verilator builds (a failure keeps them, its log and WAVES=1 trace)
            shutil.rmtree(out / d, ignore_errors=True)
    o.log = "" if o.status == "passed" else str((out / "sim" / "sim.log").relative_to(REPO))


def run(kind_name: str, solves: int, seed: int = 1, per_config: int | None = None, out: Path | None = DOCS,
        keep_builds: bool = False, max_failures: int = 10, only: int | None = None, build: Path = BUILD) -> Soak:
    """Soak `kind_name` for at least `solves` solves (or configuration seed `only`); writes the report into `out`
    after each configuration (None: no report). Stops early after `max_failures` failing configurations."""
    from mpc_cores.progress import bar
    from mpc_cores.soak.report import revision, write

    kind = registry.get(kind_name)
    space = load(kind.soak)
    s = Soak(kind.name, seed, solves, solves if only is not None else per_config or space.solves_per_config, build,
             source=revision(kind.name))
    pb = bar(total=solves, desc=f"soak {kind.name}", unit="solve")
    i, done = 0, 0
    try:
        while done < solves and sum(o.failed for o in s.outcomes) < max_failures:
            want = math.ceil((solves - done) / s.per_config)
            wave, refused = [], 0
            while len(wave) < want:
                pb.set_postfix_str(f"design {i}")
                o, d = draw(kind, only if only is not None else config_seed(seed, i), i)
                i += 1
                s.outcomes.append(o)
                if d is not None:
                    wave.append((o, d))
                    refused = 0
                elif (refused := refused + 1) >= MAX_REFUSED:
                    raise DesignError(f"soak {kind.name}: the design flow refused {refused} configurations in a "
                                      f"row, the last: {o.reason}")
            pb.set_postfix_str(f"generate {len(wave)} configurations")
            t0 = time.time()
            cores = generate_all(kind, wave, s.build)
            share = (time.time() - t0) / max(1, len(wave))
            made = [o for o, _ in wave if o.index in cores]
            for k, o in enumerate(made):
                pb.set_postfix_str(f"configuration {o.index}: build and simulate; "
                                   f"{sum(x.failed for x in s.outcomes)} failed")
                t0 = time.time()
                share_k = max(s.per_config // 2, math.ceil((solves - done) / (len(made) - k)))
                simulate(kind, o, cores[o.index], share_k, s.build, keep_builds)
                o.seconds = round(time.time() - t0 + share, 1)
                done += o.solves
                pb.update(o.solves)
                if out is not None:
                    write(s, out, finished=False)
            if only is not None:
                break
    finally:
        pb.close()
    if out is not None:
        write(s, out, finished=True)
    return s


def soaked_kinds() -> list[str]:
    """The kinds of the registry that declare a soak space, in registry order."""
    return [n for n, k in registry.kinds().items() if k.soak]


def summary(s, out: Path) -> str:
    from mpc_cores.soak.report import totals

    t = totals(s)
    return (f"soak {s.kind}: {t['configurations']} configurations ({t['refused']} refused), {t['solves']} solves, "
            f"{t['mismatch']} mismatches, {t['hang']} hangs, {t['error']} errors, {t['wall_time']}: "
            f"{Path(out) / (s.kind + '.md')}")


def failed(s) -> bool:
    return any(o.failed for o in s.outcomes)


def run_all(solves: int, seed: int = 1, per_config: int | None = None, out: Path = DOCS, keep_builds: bool = False,
            max_failures: int = 10, kinds: list[str] | None = None) -> bool:
    """`make soak-all`: soak every kind with a soak space (or `kinds`) one after another, each for `solves` solves
    into its report in `out`; one line per kind as it ends. A kind the design flow or the generator stops is
    reported and the next one runs. True when every kind passed."""
    from mpc_cores.progress import bar
    from tqdm import tqdm

    ok = True
    kinds = kinds or soaked_kinds()
    pb = bar(total=len(kinds), desc="soak-all", unit="kind")
    try:
        for name in kinds:
            pb.set_postfix_str(name)
            try:
                s = run(name, solves, seed, per_config, out, keep_builds, max_failures)
                line, ok = summary(s, out), ok and not failed(s)
            except (DesignError, GeneratorError) as e:
                line, ok = f"soak {name}: stopped: {str(e).splitlines()[0]}", False
            tqdm.write(line)
            pb.update(1)
    finally:
        pb.close()
    return ok


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(prog="mpc-cores soak", description=__doc__.split("\n\n")[0])
    ap.add_argument("--core", default="fgm", help=f"core kind: {', '.join(registry.names())}")
    ap.add_argument("--all", action="store_true", help="every kind with a soak space, one after another "
                    "(`make soak-all`; --solves each)")
    ap.add_argument("--solves", type=int, default=10**4, help="random solves in all (default 10^4)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--per-config", type=int, help="solves per configuration (default: the kind's)")
    ap.add_argument("--config-seed", type=int, help="run this configuration alone (a reproducer)")
    ap.add_argument("--out", help=f"report folder (<core>.md, <core>.json; default {DOCS.relative_to(REPO)}, with "
                    f"--config-seed {(BUILD / 'reproduce').relative_to(REPO)})")
    ap.add_argument("--keep-builds", action="store_true", help="keep the Verilator builds of passing configurations")
    ap.add_argument("--max-failures", type=int, default=10, help="stop after this many failing configurations")
    a = ap.parse_args(argv)
    a.out = a.out or (DOCS if a.config_seed is None else BUILD / "reproduce")
    from mpc_cores.cli import refuse

    if a.all:
        if a.config_seed is not None:
            refuse("--config-seed reruns one configuration of one kind (--core), not --all")
        raise SystemExit(0 if run_all(a.solves, a.seed, a.per_config, Path(a.out), a.keep_builds,
                                      a.max_failures) else 1)
    try:
        s = run(a.core, a.solves, a.seed, a.per_config, Path(a.out), a.keep_builds, a.max_failures, a.config_seed)
    except KeyError as e:
        refuse(e.args[0])
    except (DesignError, GeneratorError) as e:
        refuse(str(e))
    print(summary(s, a.out))
    raise SystemExit(1 if failed(s) else 0)
