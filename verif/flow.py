"""Generation flow: design -> config.json -> Chisel generator (sbt) -> SystemVerilog, core.json, C header.

One sbt invocation elaborates a batch of cores (sbt start-up dominates the cost of a small design).
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SBT_VERSION = "1.11.7"


class GeneratorError(RuntimeError):
    """The Chisel generator refused the configuration or failed; the message carries its reason."""


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


def run_generator(main: str, args: list[str]) -> str:
    """Run `runMain main args` under sbt in the repository; return its output, raise GeneratorError on failure."""
    cmd = ["java", "-Xss8m", "-jar", str(sbt_launcher()), f"runMain {main} " + " ".join(args)]
    p = subprocess.run(cmd, cwd=REPO, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                       text=True)
    if p.returncode != 0:
        reasons = [ln for ln in p.stdout.splitlines() if ln.startswith("REFUSED") or "Exception" in ln
                   or "[error]" in ln]
        raise GeneratorError(f"{main} failed:\n" + "\n".join(reasons[:20] or p.stdout.splitlines()[-30:]))
    return p.stdout


def _generate(main: str, jobs: list[tuple[object, Path]], core_json, c_header) -> list[dict]:
    args = []
    for d, out in jobs:
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        d.write_config(out / "config.json")
        args += [str((out / "config.json").resolve()), str(out.resolve())]
    run_generator(main, args)
    cores = []
    for d, out in jobs:
        out = Path(out)
        hw = json.loads((out / "hw.json").read_text())
        core = core_json(d, hw)
        (out / "core.json").write_text(json.dumps(core, indent=2))
        (out / f"{core['module']}.h").write_text(c_header(core))
        cores.append(core)
    return cores


def generate_fgm(jobs: list[tuple[object, Path]]) -> list[dict]:
    """Elaborate FGM cores: jobs are (FgmDesign, out_dir). Writes per out_dir: config.json, <module>.sv,
    core.json and <module>.h. Returns the core.json dicts."""
    from verif.fgm.report import c_header, core_json

    return _generate("fgm.FgmMain", jobs, core_json, c_header)


def generate_admm(jobs: list[tuple[object, Path]]) -> list[dict]:
    """Elaborate ADMM cores: jobs are (AdmmDesign, out_dir); the same files as generate_fgm."""
    from verif.admm.report import c_header, core_json

    return _generate("admm.AdmmMain", jobs, core_json, c_header)


def generate_minres(jobs: list[tuple[object, Path]]) -> list[dict]:
    """Elaborate MINRES cores: jobs are (MinresDesign, out_dir); the same files as generate_fgm."""
    from verif.minres.report import c_header, core_json

    return _generate("minres.MinresMain", jobs, core_json, c_header)
