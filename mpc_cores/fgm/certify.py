"""Certified choices for the FGM core: iterations from eq. (7) of 002, fraction bits from eq. (20), integer bits
from Prop. 1 (design_fgm), c and beta from Assumption 1 (design_fgm).

Target: a solution error ||z_Imax^fixed - z*||_2 <= tol for every state in the box X0, cold start, split into
tol/2 for convergence (eq. (7) turned into a distance by strong convexity) and tol/2 for round-off (eq. (20)).
Everything here is on the quantised problem the core solves (H^_n, Phi^_n, the quantised bounds).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mpc_cores.fgm.design import DesignError, FgmDesign, design_fgm, roundoff_bound
from mpc_cores.problem import MpcProblem

MAX_ITERATIONS = 65535          # the IMAX register
FRAC_BITS_RANGE = (8, 30)        # 30 keeps coefficient words within one 32-bit AXI4-Lite word


def rate_eq7(kappa: float, i: int) -> float:
    """The factor of eq. (7) of 002: f(z_i) - f* <= rate_eq7(kappa, i) (f(z_0) - f*)."""
    return 2.0 * min((1.0 - math.sqrt(1.0 / kappa)) ** i, 4.0 * kappa / (2.0 * math.sqrt(kappa) + i) ** 2)


def kappa_eff(d: FgmDesign) -> float:
    """Condition number the fixed step size is tuned for, eq. (13) of 002: ((1 + beta^)/(1 - beta^))^2."""
    be = d.beta / (1 << d.b)
    return ((1.0 + be) / (1.0 - be)) ** 2


def cold_start(d: FgmDesign) -> np.ndarray:
    one = float(1 << d.b)
    return np.clip(0.0, d.lo / one, d.hi / one)


def initial_gap_bound(d: FgmDesign) -> float:
    """Upper bound of f(z_0; w) - f*(w) over every w in the box, z_0 = proj(0) (cold start).

    Convexity: f* >= f(z_0) + g_0'(z* - z_0), so f(z_0) - f* <= max_{z in K} g_0'(z_0 - z)
    = sum_i max(g_i (z0_i - lo_i), g_i (z0_i - hi_i)), g_0 = H^_n z_0 + Phi^_n w affine in w; each term is maximised
    separately over the interval of g_i (interval arithmetic), which bounds the maximum of the sum."""
    one = float(1 << d.b)
    z0 = cold_start(d)
    lo, hi = d.lo / one, d.hi / one
    F = d.F / one
    wlo, whi = d.xlo / one, d.xhi / one
    base = d.Hn_hat @ z0
    gmin = base + np.minimum(F * wlo, F * whi).sum(axis=1)
    gmax = base + np.maximum(F * wlo, F * whi).sum(axis=1)
    terms = np.maximum(gmax * (z0 - lo), gmin * (z0 - hi))
    return float(max(terms.sum(), 0.0))


@dataclass
class Certificate:
    tol: float
    b: int
    imax: int
    mu: float             # lambda_min(H^_n): strong convexity of the quantised problem
    kappa: float          # eq. (13)
    gap0: float           # bound of f(z_0) - f* over the box
    conv_error: float     # sqrt(2 rate_eq7 gap0 / mu): bound of ||z_Imax^exact - z*||_2
    roundoff_error: float  # eq. (20) at Imax: bound of ||z_Imax^fixed - z_Imax^exact||_2

    @property
    def total(self) -> float:
        return self.conv_error + self.roundoff_error

    def as_dict(self) -> dict:
        return dict(tol=self.tol, frac_bits=self.b, iterations=self.imax, mu=self.mu, kappa_eq13=self.kappa,
                    initial_gap_bound=self.gap0, convergence_error_bound=self.conv_error,
                    roundoff_error_bound_eq20=self.roundoff_error, total_error_bound=self.total)


def certify(d: FgmDesign, tol: float | None = None) -> Certificate:
    """Bounds of the solution error of a given design (its b and Imax) over the box, cold start."""
    mu = d.mu
    kap = kappa_eff(d)
    gap = initial_gap_bound(d)
    conv = math.sqrt(max(0.0, 2.0 * rate_eq7(kap, d.iterations) * gap / mu))
    eta = float(roundoff_bound(d, d.iterations)[-1])
    return Certificate(tol=float("nan") if tol is None else tol, b=d.b, imax=d.iterations, mu=mu, kappa=kap,
                       gap0=gap, conv_error=conv, roundoff_error=eta)


def iterations_for(d: FgmDesign, eps_f: float) -> int:
    """Smallest Imax with rate_eq7(kappa, Imax) * gap0 <= eps_f (eq. (7) of 002)."""
    kap, gap = kappa_eff(d), initial_gap_bound(d)
    if gap <= eps_f:
        return 1
    i = 1
    # the linear rate decreases monotonically; the sublinear term too, so a doubling search then bisection works
    hi = 1
    while rate_eq7(kap, hi) * gap > eps_f:
        hi *= 2
        if hi > 4 * MAX_ITERATIONS:
            return hi
    lo = hi // 2
    while lo + 1 < hi:
        mid = (lo + hi) // 2
        if rate_eq7(kap, mid) * gap > eps_f:
            lo = mid
        else:
            hi = mid
    return max(i, hi)


def design_for_tolerance(problem: MpcProblem, tol: float, **overrides) -> tuple[FgmDesign, Certificate, list[str]]:
    """Choose frac_bits and iterations so that ||z_fixed - z*||_2 <= tol for every state in the box (cold start).
    Returns the design, its certificate and the log of the frac_bits tried."""
    if not tol > 0:
        raise DesignError(f"TOL must be > 0: got {tol}")
    overrides = {k: v for k, v in overrides.items() if k not in ("frac_bits", "iterations", "tol")}
    log = []
    best = None
    for b in range(FRAC_BITS_RANGE[0], FRAC_BITS_RANGE[1] + 1):
        try:
            d = design_fgm(problem, frac_bits=b, iterations=1, **overrides)
        except DesignError as e:
            log.append(f"b={b}: refused ({e})")
            continue
        eps_f = d.mu * (tol / 2) ** 2 / 2           # ||z - z*||^2 <= 2 (f(z) - f*) / mu
        imax = iterations_for(d, eps_f)
        if imax > MAX_ITERATIONS:
            log.append(f"b={b}: eq. (7) needs {imax} iterations > {MAX_ITERATIONS}")
            continue
        d = design_fgm(problem, frac_bits=b, iterations=imax, tol=tol, **overrides)
        cert = certify(d, tol)
        log.append(f"b={b}: Imax={imax} (eq. (7)), eq. (20) bound {cert.roundoff_error:.3g} "
                   f"{'<=' if cert.roundoff_error <= tol / 2 else '>'} tol/2 = {tol / 2:.3g}")
        best = (d, cert) if best is None or cert.roundoff_error < best[1].roundoff_error else best
        if cert.roundoff_error <= tol / 2 and cert.conv_error <= tol / 2:
            return d, cert, log
    hint = ""
    if best is not None:
        hint = (f"; the best was b={best[0].b}, Imax={best[1].imax} with an eq. (20) bound of "
                f"{best[1].roundoff_error:.3g}")
    raise DesignError(f"no frac_bits in [{FRAC_BITS_RANGE[0]}, {FRAC_BITS_RANGE[1]}] meets TOL={tol:g} "
                      f"(eq. (20) round-off bound <= TOL/2 with Imax from eq. (7)){hint}: relax TOL")


def certificate_report(d: FgmDesign, cert: Certificate, log: list[str] | None = None) -> str:
    if cert.tol != cert.tol:  # no target: state the bounds of this design
        return (f"Error bounds over the whole box X0 (cold start z_0 = proj(0)), proven: ||z_Imax - z*||_2 <= "
                f"{cert.conv_error:.3g} from eq. (7) (kappa = {cert.kappa:.4g}, f(z_0) - f* <= {cert.gap0:.4g}, "
                f"mu = {cert.mu:.4g}); round-off ||z_fixed - z_exact||_2 <= {cert.roundoff_error:.3g} from eq. (20); "
                f"total {cert.total:.3g}. Use TOL=... to choose b and Imax for a target.")
    lines = [
        f"Certified design for ||z_fixed - z*||_2 <= TOL = {cert.tol:g} over the whole box X0 (cold start z_0 = proj(0)):",
        f"  Imax = {cert.imax}: eq. (7) of 002 with kappa = ((1+beta^)/(1-beta^))^2 = {cert.kappa:.4g} (eq. (13)), "
        f"f(z_0) - f* <= {cert.gap0:.4g} over X0 (convexity + interval bound, proven), "
        f"so ||z_Imax - z*||_2 <= sqrt(2 (f - f*)/mu) = {cert.conv_error:.3g} <= TOL/2 (mu = {cert.mu:.4g})   [proven]",
        f"  b = {cert.b}: eq. (20) of 002 gives ||z_fixed - z_exact||_2 <= {cert.roundoff_error:.3g} <= TOL/2 "
        f"at Imax = {cert.imax}   [proven, projection assumed non-expansive as in 002]",
        f"  integer bits: Prop. 1 of 002 on the quantised words (no overflow for any state in X0)   [proven]",
        f"  c = {d.c:.6g}, beta^ = {d.beta / (1 << d.b):.6f}: Assumption 1 of 002 checked on the quantised data   [checked]",
        f"  total bound {cert.total:.3g} <= TOL; warm starts are not covered by the certificate (z_0 then depends on "
        f"the previous sample)",
    ]
    if log:
        lines.append("  frac_bits tried: " + "; ".join(log))
    return "\n".join(lines)


def certificate_text(d: FgmDesign) -> str:
    """The certificate of a design as `make design` prints it (no tolerance target)."""
    return certificate_report(d, certify(d, None))


def write_certified_spec(kind, problem_path, tol: float, overrides: dict, out=None) -> Path:
    """`make design TOL=...`: choose b and Imax with guarantees, print the report and certificate, and write the spec
    `make verilog` takes (to `out`, default build/design/<name>_tol<tol>.yaml)."""
    import yaml

    from mpc_cores.problem import load_spec

    p = load_spec(problem_path)
    d, cert, log = design_for_tolerance(p, tol, **overrides)
    print(kind.design_report(d))
    print(certificate_report(d, cert, log))
    spec = yaml.safe_load(Path(problem_path).read_text())
    spec.setdefault("name", p.name)
    spec["solver"] = dict(spec.get("solver") or {}, frac_bits=d.b, iterations=d.iterations, P=d.P,
                          lat_add=d.lat_add, lat_mul=d.lat_mul, rounding=d.rounding, tol=float(tol))
    out = Path(out or f"build/design/{p.name}_tol{tol:g}.yaml")
    out.parent.mkdir(parents=True, exist_ok=True)
    header = (f"# Designed by `make design TOL={tol:g}` from {problem_path}: frac_bits and iterations certified by\n"
              f"# eq. (7) and eq. (20) of 002 for ||z_fixed - z*||_2 <= {tol:g} over the state box (cold start).\n")
    out.write_text(header + yaml.safe_dump(spec, sort_keys=False))
    print(f"wrote {out}  (next: make verilog PROBLEM={out})")
    return out
