"""The FGM front end (mpc_cores/fgm/design.py) and golden models (mpc_cores/fgm/model.py) against the analysis of 002:
Algorithm 1, Assumption 1, the overflow bounds of Prop. 1 (eq. (14)), the round-off bound of Prop. 2 (eq. (20))
and the convergence bound (7)."""
import dataclasses
import functools
import itertools
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from mpc_cores.fgm.design import DesignError, design_fgm, int_bits_of, roundoff_bound
from mpc_cores.fgm.model import FgmFixed, fgm_float, fgm_float_quantised
from mpc_cores.fixed import bits_for, quantize, shift_round
from mpc_cores.problem import CondensedQP, SpecError, condense, load_spec, problem_from_dict, qp_objective
from mpc_cores.reference import kkt_residual, solve_qp_exact, solve_qp_osqp

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


@functools.lru_cache(maxsize=None)
def problem(name):
    return load_spec(EXAMPLES / f"{name}.yaml")


@functools.lru_cache(maxsize=None)
def design(name, b, rounding="truncate"):
    return design_fgm(problem(name), frac_bits=b, rounding=rounding)


ROUNDOFF_CONFIGS = [
    ("masses", 12, "truncate"),
    ("masses", 12, "nearest"),
    ("masses", 16, "truncate"),
    ("masses", 16, "nearest"),
    ("afm_like", 16, "truncate"),
    ("afm_like", 16, "nearest"),
]
# every design the tests below build from the examples; Assumption 1 is checked on all of them
ALL_CONFIGS = ROUNDOFF_CONFIGS + [("masses", 6, "truncate"), ("afm_like", 11, "truncate"), ("afm_like", 12, "nearest")]


def _cfg_id(c):
    return "-".join(map(str, c))


def random_words(d, rng, count):
    """w words drawn uniformly from the accepted box [xlo, xhi]."""
    return [rng.integers(d.xlo, d.xhi + 1) for _ in range(count)]


def quantised_qp(d):
    """The QP the core actually solves: H^_n, Phi^_n and the box K^, in reals (words / 2^b)."""
    one = float(1 << d.b)
    return CondensedQP(H=d.Hn_hat, Phi=d.F / one, lb=d.lo / one, ub=d.hi / one, n=d.n, nw=d.nw, nu=d.nu)


# ---------------------------------------------------------------------------
# (a) fixed point vs exact arithmetic on the quantised data: eq. (20)

IMAX_ROUNDOFF = 40


@pytest.mark.parametrize("cfg", ROUNDOFF_CONFIGS, ids=_cfg_id)
def test_roundoff_within_eq20(cfg, record_property):
    d = design(*cfg)
    one = float(1 << d.b)
    eta = roundoff_bound(d, IMAX_ROUNDOFF)
    assert eta[0] == 0.0 and np.all(np.diff(eta) > 0)
    model = FgmFixed(d)
    rng = np.random.default_rng(1000 + d.b)
    worst_ratio, worst_err = 0.0, 0.0
    for w in random_words(d, rng, 50):
        res = model.solve(w, IMAX_ROUNDOFF, warm=False, record=True)
        assert not res.overflow and not res.sat
        exact = fgm_float_quantised(d, w, IMAX_ROUNDOFF)
        assert len(res.iterates) == len(exact) == IMAX_ROUNDOFF + 1
        # both start from clip(0, lo, hi): eta_0 = 0, so only the arithmetic term of (20) remains
        assert np.array_equal(res.iterates[0] / one, exact[0])
        err = np.array([np.linalg.norm(zi / one - ze) for zi, ze in zip(res.iterates, exact)])
        assert np.all(err <= eta), (cfg, np.flatnonzero(err > eta))
        worst_ratio = max(worst_ratio, float(np.max(err[1:] / eta[1:])))
        worst_err = max(worst_err, float(err.max()))
    record_property("max_observed_over_eq20", worst_ratio)
    record_property("max_error", worst_err)
    print(f"{_cfg_id(cfg)}: max |z^_i - z_i| / eta_i = {worst_ratio:.4g}, max error {worst_err:.3g}")
    assert worst_ratio < 1
    assert worst_err > 0, "fixed point and exact iterates never differ: the comparison cannot fail"


# ---------------------------------------------------------------------------
# (b) convergence to the QP solution: eq. (20) + eq. (7)


def convergence_radius(d, qpq, w_real, z0, zstar, imax):
    """Upper bound on ||z_i - z*||_2, i = 0..imax, for exact-arithmetic iterates of Algorithm 1 on the quantised QP.

    Eq. (7) with L = 1 (Assumption 1(i)) and the effective condition number kappa_n of eq. (13), since the rounded-up
    beta^ corresponds to a convexity parameter ((1 - beta^)/(1 + beta^))^2 <= mu; then strong convexity
    f(z) - f* >= mu/2 ||z - z*||^2 with mu = lambda_min(H^_n)."""
    beta = d.beta / (1 << d.b)
    kappa = ((1 + beta) / (1 - beta)) ** 2
    mu = d.mu
    fstar = qp_objective(qpq, zstar, w_real)
    gap0 = max(qp_objective(qpq, z0, w_real) - fstar, 0.0)
    i = np.arange(imax + 1, dtype=float)
    rate = np.minimum((1 - math.sqrt(1 / kappa)) ** i, 4 * kappa / (2 * math.sqrt(kappa) + i) ** 2)
    fgap = rate * 2 * gap0
    return np.sqrt(2 * fgap / mu), fgap, fstar


def test_fixed_point_converges_to_quantised_qp_solution(record_property):
    d = design("masses", 16)
    one = float(1 << d.b)
    qpq = quantised_qp(d)
    beta = d.beta / one
    kappa = ((1 + beta) / (1 - beta)) ** 2
    # iterations for the linear rate of (7) to reach 1e-12: beyond that the round-off term of (20) dominates
    imax = math.ceil(math.log(1e-12) / math.log(1 - math.sqrt(1 / kappa)))
    assert 50 < imax < 400
    eta = roundoff_bound(d, imax)
    model = FgmFixed(d)
    rng = np.random.default_rng(2024)
    margins, ratios, conv_end = [], [], []
    for w in random_words(d, rng, 20):
        w_real = np.clip(w, d.xlo, d.xhi) / one
        zstar = solve_qp_osqp(qpq, w_real)
        # the two references agree on the quantised QP
        assert np.linalg.norm(zstar - solve_qp_exact(qpq, w_real)) < 1e-8
        res = model.solve(w, imax, warm=False, record=True)
        assert not res.overflow
        exact = fgm_float_quantised(d, w, imax)
        radius, fgap, fstar = convergence_radius(d, qpq, w_real, exact[0], zstar, imax)
        for i in range(imax + 1):
            # eq. (7) itself on the exact-arithmetic iterates, and the distance it implies
            assert qp_objective(qpq, exact[i], w_real) - fstar <= fgap[i] + 1e-12, i
            assert np.linalg.norm(exact[i] - zstar) <= radius[i] + 1e-9, i
            # fixed point: round-off (20) plus convergence (7)
            err = np.linalg.norm(res.iterates[i] / one - zstar)
            assert err <= eta[i] + radius[i] + 1e-9, i
        err = float(np.linalg.norm(res.z / one - zstar))
        margins.append(eta[imax] + radius[imax] + 1e-9 - err)
        ratios.append(err / (eta[imax] + radius[imax] + 1e-9))
        conv_end.append(radius[imax])
    record_property("imax", imax)
    record_property("min_margin", min(margins))
    record_property("max_ratio", max(ratios))
    print(f"imax={imax}, eta={eta[imax]:.4g}, max conv radius={max(conv_end):.3g}, "
          f"min margin={min(margins):.4g}, max err/bound={max(ratios):.4g}")
    assert max(conv_end) < 1e-3   # imax is in the converged regime


@pytest.mark.parametrize("name", ["masses", "afm_like"])
def test_float_fgm_on_normalised_qp_converges_to_osqp(name):
    # Algorithm 1 with the normalisation of Assumption 1 but no quantisation solves the original condensed QP
    p = problem(name)
    d = design(name, 16)
    qp = condense(p)
    scale = d.c * d.lam_max
    Hn, Phin = qp.H / scale, qp.Phi / scale
    lam = np.linalg.eigvalsh(Hn)
    assert 0 < lam[0] and lam[-1] <= 1 + 1e-3
    mu = float(lam[0])
    beta = (1 - math.sqrt(mu)) / (1 + math.sqrt(mu))
    G = np.eye(qp.n) - Hn
    rng = np.random.default_rng(7 if name == "masses" else 8)
    wlo = np.concatenate([p.xmin, p.rmin])
    whi = np.concatenate([p.xmax, p.rmax])
    for _ in range(20 if name == "masses" else 8):
        w = rng.uniform(wlo, whi)
        zstar = solve_qp_osqp(qp, w)
        z = fgm_float(G, Phin, beta, qp.lb, qp.ub, w, 2000)[-1]
        assert np.all(z >= qp.lb) and np.all(z <= qp.ub)
        assert np.linalg.norm(z - zstar) < 1e-6
        assert kkt_residual(qp, z, w) < 1e-6


# ---------------------------------------------------------------------------
# (c) Assumption 1 and the construction of the quantised data


@pytest.mark.parametrize("cfg", ALL_CONFIGS, ids=_cfg_id)
def test_assumption1_holds(cfg):
    d = design(*cfg)
    one = 1 << d.b
    p = d.problem
    assert np.array_equal(d.A, d.A.T)
    lam = np.linalg.eigvalsh(d.Hn_hat)
    # (i): eigenvalues of H^_n in (0, 1]
    assert lam[0] > 0 and lam[-1] <= 1.0
    assert d.mu == pytest.approx(lam[0], rel=1e-12)
    # (ii): 1 > beta^ >= (sqrt(kappa) - 1)/(sqrt(kappa) + 1) >= 0
    kappa = lam[-1] / lam[0]
    beta = d.beta / one
    assert 1 > beta >= (math.sqrt(kappa) - 1) / (math.sqrt(kappa) + 1) >= 0
    assert ((1 + beta) / (1 - beta)) ** 2 >= kappa        # eq. (13)
    assert d.one_plus_beta == one + d.beta
    # H_n = H^_F / (c lambda_max(H^_F)), Phi_n likewise, c >= 1
    Hq = quantize(d.qp.H, d.b) / one
    assert d.c >= 1
    assert d.lam_max == pytest.approx(np.linalg.eigvalsh(Hq)[-1], rel=1e-12)
    assert np.array_equal(d.A, quantize(np.eye(d.n) - Hq / (d.c * d.lam_max), d.b))
    assert np.array_equal(d.F, quantize(d.qp.Phi / (d.c * d.lam_max), d.b))
    # K^ inside K, X_0 inside X^_0
    assert np.all(d.lo / one >= d.qp.lb) and np.all(d.hi / one <= d.qp.ub) and np.all(d.lo <= d.hi)
    assert np.all(d.xlo / one <= np.concatenate([p.xmin, p.rmin]))
    assert np.all(d.xhi / one >= np.concatenate([p.xmax, p.rmax]))


# ---------------------------------------------------------------------------
# (d) Prop. 1: no overflow anywhere in the box, and the recorded bounds cover what the datapath reaches


class ProbedFgm(FgmFixed):
    """FgmFixed that records the largest |word| of every product and adder-tree partial sum, of t and of y,
    recomputed without saturation from the operands the model feeds its dot products."""

    def __init__(self, d):
        super().__init__(d)
        self.peak = {"sum": 0, "t": 0, "y": 0}
        self._h = None

    def _dot(self, M, v):
        out, flag = super()._dot(M, v)
        d = self.d
        Mp = np.zeros((M.shape[0], d.m), dtype=np.int64)      # the same zero padding as the m-input tree
        Mp[:, : M.shape[1]] = M
        vp = np.zeros(d.m, dtype=np.int64)
        vp[: v.shape[0]] = v
        level = shift_round(Mp * vp[None, :], d.b, d.rounding)
        peak = int(np.abs(level).max())
        while level.shape[1] > 1:
            k = level.shape[1]
            nxt = level[:, 0 : k - k % 2 : 2] + level[:, 1 : k - k % 2 : 2]
            level = np.concatenate([nxt, level[:, k - 1 :]], axis=1) if k % 2 else nxt
            peak = max(peak, int(np.abs(level).max()))
        if not flag:
            assert np.array_equal(out, level[:, 0])
        self.peak["sum"] = max(self.peak["sum"], peak)
        if M is self.F:
            self._h = out
        else:  # v is y_i, out - h is t_i
            self.peak["y"] = max(self.peak["y"], int(np.abs(v).max()))
            self.peak["t"] = max(self.peak["t"], int(np.abs(out - self._h).max()))
        return out, flag

    def note_last_y(self, iterates):
        # y_Imax is formed but never multiplied: recompute it from the last two iterates
        z1, z0 = iterates[-1], iterates[-2]
        y = shift_round(self.opb * z1, self.d.b, self.d.rounding) - shift_round(self.beta * z0, self.d.b, self.d.rounding)
        self.peak["y"] = max(self.peak["y"], int(np.abs(y).max()))


def box_corner_words(d, rng):
    """All-min, all-max, all 2^4 patterns on four components (the rest at random corners), random corners and
    uniform points: >= 100 words."""
    ws = [d.xlo.copy(), d.xhi.copy()]
    nx = d.problem.nx
    comps = sorted({0, nx // 2, nx - 1, d.nw - 1})
    for pat in itertools.product([False, True], repeat=len(comps)):
        for base in (d.xlo, d.xhi, np.where(rng.random(d.nw) < 0.5, d.xlo, d.xhi)):
            w = base.copy()
            for c, hi in zip(comps, pat):
                w[c] = d.xhi[c] if hi else d.xlo[c]
            ws.append(w)
    ws += [np.where(rng.random(d.nw) < 0.5, d.xlo, d.xhi) for _ in range(20)]
    ws += random_words(d, rng, 30)
    return ws


PROP1_CONFIGS = [("masses", 16, "truncate"), ("masses", 16, "nearest"), ("masses", 12, "truncate"),
                 ("afm_like", 16, "truncate"), ("afm_like", 16, "nearest")]


@pytest.mark.parametrize("cfg", PROP1_CONFIGS, ids=_cfg_id)
def test_prop1_no_overflow_and_bounds_cover_datapath(cfg, record_property):
    d = design(*cfg)
    rng = np.random.default_rng(3000 + d.b)
    ws = box_corner_words(d, rng)
    assert len(ws) >= 100
    model = ProbedFgm(d)
    imax = 40
    for k, w in enumerate(ws):
        # alternate cold and warm starts: both start inside K^
        res = model.solve(w, imax, warm=bool(k % 2), record=True)
        assert not res.overflow, (cfg, k)
        assert not res.sat
        assert all(np.all(z >= d.lo) and np.all(z <= d.hi) for z in res.iterates)
        model.note_last_y(res.iterates)
    # states beyond the box saturate at the input and still cannot overflow the datapath
    for w in (d.xlo - 1000, d.xhi + 1000):
        res = model.solve(w, imax, warm=False, record=True)
        assert res.sat and not res.overflow
        model.note_last_y(res.iterates)
    for sig in ("sum", "t", "y"):
        seen, bound, width = model.peak[sig], d.bounds[sig], d.widths[sig]
        record_property(f"{sig}_seen_over_bound", seen / bound)
        assert 0 < seen <= bound, sig
        assert bits_for(bound) <= width
        assert bits_for(seen) >= width - 3, f"{sig}: width {width} but only {bits_for(seen)} bits used"
    assert d.bounds["y"] >= d.bounds["z"]
    assert d.bounds["x"] == int(np.max(np.maximum(np.abs(d.xlo), np.abs(d.xhi))))


def test_overflow_flag_raised_when_widths_too_small():
    # the brute-force test above can only pass if the flag works: starve the sum word and it must fire
    d = design("masses", 16)
    cfg = d.config()
    cfg["widths"] = dict(cfg["widths"], sum=d.widths["sum"] - 3)
    assert FgmFixed(cfg).solve(d.xhi, 15, warm=False).overflow
    cfg = d.config()
    cfg["widths"] = dict(cfg["widths"], y=d.widths["y"] - 2)
    assert FgmFixed(cfg).solve(d.xhi, 15, warm=False).overflow


# ---------------------------------------------------------------------------
# (e) refusals


def test_refuses_P_out_of_range():
    p = problem("masses")
    n = condense(p).n
    with pytest.raises(DesignError, match=rf"P must be in \[1, n\].*P={n + 1}, n={n}"):
        design_fgm(p, P=n + 1)
    with pytest.raises(DesignError, match=r"P must be in \[1, n\].*P=0"):
        design_fgm(p, P=0)
    assert design_fgm(p, P=n).P == n


@pytest.mark.parametrize("name,b", [("afm_like", 6), ("afm_like", 10), ("masses", 4)])
def test_refuses_too_few_frac_bits_for_assumption1(name, b):
    with pytest.raises(DesignError, match=rf"Assumption 1\(i\) of 002 fails at frac_bits={b}.*increase frac_bits"):
        design_fgm(problem(name), frac_bits=b)


def test_refuses_int_bits_below_prop1():
    p = problem("masses")
    d = design("masses", 16)
    with pytest.raises(DesignError, match=r"below the \d+ integer bits that Prop\. 1 of 002 requires"):
        design_fgm(p, int_bits=0)
    req = {k: int_bits_of(d, k) for k in ("y", "sum", "t")}
    for k in req:
        with pytest.raises(DesignError, match=rf"for signal '{k}'.*Prop\. 1"):
            design_fgm(p, int_bits={k: req[k] - 1})
    # exactly the requirement is accepted and changes nothing; more widens the word
    assert design_fgm(p, int_bits=req).widths == d.widths
    assert design_fgm(p, int_bits={"t": req["t"] + 4}).widths["t"] == d.widths["t"] + 4
    with pytest.raises(DesignError, match="unknown signal 'z'"):
        design_fgm(p, int_bits={"z": 5})


@pytest.mark.parametrize("overrides,msg", [
    ({"rounding": "even"}, r"rounding must be one of \('truncate', 'nearest'\): got 'even'"),
    ({"iterations": 0}, r"iterations must be in \[1, 65535\]: got 0"),
    ({"iterations": 65536}, r"iterations must be in \[1, 65535\]: got 65536"),
    ({"frac_bits": 0}, r"frac_bits must be >= 1"),
    ({"c": 0.5}, r"c must be >= 1 \(Assumption 1"),
    ({"lat_add": -1}, r"lat_add and lat_mul must be >= 0"),
])
def test_refuses_bad_options(overrides, msg):
    with pytest.raises(DesignError, match=msg):
        design_fgm(problem("masses"), **overrides)


def test_refuses_indefinite_hessian():
    spec = yaml.safe_load((EXAMPLES / "masses.yaml").read_text())
    spec["cost"]["R"] = -1.0e-3
    with pytest.raises(SpecError, match=r"cost\.R must be positive definite"):
        problem_from_dict(spec)
    # a problem object built past the spec checks: the front end must still refuse it
    p = dataclasses.replace(problem("masses"), R=-10.0 * np.eye(4))
    assert np.linalg.eigvalsh(condense(p).H)[0] < 0
    with pytest.raises(DesignError, match="H_F is not positive definite"):
        design_fgm(p)
    # A PSD-but-singular H_F (R = 0 with a rank-deficient prediction) has a computed smallest eigenvalue of
    # either sign at rounding level, so the refusal of that case is not deterministic and is not tested.


# ---------------------------------------------------------------------------
# (f) warm start


def test_warm_start_shifts_previous_solution():
    d = design("masses", 16)
    n, nu, one = d.n, d.nu, 1 << d.b
    rng = np.random.default_rng(55)
    w1, w2, w3 = random_words(d, rng, 3)
    model = FgmFixed(d)
    cold0 = np.clip(np.zeros(n, dtype=np.int64), d.lo, d.hi)

    r0 = model.solve(w1, 10, warm=True, record=True)   # nothing to warm-start from yet
    assert np.array_equal(r0.iterates[0], cold0)
    r1 = model.solve(w1, 15, warm=False)
    shifted = np.concatenate([r1.z[nu:], r1.z[n - nu:]])
    assert not np.array_equal(shifted, cold0)
    r1.z[:] = 0  # the model keeps its own copy
    r2 = model.solve(w2, 12, warm=True, record=True)
    assert np.array_equal(r2.iterates[0], shifted)
    # eq. (20) with eta_0 = 0 also holds from a warm start (same z_0 in exact arithmetic)
    exact = fgm_float_quantised(d, w2, 12, z0_words=shifted)
    eta = roundoff_bound(d, 12)
    for i, (zi, ze) in enumerate(zip(r2.iterates, exact)):
        assert np.linalg.norm(zi / one - ze) <= eta[i]

    # warm=None follows the design (warm_start defaults to True)
    assert d.warm_start
    r3 = model.solve(w3, 5, record=True)
    assert np.array_equal(r3.iterates[0], np.concatenate([r2.z[nu:], r2.z[n - nu:]]))

    # reset: cold start from clip(0, lo, hi)
    model.reset()
    r4 = model.solve(w3, 5, warm=True, record=True)
    assert np.array_equal(r4.iterates[0], cold0)

    # a bounds write invalidates the warm start; the cold start uses the new bounds
    model.solve(w1, 5, warm=True)
    new_lo = d.lo.copy()
    new_lo[::3] = d.hi[::3] // 4          # positive lower bounds: clip(0, lo, hi) is no longer 0 there
    assert np.all(new_lo <= d.hi) and np.any(new_lo > 0)
    model.write_bounds(lo=new_lo)
    r5 = model.solve(w2, 8, warm=True, record=True)
    assert np.array_equal(r5.iterates[0], np.clip(np.zeros(n, dtype=np.int64), new_lo, d.hi))
    assert all(np.all(z >= new_lo) and np.all(z <= d.hi) for z in r5.iterates)
    model.solve(w3, 5, warm=True)
    new_hi = d.hi.copy()
    new_hi[1::2] = d.lo[1::2] // 4        # negative upper bounds
    model.write_bounds(hi=new_hi)
    r6 = model.solve(w3, 5, warm=True, record=True)
    assert np.array_equal(r6.iterates[0], np.clip(np.zeros(n, dtype=np.int64), new_lo, new_hi))


def test_no_warm_start_design_always_cold():
    d = design_fgm(problem("masses"), frac_bits=16, warm_start=False)
    model = FgmFixed(d)
    rng = np.random.default_rng(56)
    w1, w2 = random_words(d, rng, 2)
    a = model.solve(w1, 15)
    b = model.solve(w2, 15, record=True)
    assert np.array_equal(b.iterates[0], np.clip(np.zeros(d.n, dtype=np.int64), d.lo, d.hi))
    # cold solves do not depend on history
    assert np.array_equal(FgmFixed(d).solve(w2, 15).z, b.z)
    assert np.array_equal(model.solve(w1, 15).z, a.z)
    # warm=True overrides the design default
    c = model.solve(w2, 3, warm=True, record=True)
    assert np.array_equal(c.iterates[0], np.concatenate([a.z[d.nu:], a.z[d.n - d.nu:]]))


def test_fgm_refuses_state_constrained_specs():
    """Rate and soft/hard state constraints are beyond the FGM core: refused, not silently dropped."""
    with pytest.raises(DesignError, match="input-constrained MPC only.*input_rate, soft_states"):
        design_fgm(load_spec(Path(__file__).resolve().parents[1] / "examples/masses_rate_soft.yaml"))


def test_design_report_names_the_b_of_one_dsp_per_product():
    """On a DSP target, the report names the largest b at which every product is one DSP, and the DSPs it saves;
    at that b (or on the generic target) it says nothing."""
    from mpc_cores.fgm.report import design_report
    from mpc_cores.target import parts

    masses = load_spec(Path(__file__).parents[1] / "examples/masses.yaml")
    d = design_fgm(masses, P=3, target="ecp5", lat_mul=4)
    assert any(parts("ecp5", *p) > 1 for p in d.products())
    assert "Fit: b = 15 keeps every product on one DSP (126 instead of 246;" in design_report(d)
    d15 = design_fgm(masses, P=3, target="ecp5", lat_mul=4, frac_bits=15)
    assert all(parts("ecp5", *p) == 1 for p in d15.products())
    assert "Fit:" not in design_report(d15)
    assert "Fit:" not in design_report(design_fgm(masses, P=3))


# ----------------------------------------------------------------------------------------- the exit test

def _exit_design(name="masses", b=16, **ov):
    return design_fgm(problem(name), frac_bits=b, early_exit=True, **ov)


def test_exit_test_stops_where_the_steps_fall_below_the_tolerance():
    """With the exit test the model runs the plain iteration and stops after the first iteration whose step and the
    previous one are below EXIT_TOL (the first iteration's previous step is 0): its answer is the plain model's at
    that many iterations; EXIT_TOL 0 never stops before IMAX; MET says whether the test ended the solve."""
    d = _exit_design()
    rng = np.random.default_rng(3)
    plain, ex = FgmFixed(d.config() | {"early_exit": False}), FgmFixed(d)
    counts = []
    for k in range(30):
        w = rng.integers(d.xlo, d.xhi + 1)
        tol = int(rng.choice([0, 2, 64, 1024, 8192]))
        r = ex.solve(w, imax=60, warm=False, record=True, exit_tol=tol)
        steps = [int(np.abs(b - a).max()) for a, b in zip(r.iterates, r.iterates[1:])]
        ok = [s < tol for s in steps]
        first = next((i + 1 for i in range(len(ok)) if ok[i] and (i == 0 or ok[i - 1])), None)
        assert r.iterations == (first or 60) and r.met == (first is not None), (tol, steps)
        assert np.array_equal(r.z, plain.solve(w, imax=r.iterations, warm=False).z)
        counts.append(r.iterations)
        if tol == 0:
            assert r.iterations == 60 and not r.met
    assert min(counts) < 60 and max(counts) == 60, counts


def test_exit_bound_holds_for_the_exact_iteration():
    """The suboptimality the design report states for the exit test, n (1 + beta)^2 eps^2 (1/mu - 1) / 2 on the
    normalised cost (times c lambda_max on V), holds for Algorithm 1 in float64 on the quantised data stopped by the
    same test, at random states of the box and several tolerances; and it is not loose by more than it must be
    (the worst case comes within 10^4 of it)."""
    d = _exit_design("afm_like")
    one = float(1 << d.b)
    G, Phi, lb, ub = d.A / one, d.F / one, d.lo / one, d.hi / one
    Hn = np.eye(d.n) - G
    beta = d.beta / one
    rng = np.random.default_rng(5)
    worst = 0.0
    for tol_word in (4, 64, 1024):
        eps = tol_word / one
        bound = d.exit_bound(tol_word) / (d.c * d.lam_max)
        for _ in range(20):
            w = rng.integers(d.xlo, d.xhi + 1) / one
            h = Phi @ w
            f = lambda z: 0.5 * z @ Hn @ z + h @ z  # noqa: E731
            z = np.clip(np.zeros(d.n), lb, ub)
            y, prev_ok = z.copy(), True
            for _ in range(5000):
                zn = np.clip(G @ y - h, lb, ub)
                ok = np.abs(zn - z).max() < eps
                y, z, met, prev_ok = (1 + beta) * zn - beta * z, zn, ok and prev_ok, ok
                if met:
                    break
            zs = fgm_float(G, Phi, beta, lb, ub, w, 20000)[-1]
            gap = f(z) - f(zs)
            assert gap <= bound * (1 + 1e-9) + 1e-12, (tol_word, gap, bound)
            worst = max(worst, gap / bound)
    assert worst > 1e-4, worst


def test_exit_options_are_checked():
    """early_exit builds the test (EXIT_TOL 2 LSB by default), exit_tol alone builds it too; the cycle count grows
    by max(0, 5 - l_M - l_A); refusals name the rule."""
    d = _exit_design(b=12, lat_add=0, lat_mul=0)
    assert d.exit_tol == 2 and d.exit_extra == 5
    assert d.cycles_per_iteration == design_fgm(problem("masses"), frac_bits=12, lat_add=0, lat_mul=0).cycles_per_iteration + 5
    assert design_fgm(problem("masses"), frac_bits=12, exit_tol=2.0 ** -6).exit_tol == 64
    assert _exit_design(b=12, lat_add=1, lat_mul=4).exit_extra == 0
    with pytest.raises(DesignError, match="early_exit needs one problem"):
        _exit_design(b=12, problems=2)
    with pytest.raises(DesignError, match="exit_tol needs early_exit"):
        design_fgm(problem("masses"), frac_bits=12, early_exit=False, exit_tol=0.01)
    with pytest.raises(DesignError, match="exit_tol must be in"):
        design_fgm(problem("masses"), frac_bits=12, exit_tol=2.0 ** -14)
