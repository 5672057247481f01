"""Generation flow: design -> config.json -> Chisel generator (sbt) -> SystemVerilog, core.json, SystemRDL register
description and its PeakRDL exports (C header, register reference, IP-XACT memory map), IP-XACT component,
FuseSoC core file.

One sbt invocation elaborates a batch of cores (sbt start-up dominates the cost of a small design).
"""
from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import os
import shutil
import subprocess
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SBT_VERSION = "1.11.7"

from mpc_cores.errors import GeneratorError  # noqa: F401  (part of this module's API)


def sbt_launcher() -> Path:
    """The sbt launcher jar (from Maven Central; fetched with mvn on first use)."""
    env = os.environ.get("SBT_LAUNCH")
    if env:
        return Path(env)
    jar = Path.home() / f".m2/repository/org/scala-sbt/sbt-launch/{SBT_VERSION}/sbt-launch-{SBT_VERSION}.jar"
    if not jar.exists():
        if shutil.which("mvn") is None:
            raise GeneratorError("sbt launcher missing and mvn not found: run `make setup` (needs Java 17 and Maven)")
        subprocess.run(["mvn", "-q", "dependency:get", f"-Dartifact=org.scala-sbt:sbt-launch:{SBT_VERSION}",
                        "-Dtransitive=false"], check=True, stdin=subprocess.DEVNULL)
    return jar


@contextlib.contextmanager
def locked(path: Path):
    """An exclusive lock on `path` (created if needed), held for the block: parallel test workers and tools share
    sbt's project folder and the build folders."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "a") as f:
        fcntl.flock(f, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


SBT_LOCK = REPO / "build" / ".sbt.lock"


def generator_digest() -> str:
    """A digest of the generator's sources (Scala and build definition)."""
    h = hashlib.sha256()
    files = sorted((REPO / "src" / "main" / "scala").rglob("*.scala")) + [REPO / "build.sbt"]
    for f in files:
        h.update(f.relative_to(REPO).as_posix().encode() + b"\0" + f.read_bytes())
    return h.hexdigest()


CLASSPATH_FILE = REPO / "build" / ".generator-classpath.json"


def _sbt(command: str) -> subprocess.CompletedProcess:
    return subprocess.run(["java", "-Xss8m", "-jar", str(sbt_launcher()), command], cwd=REPO, stdin=subprocess.DEVNULL,
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def generator_classpath() -> str:
    """The generator's compiled classes and dependencies, for running a generator main with java directly (sbt's
    start-up is most of the cost of a small design). sbt compiles and exports it when the generator sources have
    changed since the last export; call with SBT_LOCK held."""
    digest = generator_digest()
    try:
        saved = json.loads(CLASSPATH_FILE.read_text())
        if saved["digest"] == digest and all(Path(e).exists() for e in saved["classpath"].split(os.pathsep)):
            return saved["classpath"]
    except (OSError, ValueError, KeyError):
        pass
    p = _sbt("export Runtime/fullClasspath")
    # the classpath is the line of sbt's output listing the compiled classes and the jars
    lines = [ln.strip() for ln in p.stdout.splitlines()
             if not ln.startswith("[") and "classes" in ln and ".jar" in ln and os.pathsep in ln]
    if p.returncode != 0 or not lines:
        errors = [ln for ln in p.stdout.splitlines() if "[error]" in ln]
        raise GeneratorError("the generator does not compile:\n" + "\n".join(errors[:20] or p.stdout.splitlines()[-30:]))
    CLASSPATH_FILE.parent.mkdir(parents=True, exist_ok=True)
    CLASSPATH_FILE.write_text(json.dumps({"digest": digest, "classpath": lines[-1]}))
    return lines[-1]


def run_generator(main: str, args: list[str]) -> str:
    """Run the generator object `main` with `args` (compiled by sbt when its sources changed); return its output,
    raise GeneratorError on failure. One generator or sbt run at a time on this checkout (a lock under build/)."""
    with locked(SBT_LOCK):
        cmd = ["java", "-Xss8m", "-cp", generator_classpath(), main, *args]
        p = subprocess.run(cmd, cwd=REPO, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                           text=True)
    if p.returncode != 0:
        reasons = [ln for ln in p.stdout.splitlines() if ln.startswith("REFUSED") or "Exception" in ln
                   or "[error]" in ln]
        raise GeneratorError(f"{main} failed:\n" + "\n".join(reasons[:20] or p.stdout.splitlines()[-30:]))
    return p.stdout


def _outputs_present(out: Path) -> bool:
    """The generator's outputs in `out`: hw.json and the SystemVerilog and SystemRDL files of the module it names."""
    try:
        module = json.loads((out / "hw.json").read_text())["module"]
    except (OSError, ValueError, KeyError):
        return False
    return (out / f"{module}.sv").exists() and (out / f"{module}.rdl").exists()


GENERATE_LOCK = SBT_LOCK.with_name(".generate.lock")


def run_stale(main: str, jobs: list, current) -> None:
    """Run generator `main` once for the jobs (config text, out_dir, write_config(path)) whose outputs are not
    current: `current(out_dir)` false, or a stamp `.generated` that differs from the digest of the main, the
    generator sources and the configuration. Call it under GENERATE_LOCK."""
    src = generator_digest()
    args, stamps = [], []
    for text, out, write_config in jobs:
        out.mkdir(parents=True, exist_ok=True)
        stamp = hashlib.sha256((main + src + text).encode()).hexdigest()
        done = out / ".generated"
        if done.exists() and done.read_text() == stamp and current(out):
            continue  # the same configuration from the same generator sources: its outputs are current
        done.unlink(missing_ok=True)
        write_config(out / "config.json")
        args += [str((out / "config.json").resolve()), str(out.resolve())]
        stamps.append((done, stamp))
    if args:
        run_generator(main, args)
    for done, stamp in stamps:
        done.write_text(stamp)


def generate(kind, jobs: list[tuple[object, Path]]) -> list[dict]:
    """Elaborate cores of one kind (a CoreKind or its name) in one sbt run: jobs are (design, out_dir). Writes per
    out_dir: config.json, <module>.sv, hw.json, core.json, the SystemRDL register description <module>.rdl and
    what PeakRDL makes of it (C header, register reference, IP-XACT memory map), the IP-XACT component
    <module>.component.xml and the FuseSoC core file. Returns the core.json dicts."""
    from mpc_cores import cdriver, fusesoc, ipxact, registry, regmap

    kind = registry.get(kind) if isinstance(kind, str) else kind
    with locked(GENERATE_LOCK):
        run_stale(kind.generator_main, [(json.dumps(d.config(), sort_keys=True), Path(out), d.write_config)
                                        for d, out in jobs], _outputs_present)
        cores = []
        for d, out in jobs:
            out = Path(out)
            hw = json.loads((out / "hw.json").read_text())
            core = kind.core_json(d, hw)
            core["axil_response_cycles"] = hw["axil_response_cycles"]
            core.update(regmap.export(out, core))
            core.update(cdriver.write_driver(out, core))
            core.update(ipxact.write_component(out, core))
            core.update(fusesoc.write_core(out, core))
            tmp = out / "core.json.tmp"
            tmp.write_text(json.dumps(core, indent=2))
            tmp.replace(out / "core.json")
            cores.append(core)
        return cores


def generate_fgm(jobs: list[tuple[object, Path]]) -> list[dict]:
    """Elaborate FGM cores: jobs are (FgmDesign, out_dir). See `generate`."""
    return generate("fgm", jobs)


def generate_admm(jobs: list[tuple[object, Path]]) -> list[dict]:
    """Elaborate ADMM cores: jobs are (AdmmDesign, out_dir). See `generate`."""
    return generate("admm", jobs)


def generate_minres(jobs: list[tuple[object, Path]]) -> list[dict]:
    """Elaborate MINRES cores: jobs are (MinresDesign, out_dir). See `generate`."""
    return generate("minres", jobs)
