"""The QP solvers of the FGM and ADMM software baselines (mpc_bench.qp_solvers) on QPs of the bench's loops against
the bench's reference, and the report cells that set their timers against a core, on canned times: not timed, no
sbt, no Verilator, no Yosys. A solver whose package is missing (they come with requirements-bench.txt, which
`make bench` installs) is skipped."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from mpc_bench import baselines, bench, fgm
from mpc_bench import qp_solvers as qs
from mpc_cores.flow import REPO

# Bounds on max |u0 - u0*| against the bench's reference (OSQP at eps 1e-9, within 1e-8 of a solve at eps 1e-12 on
# these QPs), from each solver's stopping rule at the bench's settings:
#   exact: DAQP and quadprog are active-set methods; they stop on the exact KKT point of their final active set, so
#          they agree with the reference to its own accuracy;
#   ipm:   PIQP and Clarabel stop at 1e-8 on the residuals and the (relative) duality gap; a gap g leaves
#          |z - z*| up to sqrt(2 g / mu): on the soft QP's loop Clarabel reaches 1e-4 at its worst step;
#   proxqp: ProxQP stops at eps_abs 1e-5 on the residuals, |z - z*| <= |r| / mu with mu = lambda_min(H) = 2.1 on
#          the box QP: 1e-5 with a margin of 10;
#   osqp:  OSQP stops at eps 1e-3 on the scaled residuals; on the loops its error reaches 7e-4 (box QP, tuned) and
#          2e-2 (soft QP).
BOUND = {"exact": 1e-7, "ipm": 1e-4, "proxqp": 1e-4, "osqp": 3e-2}
KIND = {qs.Daqp: "exact", qs.Quadprog: "exact", qs.PiqpDense: "ipm", qs.PiqpSparse: "ipm", qs.Clarabel: "ipm",
        qs.ProxqpDense: "proxqp", qs.Osqp: "osqp"}


@pytest.fixture(scope="module")
def box():
    """Problem A: masses condensed, the first steps of the bench's closed loop (no bound active) and the same
    parameters scaled by 4 (about 16 of the 40 bounds active)."""
    from mpc_cores.fgm.design import design_fgm
    from mpc_cores.problem import condense, load_spec

    p = load_spec(REPO / "examples/masses.yaml")
    qp = condense(p)
    W = baselines.closed_loop_qps(p, qp, design_fgm(p, P=1, frac_bits=16), 8, 4)
    W = np.vstack([W[:4], 4 * W[4:]])
    return qs.box_qp(qp), W, p.nu


@pytest.fixture(scope="module")
def soft():
    """Problem B: the soft-constrained QP of masses_rate_soft at parameters drawn in its parameter box."""
    from mpc_cores.admm.problem import build_admm_qp
    from mpc_cores.problem import load_spec

    p = load_spec(REPO / "examples/masses_rate_soft.yaml")
    qp = build_admm_qp(p)
    rng = np.random.default_rng(1)
    return qs.soft_qp(qp), np.array([rng.uniform(qp.wlo, qp.whi) for _ in range(6)]), p.nu


def _reference(lqp, W, nu):
    ref = qs.Osqp(lqp, "reference", baselines.REFERENCE)
    return np.array([ref.solve(w)[0][:nu] for w in W])


@pytest.mark.parametrize("problem,name", [(pb, nm) for pb, rows in qs.SOLVERS.items() for nm, _, _ in rows])
def test_solver_reaches_the_reference(problem, name, request):
    _, cls, settings = next(r for r in qs.SOLVERS[problem] if r[0] == name)
    pytest.importorskip(cls.module)
    lqp, W, nu = request.getfixturevalue(problem)
    u_ref = _reference(lqp, W, nu)
    s = cls(lqp, name, settings)
    err, own = [], []
    for w, u in zip(W, u_ref):       # in sequence: warm and hot starts carry over from step to step
        z, t = s.solve(w)
        t = t() if callable(t) else t
        assert z.shape == (lqp.n,)
        err.append(np.abs(z[:nu] - u).max())
        own.append(t)
    assert max(err) <= BOUND[KIND[cls]], (name, max(err))
    assert len(s.iters) == len(W) and min(s.iters) >= 0
    if cls.timer == "n/a":
        assert all(t is None for t in own)
    else:
        assert all(0 < t < 1.0 for t in own), own        # seconds
    assert s.settings


def test_daqp_hot_start_keeps_the_working_set(box):
    pytest.importorskip("daqp")
    lqp, W, _ = box
    s = qs.Daqp(lqp, "DAQP", {})
    s.solve(W[-1])
    cold = s.iters[-1]
    s.solve(W[-1])
    assert cold > 5 and s.iters[-1] == 1      # the same QP again: its active set is already the working set


def test_loop_qp_parts(soft):
    """The soft QP split for the solvers that take variable bounds: the rows with one entry 1 (the boxes and
    delta >= 0) as bounds, the two slanted rows of each soft pair as two-sided rows, nothing lost."""
    lqp = soft[0]
    E, x_l, x_u, G, h_l, h_u = lqp.parts()
    R = lqp.A.tocsr()[lqp.neq:]
    l, u = lqp.l[lqp.neq:], lqp.u[lqp.neq:]
    single = np.diff(R.indptr) == 1
    assert np.array_equal(E, lqp.A.toarray()[: lqp.neq]) and lqp.neq > 0
    assert np.array_equal(G, R[~single].toarray())
    assert np.array_equal(h_l, l[~single]) and np.array_equal(h_u, u[~single])
    assert G.shape[0] == 2 * np.count_nonzero(x_l == 0) > 0
    cols = R[single].indices
    assert len(set(cols)) == len(cols)               # one bound row per variable here
    assert np.array_equal(x_l[cols], l[single]) and np.array_equal(x_u[cols], u[single])
    free = np.setdiff1d(np.arange(lqp.n), cols)
    assert np.all(np.isinf(x_l[free])) and np.all(np.isinf(x_u[free]))


def test_every_solver_module_is_in_the_bench_requirements():
    req = (REPO / "requirements-bench.txt").read_text() + (REPO / "requirements.txt").read_text()
    names = {line.split("==")[0].strip().lower() for line in req.splitlines() if "==" in line}
    assert {cls.module for rows in qs.SOLVERS.values() for _, cls, _ in rows} <= names


# ----------------------------------------------------------------------------------------- report cells

def _sw(names, timers=True):
    """Canned timings: two replays of three solves per solver, the own timer 80 % of the wall time."""
    out = []
    for i, nm in enumerate(names):
        t = np.array([[10.0, 11.0, 30.0], [9.0, 12.0, 13.0]]) * (i + 1)
        own = 0.8 * t if timers and nm != "quadprog" else None
        out.append(baselines.SwResult(nm, "s", t, 1e-6 * (i + 1), [1, 2, 3, 1, 2, 3], 1e-9, own,
                                      "info" if own is not None else None))
    return {"solvers": out, "repeats": 2, "load": [0.5, 0.6], "cpu": 1, "missing": ["ProxQP dense"]}


def test_timings_merge_with_own_timers():
    a, b = _sw(["DAQP hot start", "quadprog"]), _sw(["DAQP hot start", "quadprog"])
    m = baselines.merge_software(a, b)
    d, q = m["solvers"]
    assert d.own_us.shape == (4, 3) and q.own_us is None and m["cpu"] == 1
    assert d.median_us == 11.0 and d.own_median_us == pytest.approx(8.8)
    assert d.p99_us == pytest.approx(np.percentile(d.times_us, 99)) and d.own_max_us == pytest.approx(24.0)


def test_core_ratios_and_tables():
    sw = _sw(["OSQP tuned", "DAQP hot start", "quadprog"])
    r = dict(P=1, b=16, **baselines.core_ratios(5.0, sw))
    assert r["core_solves_per_s"] == pytest.approx(2e5)
    # the ratios take the solver's own timer (80 % of the wall time here), the wall time where it has none
    assert r["daqp_hot_start_basis"] == "own" and r["quadprog_basis"] == "wall"
    assert r["daqp_hot_start_median_us"] == pytest.approx(22.0)
    assert r["daqp_hot_start_median_over_core"] == pytest.approx(0.8 * 22.0 / 5.0)
    assert r["daqp_hot_start_p99_over_core"] == pytest.approx(np.percentile(sw["solvers"][1].own_us, 99) / 5.0)
    assert r["quadprog_median_over_core"] == pytest.approx(33.0 / 5.0)
    assert r["osqp_tuned_throughput_ratio"] == pytest.approx(0.8 * 11.0 / 5.0)
    assert r["fastest_solver"] == "OSQP tuned" and "OSQP tuned 1.8x" in baselines.fastest_cell(r)
    timers = "\n".join(baselines.timer_table(sw))
    assert "own p99 us" in timers and "wall p99 us" in timers and "| quadprog | n/a | n/a | n/a |" in timers
    ratios = "\n".join(baselines.ratio_table([r], sw, "ECP5"))
    assert "p99 / core" in ratios and "core solves/s" in ratios
    assert "| 1 | 16 | 5.00 | 200000 | DAQP hot start | own | 17.6 |" in ratios
    assert "| 1 | 16 | 5.00 | 200000 | quadprog | wall | 33.0 |" in ratios
    notes = " ".join(baselines.software_notes(sw))
    assert "pinned to CPU 1" in notes and "Not installed, not run: ProxQP dense" in notes
    assert baselines.core_ratios(None, sw)["daqp_hot_start_median_over_core"] is None


def _fgm_core():
    c = fgm.Core("fgm", "masses", 1, 16, None, SimpleNamespace(lat_add=1, lat_mul=1, multipliers=42), 15)
    c.core = {"n": 40, "nw": 12, "nx": 8, "iterations": 15, "lat_add": 1, "lat_mul": 1, "cycles_per_iteration": 52,
              "cycles_eq23": 52, "cycles_per_solve": 823, "solve_overhead_cycles": 43, "multipliers": 42,
              "module": "FgmCore_x"}
    c.measured = {"cycles_per_iteration": 52, "cycles_per_solve": 823, "iterations": 15}
    c.pnr = {"fmax_mhz": 100.0, "target_mhz": 200.0}
    return c


def test_fgm_report_has_the_solver_columns():
    names = ["OSQP default", "OSQP tuned", "numpy FGM float64", "DAQP hot start", "PIQP dense", "ProxQP dense",
             "Clarabel", "quadprog"]
    sw = dict(_sw(names), core_err={16: (0.04, 2e-3)}, steps=3, hold=30, imax=15, u_box=(-0.5, 0.5))
    cores = [_fgm_core()]
    recs = fgm.fgm_rows(cores, sw)
    assert recs[0]["core_latency_us"] == pytest.approx(8.23) and recs[0]["quadprog_p99_over_core"] > 0
    summary = "\n".join(fgm.fgm_summary_table(recs))
    assert "fastest solver / core (median, p99)" in summary and "OSQP default 1.1x" in summary  # own: 8.8 / 8.23
    info = {"machine": {"cpu": "cpu", "cores": 2, "logical": 2, "system": "Linux", "python": "3"}, "date": "d",
            "quick": True, "Ps": (1,), "bs": (16,), "xilinx": False, "jobs": 1, "errors": [], "runtime_s": 60.0,
            "revision": "abc"}
    md = bench.report_md(cores, recs, [], {"fgm": sw}, info)
    assert "#### Per-solve time by timer, and against the core" in md
    for col in ("own median us", "own p99 us", "wall p99 us", "median / core", "p99 / core", "core solves/s"):
        assert col in md
    for nm in names:
        assert f"| {nm} |" in md
    assert "QP solvers: osqp" in md and "pinned to CPU 1" in md


def test_a_missing_package_leaves_its_solver_out(box, monkeypatch):
    # OSQP is a requirement of the package (the bench's other solvers need not be installed for make test)
    _, absent = qs.solver_makers("box", box[0])
    assert "OSQP default" not in absent
    monkeypatch.setattr(qs.Osqp, "module", "no_such_package_here")
    makers, missing = qs.solver_makers("box", box[0])
    assert sorted(missing) == sorted(set(absent) | {"OSQP default", "OSQP tuned"})
    assert len(makers) == len(qs.SOLVERS["box"]) - len(missing)
    assert "no_such_package_here" not in qs.versions()


def test_own_timer_columns_and_the_exit_loop():
    """Every core row carries each solver's own-timer median, p99 and max (None without a timer); a core with the
    exit test over the loop gets its latency quantiles at its Fmax and the own-timer ratios against them."""
    sw = _sw(["DAQP hot start", "quadprog"])
    r = baselines.core_ratios(5.0, sw)
    assert r["daqp_hot_start_own_median_us"] == pytest.approx(8.8)
    assert r["daqp_hot_start_own_max_us"] == pytest.approx(24.0) and r["quadprog_own_p99_us"] is None
    c = _fgm_core()
    c.core.update(early_exit=True, exit_tol_value=2.0 ** -9)
    rec = dict(fmax_mhz=100.0)
    fgm.loop_columns(rec, c, [1] * 98 + [15, 15], sw)
    assert rec["loop_iter_median"] == 1 and rec["loop_iter_max"] == 15 and rec["loop_exit_share"] == 0.98
    assert rec["loop_us_median"] == pytest.approx((43 + 52) / 100.0)
    assert rec["loop_us_max"] == pytest.approx((43 + 15 * 52) / 100.0)
    assert rec["daqp_hot_start_own_median_over_core"] == pytest.approx(8.8 / 0.95)
    table = "\n".join(fgm.exit_table([dict(rec, P=1, b=15)], sw))
    assert "### The exit test over the software loop" in table
    assert "| 1 / 15 / 15 | 98 % | 0.95 / " in table      # iterations, the share ended by the test, core us


@pytest.mark.skipif(not qs.installed(qs.TinyMpc), reason="tinympc not installed (make bench builds it)")
def test_tinympc_on_the_masses_loop(box):
    """TinyMPC on the spec's model: an answer of nu inputs inside the box per step, warm-started (few iterations)"""
    from mpc_cores.problem import load_spec
    from mpc_cores.quiet import c_output_silenced

    p = load_spec(REPO / "examples/masses.yaml")
    s = qs.TinyMpc(p, "TinyMPC", {})
    with c_output_silenced():
        for w in box[1]:
            u, own = s.solve(w)
            assert own is None and u.shape == (p.nu,)
            assert np.all(u >= p.umin - 1e-6) and np.all(u <= p.umax + 1e-6)
    assert len(s.iters) == len(box[1]) and max(s.iters) < 1000
