"""The report of a soak (mpc_cores.soak.run): <kind>.md and the same facts in <kind>.json beside it."""
from __future__ import annotations

import datetime
import hashlib
import json
import re
import subprocess
import time
from dataclasses import asdict
from pathlib import Path

from mpc_cores import registry
from mpc_cores.flow import REPO
from mpc_cores.kind import load

STATUSES = ("passed", "mismatch", "hang", "error", "refused", "refused_generator")
SOURCES = ("src", "build.sbt", "mpc_cores", "verif")   # what the soaked RTL, models and testbenches come from


def _git(*args: str) -> str:
    p = subprocess.run(["git", *args], cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    return p.stdout if p.returncode == 0 else ""


SCALA = REPO / "src" / "main" / "scala"


_TOP = re.compile(r"^(?:(?:final|sealed|abstract|case|private|implicit)\s+)*(?:class|object|trait)\s+(\w+)", re.M)


def kind_sources(kind: str) -> list[Path]:
    """The generator sources a kind's RTL comes from, with build.sbt: its Scala package's files and, transitively,
    every file that defines a top-level class, object or trait whose name appears in one of them (imported, or
    named in its own package). A name defined in several files takes them all, so the set errs on the side of
    more. A change to a block the kind does not use (another kind's package, a floating-point unit in a
    fixed-point core) leaves its soak current. Comments are left out: a name in a comment is no use."""
    files = sorted(SCALA.rglob("*.scala"))
    text = {f: re.sub(r"//[^\n]*", "", re.sub(r"/\*.*?\*/", "", f.read_text(), flags=re.S)) for f in files}
    where: dict[str, list[Path]] = {}
    for f in files:
        for name in _TOP.findall(text[f]):
            where.setdefault(name, []).append(f)
    todo = list((SCALA / registry.kinds()[kind].generator_main.split(".")[0]).glob("*.scala"))
    used: set[Path] = set()
    while todo:
        f = todo.pop()
        if f in used:
            continue
        used.add(f)
        todo += [g for tok in set(re.findall(r"\w+", text[f])) for g in where.get(tok, ())]
    return sorted(used) + [REPO / "build.sbt"]


def kind_digest(kind: str) -> str:
    """A digest of `kind_sources(kind)`, which `staleness` compares with today's."""
    h = hashlib.sha256()
    for f in kind_sources(kind):
        h.update(f.relative_to(REPO).as_posix().encode() + b"\0" + f.read_bytes())
    return h.hexdigest()


def revision(kind: str) -> dict:
    """What a soak of `kind` runs: the commit, the sources changed since (the soak ran what is in the tree),
    whether there are any (dirty) and the digest of the kind's generator sources (`kind_digest`)."""
    changed = [ln[3:] for ln in _git("status", "--porcelain", "--", *SOURCES).splitlines() if ln.strip()]
    return {"commit": _git("rev-parse", "--short=12", "HEAD").strip(), "uncommitted": changed,
            "dirty": bool(changed), "generator_digest": kind_digest(kind)}


def staleness(folder: Path, kinds: list[str] | None = None) -> dict[str, str]:
    """kind -> why its report in `folder` does not describe today's generator sources: no report, no digest recorded
    (a report from before the field) or another digest. Current reports are left out. `kinds`: default every kind
    of the registry with a soak space."""
    folder = Path(folder)
    kinds = kinds if kinds is not None else [n for n, k in registry.kinds().items() if k.soak]
    out = {}
    for name in kinds:
        now = kind_digest(name)
        try:
            rec = json.loads((folder / f"{name}.json").read_text())
        except (OSError, ValueError):
            out[name] = "no report"
            continue
        at = f"commit {rec.get('commit') or 'unknown'}" + (" with uncommitted changes"
                                                           if rec.get("uncommitted") else "")
        if not rec.get("generator_digest"):
            out[name] = f"no digest recorded ({at})"
        elif rec["generator_digest"] != now:
            out[name] = f"generator sources changed since the soak ({at}, digest {rec['generator_digest'][:12]})"
    return out


def _duration(sec: float) -> str:
    h, rem = divmod(int(round(sec)), 3600)
    return f"{h} h {rem // 60:02d} min" if h else f"{rem // 60} min {rem % 60:02d} s"


def totals(s) -> dict:
    count = {k: sum(o.status == k for o in s.outcomes) for k in STATUSES}
    wall = time.time() - s.started
    return {"configurations": len(s.outcomes), "simulated": sum(o.status not in ("refused", "refused_generator",
                                                                                "pending") for o in s.outcomes),
            "refused": count["refused"] + count["refused_generator"], **count,
            "solves": sum(o.solves for o in s.outcomes), "wall_seconds": round(wall), "wall_time": _duration(wall)}


def _options(design: dict) -> str:
    short = {"frac_bits": "b", "iterations": "Imax", "lat_add": "lA", "lat_mul": "lM", "warm_start": "warm",
             "warm_shift": "shift", "output_all": "all", "newton": "I_NW"}
    def value(k, v):
        return "P_eq15" if k == "P" and v == 0 else "min" if k == "lat_mul" and v is None else v
    return ", ".join(f"{short.get(k, k)}={value(k, v)}" for k, v in design.items())


def _command(s) -> str:
    return f"make soak CORE={s.kind} SOLVES={s.requested} SEED={s.seed}"


def markdown(s, finished: bool) -> str:
    kind = registry.get(s.kind)
    t, rev = totals(s), _source(s)
    when = datetime.datetime.now().astimezone().strftime("%Y-%m-%d %H:%M %Z")
    tree = f"commit {rev['commit']}" + (f" with uncommitted changes in {', '.join(rev['uncommitted'])}"
                                         if rev["uncommitted"] else "")
    tree += f", generator digest {rev['generator_digest'][:12]}"
    if rev.get("generator_digest_at_end"):
        tree += f" (the generator sources changed during the soak: {rev['generator_digest_at_end'][:12]} now)"
    lines = [f"# Soak: {s.kind}", "",
             f"{kind.title}. `{_command(s)}`, seed {s.seed}, {s.per_config} solves per configuration; "
             f"{'finished' if finished else 'running, last written'} {when}; {tree}.", "",
             "| configurations | simulated | refused | solves | mismatches | hangs | errors | wall time |",
             "|---|---|---|---|---|---|---|---|",
             f"| {t['configurations']} | {t['simulated']} | {t['refused']} | {t['solves']} | {t['mismatch']} | "
             f"{t['hang']} | {t['error']} | {t['wall_time']} |", "",
             "Every solve's output words are compared with the bit-exact golden model of the generated core "
             "(flags and status included). A mismatch is a failed check of the test, a hang its simulated-time "
             "limit (several times the expected cycles), an error any other end of the simulation.", "",
             "## Random space", ""]
    lines += [f"- {item}" for item in load(kind.soak).space]
    lines += ["", "## Configurations", "",
              "Seed: the configuration's own (it seeds the testbench too). radius: spectral radius of A. "
              "Sets: u input box, du input rate, x hard state box, soft x soft state box. Cycles: simulated. "
              "Time: generation (its share of the batch), Verilator build and simulation.", "",
              "| # | seed | nx | nu | N | ny | radius | sets | options | solves | result | cycles | time |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for o in s.outcomes:
        m = o.summary
        res = o.status if o.status != "refused_generator" else "refused (generator)"
        sim = f"{o.cycles:,}" if o.cycles else ""
        lines.append(f"| {o.index} | {o.seed} | {m['nx']} | {m['nu']} | {m['N']} | {m['ny']} | {m['radius']} | "
                     f"{', '.join(m['sets'])} | {_options(o.config['design'])} | {o.solves} | {res} | {sim} | "
                     f"{o.seconds:.0f} s |")
    failed = [o for o in s.outcomes if o.failed]
    lines += ["", "## Failures", ""]
    if not failed:
        lines.append("None.")
    for o in failed:
        lines += [f"- configuration {o.index} (seed {o.seed}, {o.module}): **{o.status}** after "
                  f"{o.sim_ms:.1f} ms simulated (limit {o.timeout_ms} ms): {o.reason[:600]}",
                  f"  - reproduce: `make soak CORE={s.kind} SOLVES={o.requested} CONFIG_SEED={o.seed}` "
                  f"(spec and design keywords in {s.kind}.json; log {o.log})"]
    refused = [o for o in s.outcomes if o.status.startswith("refused")]
    if refused:
        lines += ["", "## Refused configurations", ""]
        lines += [f"- {o.index} (seed {o.seed}, {'generator' if o.status == 'refused_generator' else 'design flow'})"
                  f": {o.reason}" for o in refused]
    return "\n".join(lines) + "\n"


def _source(s) -> dict:
    """The soak's revision (taken when it started), with the generator digest of now where it differs."""
    rev = dict(getattr(s, "source", None) or revision(s.kind))
    now = kind_digest(s.kind)
    if now != rev["generator_digest"]:
        rev["generator_digest_at_end"] = now
    return rev


def write(s, out: Path, finished: bool) -> None:
    """<kind>.md and <kind>.json in `out` (written again after each configuration)."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    record = {"kind": s.kind, "command": _command(s), "seed": s.seed, "requested_solves": s.requested,
              "solves_per_config": s.per_config, "finished": finished,
              "date": datetime.datetime.now().astimezone().isoformat(timespec="seconds"), **_source(s),
              "totals": totals(s), "space": list(load(registry.get(s.kind).soak).space),
              "configurations": [asdict(o) for o in s.outcomes]}
    for name, text in ((f"{s.kind}.json", json.dumps(record, indent=1) + "\n"),
                       (f"{s.kind}.md", markdown(s, finished))):
        tmp = out / (name + ".tmp")
        tmp.write_text(text)
        tmp.replace(out / name)
