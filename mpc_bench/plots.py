"""Plots of the benchmark (PNG, matplotlib with the Agg backend): each section's own (latency and resources
against P) and the Fmax-vs-P plot every section draws its cores on (mpc_bench.section.Section.plot_fmax)."""
from __future__ import annotations

from pathlib import Path

from mpc_bench.parsers import ECP5_85F


def by_b(recs: list[dict], b: int, key: str) -> list[tuple]:
    return [(r["P"], r[key]) for r in recs if r["b"] == b and r.get(key) is not None]


def log2_axis(ax, Ps: list[int]) -> None:
    ax.set_xscale("log", base=2)
    ax.set_xticks(Ps, [str(p) for p in Ps])
    ax.set_xlabel("P (row units)")


def latency_plot(plt, path: Path, recs: list[dict], sw: dict | None, paper: dict, table: str, ref_b: int,
                 title: str) -> None:
    """Solve latency against P: at the ECP5 Fmax (and an estimate where the rows have one), our cycles at the
    clocks of 002, the paper's Table `table` and the software medians of `sw`; the 002 clocks are drawn for the
    b of index `ref_b` of the rows' sorted b."""
    bs = sorted({r["b"] for r in recs})
    Ps = sorted({r["P"] for r in recs})
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for b in bs:
        pts = by_b(recs, b, "latency_us_ecp5")
        if pts:
            ax.plot(*zip(*pts), "o-", label=f"ECP5-85F at nextpnr Fmax, b = {b}")
        pts = by_b(recs, b, "latency_us_ecp5_est")
        if pts:
            ax.plot(*zip(*pts), "o:", label=f"at {recs[0]['fmax_est_mhz']:.0f} MHz, small core's ECP5 Fmax "
                                            f"(estimate), b = {b}")
    b0 = bs[ref_b]
    ax.plot(*zip(*by_b(recs, b0, "latency_us_v6_ours")), "s--", color="tab:red", label="our cycles at 400 MHz (Virtex-6)")
    ax.plot(*zip(*by_b(recs, b0, "latency_us_s6_ours")), "s--", color="tab:purple",
            label="our cycles at 230 MHz (Spartan-6)")
    t3 = [(P, paper[P]) for P in Ps if P in paper]
    if t3:
        t = table
        ax.plot([p for p, _ in t3], [v[1] for _, v in t3], "x", ms=9, color="tab:red", label=f"002 Table {t}, V6")
        ax.plot([p for p, _ in t3], [v[2] for _, v in t3], "x", ms=9, color="tab:purple", label=f"002 Table {t}, S6")
    if sw:
        for r, ls in zip(sw["solvers"], (":", "-.", "--")):
            ax.axhline(r.median_us, color="gray", ls=ls, lw=1)
            ax.annotate(f"{r.name} (this CPU)", (Ps[0], r.median_us), xytext=(2, 2), textcoords="offset points",
                        fontsize=7, color="gray")
    log2_axis(ax, Ps)
    ax.set_yscale("log")
    ax.set_ylabel("solve latency (us)")
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="lower left")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def resources_plot(plt, path: Path, recs: list[dict], table1: str, title: str) -> None:
    bs = sorted({r["b"] for r in recs})
    Ps = sorted({r["P"] for r in recs})
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.5))
    ms = iter((11, 9, 7, 5))
    for b in bs:
        for key, mk, lab in (("ecp5_MULT18X18D", "o", "MULT18X18D (ECP5)"), ("xc7_DSP48E1", "s", "DSP48E1 (xc7)")):
            pts = by_b(recs, b, key)
            if pts:
                a1.plot(*zip(*pts), mk, ms=next(ms, 5), mfc="none", label=f"{lab}, b = {b}")
    a1.plot(*zip(*by_b(recs, bs[-1], "multipliers_table1")), "k--", lw=1, label=f"Table I of 002: {table1}")
    a1.plot(*zip(*by_b(recs, bs[-1], "multipliers")), "k:", lw=1, label="multipliers of the core (core.json)")
    a1.axhline(ECP5_85F["MULT18X18D"], color="gray", ls=":", lw=1)
    a1.annotate("LFE5U-85F: 156 MULT18X18D", (Ps[0], ECP5_85F["MULT18X18D"]), xytext=(2, 3),
                textcoords="offset points", fontsize=7, color="gray")
    a1.set_ylabel("multipliers")
    for b in bs:
        for key, mk, lab in (("ecp5_LUT4", "o-", "LUT4 (ECP5)"), ("ecp5_FF", "o:", "FF (ECP5)"),
                             ("xc7_LUT", "s-", "LUT (xc7)"), ("xc7_FF", "s:", "FF (xc7)")):
            pts = by_b(recs, b, key)
            if pts:
                a2.plot(*zip(*pts), mk, label=f"{lab}, b = {b}")
    a2.set_ylabel("cells")
    for a in (a1, a2):
        log2_axis(a, Ps)
        a.grid(True, alpha=0.3)
        a.legend(fontsize=7)
    if len(Ps) > 1:
        a1.set_yscale("log")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def fmax_plot(plt, path: Path, sections: list) -> bool:
    """fmax_vs_P.png: Fmax against P of the cores each section draws, its constraint and reference clocks; False
    (and no file) when no section draws there."""
    fig, ax = plt.subplots(figsize=(7, 4.5))
    Ps: set = set()
    tgts: list = []
    refs: dict = {}
    drawn = False
    for s in sections:
        got = s.plot_fmax(ax)
        if got is None:
            continue
        drawn = True
        Ps |= set(got[0])
        tgts += got[1]
        for f, color, label in got[2]:
            refs.setdefault(label, (f, color))
    if not drawn:
        plt.close(fig)
        return False
    Ps = sorted(Ps) or [1]
    tgt = next((t for t in tgts if t), None)
    if tgt:
        ax.axhline(tgt, color="gray", ls=":", lw=1, label=f"constraint {tgt:g} MHz")
    for label, (f, color) in refs.items():
        ax.axhline(f, color=color, ls="--", lw=1, label=label)
    log2_axis(ax, Ps)
    ax.set_ylim(0, max([f for f, _ in refs.values()] + [tgt or 0]) * 1.15)
    ax.set_xlim(Ps[0] / 1.3, Ps[-1] * 1.3)
    ax.set_ylabel("Fmax (MHz)")
    ax.set_title("Fmax vs P, nextpnr-ecp5 on the LFE5U-85F (speed 8)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, loc="center right")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return True


def plots(out: Path, sections: list) -> list[Path]:
    """Each section's plots and fmax_vs_P.png; the files written."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    paths = []
    for s in sections:
        paths += s.plots(plt, out)
    if fmax_plot(plt, out / "fmax_vs_P.png", sections):
        paths.append(out / "fmax_vs_P.png")
    return paths
