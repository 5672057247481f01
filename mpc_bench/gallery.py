"""The examples gallery: every core kind on every plant of examples/ whose constraint sections it enforces, through
its design flow and the design check (mpc_cores.check), into docs/gallery.md (plant x kind).

Each pair runs `checked_design` with the gallery's target (TARGET_GAP: the closed-loop cost within 1 % of the
optimal MPC's, the hard constraints within 0.1 % of their ranges) and budget (BUDGET cycles per solve), so the flow
chooses the iteration count. A pair is:
  usable        the check passes at the chosen count, within the budget, and the core fits the LFE5U-85F;
  does not fit  the check passes, but the core's products take more MULT18X18D than the part has;
  fails check   no count within the budget passes (the numbers of the last one tried);
  refused       the design flow refuses the spec (the rule it names), or the kind does not enforce a section.

    python -m mpc_bench.gallery [--plants quadrotor,cartpole] [--kinds fgm,admm] [--gap 1] [--samples 24]
                                [--workers 2] [--out docs/gallery.md]
"""
from __future__ import annotations

import argparse
import os
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from mpc_cores import registry
from mpc_cores.flow import REPO
from mpc_cores.kind import SECTIONS
from mpc_cores.progress import bar

EXAMPLES = REPO / "examples"
TARGET_GAP = 1.0
BUDGET = 20_000   # cycles per solve: 100 us at 200 MHz
PART_DSPS = 156   # MULT18X18D of the LFE5U-85F
PART_BRAMS = 208  # DP16KD of the LFE5U-85F


def plants() -> list[Path]:
    return sorted(EXAMPLES.glob("*.yaml"))


def _sections(p) -> list[str]:
    return [s for s in SECTIONS if getattr(p, s) is not None]


def run_pair(spec: str, kind_name: str, gap: float, samples: int | None, budget: int = BUDGET) -> dict:
    """One plant x kind: the outcome and the check's numbers (picklable, for the process pool)."""
    import dataclasses

    from mpc_cores.check import CheckFailed, checked_design
    from mpc_cores.errors import DesignError, SpecError
    from mpc_cores.problem import load_spec

    kind = registry.get(kind_name)
    p = load_spec(spec)
    if samples is not None:
        p = dataclasses.replace(p, check=dataclasses.replace(p.check, samples=samples))
    row = {"plant": p.name, "kind": kind_name, "sections": _sections(p)}
    t = time.time()

    def attempt(overrides: dict):
        """(outcome, why, check result) of the flow with `overrides`"""
        try:
            d, res = checked_design(kind, p, overrides, target=gap, budget=budget)
            f = res.facts
            if f["cycles"] > budget:
                return ("fails check", f"{f['cycles']} cycles per solve at the spec's iteration count, over the budget "
                        f"of {budget}", res)
            return ("does not fit" if not _fits_part(f) else "usable"), None, res
        except CheckFailed as e:
            return "fails check", str(e).split(": ", 1)[-1], e.result
        except (DesignError, SpecError) as e:
            return "refused", str(e), None
        except Exception as e:  # noqa: BLE001 - one pair's failure is a row of the report, not the end of the run
            return "error", f"{type(e).__name__}: {e}", None

    row["outcome"], why, res = attempt({})
    if row["outcome"] in ("does not fit", "fails check") and "lanes" in kind.overrides:
        # the row unit's multipliers sized for the part (LANES=fit): fewer, time-multiplexed (ADMM family), or as
        # many as fit (DGP); then also with two fraction bits fewer than the flow's (narrower products take fewer
        # DSPs, so fewer chunks and more iterations within the budget)
        tries = [{"lanes": "fit"}]
        b = _default_bits(kind, p)
        if b is not None and b > 2:
            tries.append({"lanes": "fit", "frac_bits": b - 2})
        for ov in tries:
            opts = " ".join(f"{'B' if k == 'frac_bits' else k.upper()}={v}" for k, v in ov.items())
            alt = attempt(ov)
            if alt[0] == "usable":
                row["outcome"], why, res = alt
                row["options"] = opts
                break
            why = (f"{why}; " if why else "") + f"with {opts}: {alt[0]}" + (f": {alt[1]}" if alt[1] else "")
    if why:
        row["why"] = why
    if res is not None:
        f = res.facts
        row.update(gap=res.gap, violations={c: v for c, v in res.violations.items()}, diverged=res.diverged,
                   subopt=(res.subopt_median, res.subopt_worst), iterations=f["iterations_text"], cycles=f["cycles"],
                   multipliers=f["multipliers"], dsp_ecp5=f["dsp_ecp5"], bram_ecp5=f["bram_ecp5"], words=f["words"],
                   flagged={k: v for k, v in res.flagged.items() if v}, outside=res.outside, steps=res.steps)
    row["seconds"] = time.time() - t
    return row


def _num(v, fmt="{:+.3g} %") -> str:
    return "—" if v is None else fmt.format(v)


def _viol(row) -> str:
    v = row.get("violations") or {}
    out = [f"{c}: {a:.3g} ({100 * r:.2g} %)" for c, (a, r) in v.items()]
    if row.get("outside"):
        out.append(f"outside the accepted box in {row['outside']} of {row['steps']} steps")
    return "<br>".join(out) or "—"


def _default_bits(kind, p) -> int | None:
    """the fraction bits of the kind's default design for the plant (None: floating point, or refused)"""
    try:
        return getattr(kind.design(p), "b", None)
    except Exception:  # noqa: BLE001 - a refusal leaves nothing to narrow
        return None


def _fits_part(f: dict) -> bool:
    """the products and memories within the LFE5U-85F's (floating-point cores: counted by make bench)"""
    return ((f["dsp_ecp5"] is None or f["dsp_ecp5"] <= PART_DSPS)
            and (f["bram_ecp5"] is None or f["bram_ecp5"] <= PART_BRAMS))


def _fits(row) -> str:
    dsp = row.get("dsp_ecp5")
    if dsp is None:
        return "—"
    return (f"{'yes' if _fits_part(row) else 'no'} ({dsp} MULT18X18D, {row['bram_ecp5']} DP16KD)")


def markdown(rows: list[dict], gap: float, budget: int, seconds: float) -> str:
    out = ["# Examples gallery", "",
           "Every core kind on every plant of `examples/` whose constraint sections it enforces: its design flow with "
           f"the design check ([verification.md](verification.md#design-check)) at a target of {gap:g} % "
           "(closed-loop cost against the optimal MPC's, and the median suboptimality of the sampled states), the "
           f"iteration count chosen by the flow within a budget of {budget:,} cycles per solve. Written by "
           f"`make gallery` ({seconds / 60:.1f} min); each plant's source is in the header of its spec.", "",
           "Outcome: **usable** (the check passes within the budget and the core fits the LFE5U-85F), **does not "
           "fit** (it passes, but its products take more MULT18X18D than the part's 156, or its memories more DP16KD "
           "than its 208), **fails check** (no "
           "iteration count within the budget passes; the numbers are those of the last count tried) or "
           "**refused** (the rule). Violations: the worst along "
           "the closed loop, absolute and as a fraction of the constraint's range (soft states for information), and the "
           "steps whose state or reference left the box the core accepts (the core saturates them). "
           "Multipliers: the core's products; MULT18X18D: those products on the ECP5's 18 x 18 DSPs (the "
           "LFE5U-85F has 156); DP16KD: the memories in the block's best aspect ratio (an estimate; the part has "
           "208); interior-point cores are floating point, counted by `make bench`. An ADMM-family core that does "
           "not fit at one row per cycle is tried with `LANES=fit` (the row unit's multipliers time-multiplexed "
           "over chunks of each row, [admm.md](admm.md)); the options column says when.", ""]
    kinds = [k for k in registry.names()]
    by_plant: dict = {}
    for r in rows:
        by_plant.setdefault(r["plant"], []).append(r)
    out += ["## Summary", "", "| plant | sections | " + " | ".join(kinds) + " |",
            "|---|---|" + "---|" * len(kinds)]
    for plant, rs in by_plant.items():
        cell = {r["kind"]: r for r in rs}
        secs = ", ".join(rs[0]["sections"]) or "input box"
        out.append(f"| {plant} | {secs} | " + " | ".join(_short(cell.get(k)) for k in kinds) + " |")
    out += ["", "## Pairs", "", "| plant | kind | outcome | options | iterations | cycles per solve | loop cost gap | "
            "worst violation | sampled suboptimality (median, worst) | multipliers | fits the LFE5U-85F | words |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        outcome = r["outcome"] + (f": {r['why']}" if r.get("why") else "")
        if r.get("diverged"):
            outcome += " (diverges)"
        sub = r.get("subopt")
        out.append(f"| {r['plant']} | {r['kind']} | {outcome} | {r.get('options', '—')} | {r.get('iterations', '—')} | "
                   f"{r.get('cycles', '—')} | "
                   f"{_num(r.get('gap'))} | {_viol(r)} | "
                   f"{'—' if sub is None else f'{sub[0]:+.3g} %, {sub[1]:+.3g} %'} | "
                   f"{r.get('multipliers') if r.get('multipliers') is not None else '—'} | {_fits(r)} | "
                   f"{r.get('words', '—')} |")
    return "\n".join(out) + "\n"


def _short(r) -> str:
    if r is None:
        return "—"
    if r["outcome"] == "usable":
        return f"usable, {_num(r.get('gap'))}"
    if r["outcome"] == "fails check":
        return f"fails, {_num(r.get('gap'))}"
    if r["outcome"] == "does not fit":
        return f"does not fit, {_num(r.get('gap'))}"
    return "refused"


def run(specs: list[Path], kinds: list[str], gap: float = TARGET_GAP, samples: int | None = None,
        workers: int = 2, budget: int = BUDGET) -> list[dict]:
    """The rows of every plant x kind (kinds without a closed loop, MINRES, are left out)."""
    pairs = [(str(s), k) for s in specs for k in kinds if registry.get(k).has_demo]
    rows = []
    with ProcessPoolExecutor(max_workers=workers) as ex:
        futs = [ex.submit(run_pair, s, k, gap, samples, budget) for s, k in pairs]
        for f in bar(futs, desc="gallery", unit="pair"):
            rows.append(f.result())
    return rows


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(prog="mpc-cores gallery", description=__doc__.split("\n\n")[0])
    ap.add_argument("--plants", help="comma-separated spec names of examples/ (default: all)")
    ap.add_argument("--kinds", help=f"comma-separated kinds (default: {', '.join(registry.names())})")
    ap.add_argument("--gap", type=float, default=TARGET_GAP)
    ap.add_argument("--budget", type=int, default=BUDGET, help="cycles per solve")
    ap.add_argument("--samples", type=int, help="sampled states per pair (default: the spec's check.samples)")
    ap.add_argument("--workers", type=int, default=min(2, os.cpu_count() or 1))
    ap.add_argument("--out", default=str(REPO / "docs" / "gallery.md"))
    a = ap.parse_args(argv)
    specs = plants()
    if a.plants:
        want = a.plants.split(",")
        specs = [s for s in specs if s.stem in want]
    kinds = a.kinds.split(",") if a.kinds else list(registry.names())
    t = time.time()
    rows = run(specs, kinds, a.gap, a.samples, a.workers, a.budget)
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(markdown(rows, a.gap, a.budget, time.time() - t))
    print(f"wrote {a.out}: {sum(r['outcome'] == 'usable' for r in rows)} usable of {len(rows)} pairs")


if __name__ == "__main__":
    main()
