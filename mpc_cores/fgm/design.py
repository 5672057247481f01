"""FGM front end: from an MPC problem to the quantised data and word widths of the core.

Normalisation and the step size follow Assumption 1 of 002: H_n = H_F / (c lambda_max(H^_F)),
Phi_n = Phi / (c lambda_max(H^_F)), beta = (1 - sqrt(mu)) / (1 + sqrt(mu)) with mu = lambda_min(H^_n) and L = 1.
Integer bits of every signal come from the overflow bounds of Prop. 1 of 002, evaluated on the quantised
integers with one LSB of slack per rounded product, so that no word can overflow for any state in the box.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from mpc_cores.design_base import (FixedPointDesign, apply_target, check_run_options, module_suffix,
                                   problems_option, run_options, solver_opt, target_option)
from mpc_cores.errors import MODEL_PRODUCT_BITS, DesignError  # noqa: F401  (DesignError: part of this API)
from mpc_cores.fixed import bits_for, quantize
from mpc_cores.interleave import PASS_QUEUE, PASS_START, Interleave
from mpc_cores.problem import MpcProblem, condense


# The exit test (FgmCore): cycles from the last row's z to the sequencer's decision, and EXIT_TOL's default word
# (2: an iteration ends the solve when no row moved by more than one LSB, twice in a row)
EXIT_DECISION = 5
EXIT_TOL_LSB = 2


@dataclass
class FgmDesign(FixedPointDesign):
    """qp: the CondensedQP."""
    output_all: bool
    c: float
    lam_max: float            # lambda_max of the quantised H_F
    A: np.ndarray             # (I - H^_n) words, n x n
    F: np.ndarray             # Phi^_n words, n x nw
    lo: np.ndarray            # input bounds words (n,), inside the real bounds
    hi: np.ndarray
    xlo: np.ndarray           # box of accepted w = (x, r) words (nw,), containing the real box
    xhi: np.ndarray
    beta: int                 # beta^ word
    one_plus_beta: int
    tol: float | None = None  # target solution error the design was certified for (make design TOL=...)
    problems: int = 1         # K_p, problems interleaved on the row units (mpc_cores.interleave)
    early_exit: bool = False  # the exit test is built (EXIT_TOL; FgmCore): a solve may end before Imax
    exit_tol: int = 0         # EXIT_TOL's reset value, a word of z (0: no exit before Imax)
    widths: dict = field(default_factory=dict)
    bounds: dict = field(default_factory=dict)   # integer-word bounds per signal
    prop1: dict = field(default_factory=dict)    # Prop. 1 bounds in real units

    def label(self) -> str:
        """the design in a table row (make demo)"""
        return f"b = {self.b}, Imax = {self.iterations}"

    @property
    def m(self) -> int:
        return max(self.n, self.nw)

    @property
    def Hn_hat(self) -> np.ndarray:
        return np.eye(self.n) - self.A / (1 << self.b)

    @property
    def mu(self) -> float:
        return float(np.linalg.eigvalsh(self.Hn_hat)[0])

    # ---- cycle contract (mirrors FgmParams.scala; the tests check both against simulation)
    @property
    def K(self) -> int:
        return -(-self.n // self.P)

    @property
    def tree_depth(self) -> int:
        return max(0, math.ceil(math.log2(self.m))) if self.m > 1 else 0

    @property
    def exit_extra(self) -> int:
        """cycles the exit test adds to an iteration (FgmParams.exitExtra): its decision reaches the sequencer 5
        cycles after the last row's z, of which the y update's lat_mul + lat_add cover part"""
        return max(0, EXIT_DECISION - self.lat_mul - self.lat_add) if self.early_exit else 0

    @property
    def cycles_per_iteration(self) -> int:
        return self.K + self.lat_add * self.tree_depth + 2 * self.lat_mul + 3 * self.lat_add + 1 + self.exit_extra

    def exit_bound(self, tol_word: int | None = None) -> float | None:
        """The suboptimality V(z) - V* the exit test implies for the exact iteration on the core's quantised data
        (None without the test or at EXIT_TOL 0): the answer z_i = proj(y_(i-1) - grad f_n(y_(i-1))) has
        ||y_(i-1) - z_i||_inf < (1 + beta) eps (FgmCore), and for f_n mu-strongly convex with L = 1,
        f_n(z_i) - f_n* <= ||G||_2^2 (1 / mu - 1) / 2 with G = y_(i-1) - z_i; V = c lambda_max f_n."""
        tol_word = self.exit_tol if tol_word is None else tol_word
        if not self.early_exit or tol_word <= 0:
            return None
        one = float(1 << self.b)
        eps = (1 + self.beta / one) * tol_word / one
        return self.c * self.lam_max * self.n * eps ** 2 * (1.0 / self.mu - 1.0) / 2

    @property
    def cycles_eq23(self) -> int:
        d = math.ceil(math.log2(self.n)) if self.n > 1 else 0
        return self.K + self.lat_add * d + 2 * self.lat_mul + 3 * self.lat_add + 1

    def cycles_per_solve(self, imax: int | None = None) -> int:
        """one problem: from the last input word to the first output word; interleaving: the least of that"""
        imax = self.iterations if imax is None else imax
        if self.problems > 1:
            return self.interleave.latency_bounds(imax)[0]
        return self.solve_overhead + imax * self.cycles_per_iteration

    @property
    def solve_overhead(self) -> int:
        """one problem: the start PASS_START cycles after the last word, the first pass's K rows and two cycles, the
        answer's queue"""
        return PASS_START + 2 + self.K + PASS_QUEUE

    @property
    def interleave(self):
        return Interleave(self.K, self.problems, self.cycles_per_iteration)

    @property
    def period_cycles(self) -> int:
        """cycles between two iterations of one problem: L_F, or the round of K_p turns when interleaving"""
        return self.interleave.R

    @property
    def multipliers(self) -> int:
        return self.P * self.m + 2 * self.P

    @property
    def name(self) -> str:
        return self.problem.name

    @property
    def module_name(self) -> str:
        kp = f"_k{self.problems}" if self.problems > 1 else ""
        return f"FgmCore_{self.name}_n{self.n}_p{self.P}_b{self.b}{kp}{module_suffix(self.target)}"

    def products(self) -> list[tuple[int, int]]:
        """(a, b) bit widths of the multipliers (FgmCore): the row dot products, coefficient x operand (w in the
        first pass, y after), and the y update's beta^ and (1 + beta^) x z."""
        w = self.widths
        return [(w["coef"], max(w["x"], w["y"])), (w["beta"], w["z"])]

    def config(self) -> dict:
        """The JSON the Chisel generator reads (fgm.FgmParams.fromJson)."""
        return {
            **self.common_config("fgm"),
            "A": self.A.tolist(), "F": self.F.tolist(),
            "lo": self.lo.tolist(), "hi": self.hi.tolist(),
            "xlo": self.xlo.tolist(), "xhi": self.xhi.tolist(),
            "beta": int(self.beta), "one_plus_beta": int(self.one_plus_beta),
            **({"problems": self.problems} if self.problems > 1 else {}),
            **({"early_exit": True, "exit_tol": int(self.exit_tol)} if self.early_exit else {}),
        }




def design_fgm(problem: MpcProblem, **overrides) -> FgmDesign:
    """Build the FGM core description. Keyword overrides take precedence over the spec's `solver:` section:
    frac_bits, P, lat_add, lat_mul, rounding, iterations, warm_start, output_all, target, c, int_bits, stream_width,
    tol, problems, early_exit, exit_tol (in the units of u; default EXIT_TOL_LSB words)."""
    opt = lambda k, d: solver_opt(problem, overrides, k, d)  # noqa: E731
    b, P, lat_add, lat_mul, rounding, iterations, warm_start, output_all = run_options(
        problem, overrides, frac_bits=16, rounding="truncate", iterations=15)
    extra = [k for k in ("input_rate", "soft_states", "hard_states") if getattr(problem, k, None) is not None]
    if extra:
        raise DesignError(f"the FGM core solves input-constrained MPC only (box on u): the spec also has "
                          f"{', '.join(extra)}; use the ADMM formulation for those")
    target = target_option(problem, overrides)
    qp = condense(problem)
    n, nw = qp.n, qp.nw

    check_run_options(n, "n", b, P, lat_add, lat_mul, rounding, iterations)
    problems = problems_option(problem, overrides)

    H = qp.H
    lam_min_H = float(np.linalg.eigvalsh(H)[0])
    if lam_min_H <= 0:
        raise DesignError(f"H_F is not positive definite: smallest eigenvalue {lam_min_H:.3g} (make cost.R positive definite)")

    # Assumption 1(i) of 002 on the quantised data.
    one = 1 << b
    Hq = quantize(H, b) / one
    lam_max = float(np.linalg.eigvalsh(Hq)[-1])
    c = float(opt("c", 1.0))
    if c < 1:
        raise DesignError(f"c must be >= 1 (Assumption 1 of 002): got c={c}")
    for _ in range(64):
        A = quantize(np.eye(n) - Hq / (c * lam_max), b)
        eig = np.linalg.eigvalsh(np.eye(n) - A / one)
        if eig[-1] <= 1.0:
            break
        c *= 1.0 + 2.0 ** (-b)  # rounding pushed an eigenvalue of H^_n above 1: scale a little more
    if eig[-1] > 1.0:
        raise DesignError(f"Assumption 1(i) of 002 fails: quantised H_n has eigenvalue {eig[-1]:.6g} > 1 for every c tried up to {c:.6g}")
    if eig[0] <= 0:
        raise DesignError(
            f"Assumption 1(i) of 002 fails at frac_bits={b}: quantised H_n has smallest eigenvalue {eig[0]:.3g} <= 0 "
            f"(H_n = H_F / (c lambda_max), lambda_min/lambda_max = {lam_min_H / lam_max:.3g}); increase frac_bits")
    mu = float(eig[0])
    kappa = float(eig[-1] / eig[0])
    beta_real = (1 - math.sqrt(mu)) / (1 + math.sqrt(mu))
    beta = int(math.ceil(beta_real * one))        # rounding up keeps beta^ >= the bound of Assumption 1(ii)
    beta_min = (math.sqrt(kappa) - 1) / (math.sqrt(kappa) + 1)
    if not (beta < one and beta / one >= beta_min):
        raise DesignError(f"Assumption 1(ii) of 002 fails at frac_bits={b}: beta^={beta / one} not in [{beta_min:.6g}, 1)")
    F = quantize(qp.Phi / (c * lam_max), b)

    lo = quantize(qp.lb, b, "ceil")                # K^ inside K
    hi = quantize(qp.ub, b, "floor")
    if np.any(lo > hi):
        raise DesignError(f"input bounds collapse at frac_bits={b}: some min > max after quantisation")
    wmin = np.concatenate([problem.xmin, problem.rmin])
    wmax = np.concatenate([problem.xmax, problem.rmax])
    xlo = quantize(wmin, b, "floor")               # X^_0 contains X_0
    xhi = quantize(wmax, b, "ceil")

    d = FgmDesign(problem=problem, qp=qp, b=b, P=P, lat_add=lat_add, lat_mul=lat_mul, rounding=rounding,
                  iterations=iterations, warm_start=warm_start, target=target, output_all=output_all, c=c, lam_max=lam_max,
                  A=A, F=F, lo=lo, hi=hi, xlo=xlo, xhi=xhi, beta=beta, one_plus_beta=one + beta,
                  tol=None if opt("tol", None) is None else float(opt("tol", None)), problems=problems)
    _size_words(d, opt("int_bits", None), opt("stream_width", None))
    _exit_option(d, opt("early_exit", opt("exit_tol", None) is not None), opt("exit_tol", None))
    apply_target(d, lat_mul, d.products())
    return d


def _exit_option(d: FgmDesign, early_exit, exit_tol) -> None:
    """The exit test's options: `early_exit` builds it (one problem only); `exit_tol` in the units of u becomes
    EXIT_TOL's reset word, floor(exit_tol 2^b), at least one LSB, at most the largest word of z's step."""
    if not isinstance(early_exit, bool):
        raise DesignError(f"early_exit must be true or false: got {early_exit!r}")
    if not early_exit:
        if exit_tol is not None:
            raise DesignError(f"exit_tol needs early_exit: true (the exit test is not built): got exit_tol={exit_tol}")
        return
    if d.problems > 1:
        raise DesignError(f"early_exit needs one problem: interleaved problems share fixed turns (problems="
                          f"{d.problems})")
    d.early_exit = True
    top = (1 << d.widths["z"]) - 1            # EXIT_TOL is zW bits unsigned (the step z+ - z has zW + 1)
    if exit_tol is None:
        d.exit_tol = EXIT_TOL_LSB
        return
    word = math.floor(float(exit_tol) * (1 << d.b))
    if exit_tol != 0 and not 1 <= word <= top:
        raise DesignError(f"exit_tol must be in [2^-{d.b}, {top / (1 << d.b):.6g}] (one LSB to the largest z step "
                          f"word): got exit_tol={exit_tol}")
    d.exit_tol = word


def _size_words(d: FgmDesign, int_bits, stream_width) -> None:
    """Word widths from Prop. 1 of 002, on integer words (one LSB of slack per rounded product)."""
    b, one = d.b, 1 << d.b
    A, F = np.abs(d.A).astype(object), np.abs(d.F).astype(object)
    zbar_r = np.maximum(np.abs(d.lo), np.abs(d.hi)).astype(object)
    xbar_j = np.maximum(np.abs(d.xlo), np.abs(d.xhi)).astype(object)
    # y = rnd((1+beta) z) - rnd(beta z_prev), z and z_prev in the same row's box
    ybar_r = np.array([max(abs(d.one_plus_beta * h - d.beta * l), abs(d.one_plus_beta * l - d.beta * h)) // one + 2
                       for l, h in zip(d.lo.tolist(), d.hi.tolist())], dtype=object)
    ybar_r = np.maximum(ybar_r, zbar_r)
    # every partial sum of a row is bounded by the sum of |a_rj| |v_j| over the row, plus one LSB per product
    s_y = [sum(a * y // one + 1 for a, y in zip(A[r], ybar_r)) for r in range(d.n)]
    s_h = [sum(f * x // one + 1 for f, x in zip(F[r], xbar_j)) for r in range(d.n)]
    bounds = {
        "coef": int(max(np.abs(d.A).max(), np.abs(d.F).max(), 1)),
        "x": int(max(xbar_j)),
        "z": int(max(zbar_r)),
        "y": int(max(ybar_r)),
        "sum": int(max(max(s_y), max(s_h))),
        "t": int(max(sy + sh for sy, sh in zip(s_y, s_h))),
        "beta": int(d.one_plus_beta),
    }
    widths = {k: max(2, bits_for(v)) for k, v in bounds.items()}
    if int_bits is not None:
        req = {k: widths[k] - 1 - b for k in ("y", "sum", "t")}
        forced = int_bits if isinstance(int_bits, dict) else {k: int(int_bits) for k in req}
        for k, ib in forced.items():
            if k not in req:
                raise DesignError(f"int_bits: unknown signal {k!r}; choose from {sorted(req)}")
            if ib < req[k]:
                raise DesignError(
                    f"int_bits={ib} for signal '{k}' is below the {req[k]} integer bits that Prop. 1 of 002 requires "
                    f"(|{k}| <= {bounds[k] / one:.6g}): the word would overflow")
            widths[k] = 1 + int(ib) + b
    prod = widths["coef"] + max(widths["x"], widths["y"])
    if prod > MODEL_PRODUCT_BITS:
        raise DesignError(f"product width {prod} bits exceeds {MODEL_PRODUCT_BITS} (coef {widths['coef']} + operand "
                          f"{max(widths['x'], widths['y'])}): reduce frac_bits or the state box")
    for k in ("coef", "x", "z", "beta"):
        if widths[k] > 32:
            raise DesignError(f"{k} words of {widths[k]} bits do not fit a 32-bit AXI4-Lite word: reduce frac_bits")
    sw = stream_width if stream_width is not None else 8 * -(-max(widths["x"], widths["z"]) // 8)
    if sw % 8 or sw < max(widths["x"], widths["z"]) or sw > 64:
        raise DesignError(f"stream_width must be a multiple of 8 in [{max(widths['x'], widths['z'])}, 64]: got {sw}")
    widths["stream"] = int(sw)
    d.widths = widths
    d.bounds = bounds
    # Prop. 1 of 002 in real units, for the design report
    zmax, zmin = d.hi / one, d.lo / one
    zb = float(np.max(np.maximum(np.abs(zmin), np.abs(zmax))))
    yb = zb + d.beta / one * float(np.max(zmax - zmin))
    xb = float(np.max(np.maximum(np.abs(d.xlo), np.abs(d.xhi)))) / one
    yint = float(np.max(np.sum(np.abs(d.A), axis=1))) / one * yb
    hb = float(np.max(np.sum(np.abs(d.F), axis=1))) / one * xb
    d.prop1 = {"z": zb, "y": yb, "y_inter": yint, "x": xb, "h": hb, "t": yint + hb}


def int_bits_of(d: FgmDesign, signal: str) -> int:
    return d.widths[signal] - 1 - d.b


def roundoff_bound(d: FgmDesign, iters: int) -> np.ndarray:
    """eta_i of eq. (20) of 002 (2-norm, eta_0 = 0) for i = 0..iters, with the nw products of h = Phi_n x added to
    the n products of each row of eps_t (both rounded every solve)."""
    n = d.n
    G = np.eye(n) - d.Hn_hat
    be = d.beta / (1 << d.b)
    Am = np.block([[(1 + be) * G, -be * G], [np.eye(n), np.zeros((n, n))]])
    Bm = np.block([[G, np.eye(n)], [np.zeros((n, n)), np.zeros((n, n))]])
    lsb = 2.0 ** (-d.b)
    vmax = lsb * math.sqrt(n * 1 + n * (n + d.nw) ** 2)
    out = np.zeros(iters + 1)
    acc = 0.0
    M = Bm.copy()                       # A^k B
    for i in range(1, iters + 1):
        acc += np.linalg.norm(M[:n, :], 2)
        out[i] = vmax * acc
        M = Am @ M
    return out
