"""ADMM front end: from an MPC problem with input-rate and soft state constraints to the quantised data and word
widths of the core (Algorithm 2 of 002). Without an input_rate section the QP is the plain sparse form (decision
inputs u_k, w = (x, r), u_0 out; mpc_cores.admm.problem), the same core with other data (config "rate": false).

Penalty. The matching condition z = y (10) is weighted per component: rho_j = rho 2^{s_j}, rho = 2^k, with
s_j = log2(soft_scale) on the soft pairs (x_i, delta_i) (III-C of 002: the slack multipliers nu_delta ~ sigma1
need a larger step to converge; both members of a pair share it so that the projection onto the cone stays
Euclidean), s_j = log2(du_scale) on du (rate-augmented form only: without input_rate the decision inputs u_k
carry R's curvature and take rho; a du_scale set there is refused) and 0 elsewhere. Every multiplication by rho_j
is a shift by k_j = k + s_j.
With D = diag(rho_j) the y-step (12a) is the KKT solve

    [[H_A + D, F'], [F, 0]]^{-1} = [[M11, M12], [M12', M22]],   y = M11 (D z - nu) + G~ (w, 1),

G~ = [M12 b_w - M11 h_w,  -M11 h0] folds h(w) = h_w w + h0 and b(w) = b_w w, so one matrix-vector product per
solve (like h = Phi_n w in the FGM). The 1 is the word 2^b.

Assumption 2 of 002 (checked on the quantised M11): only M11 reaches the core, and its null space range(F')
cannot survive rounding (eigenvalues of order 2^-b of either sign appear there, which act as round-off, not as a
change of problem). With S = D^(1/2) M11^ D^(1/2) and U an orthonormal basis of Ker(F D^(-1/2)):
  (i)  the eigenvalues of U'SU lie in (0, 1): the quantised y-step is the exact y-step of a problem whose reduced
       Hessian is positive definite, i.e. (9) stays convex despite quantisation;
  (ii) the spectral radius of S is < 1: the round-off dynamics (17)/(18) are Schur stable (Lemma 2).
Methods (`method`, the splitting family of 004 on the same datapath; only v and the matrices differ):
  admm      v = D z - nu, M11 from H_A + D (Algorithm 2 of 002, above);
  ama       the alternating minimisation algorithm (Tseng): v = -nu, M11 and G~ from the unaugmented KKT matrix
            [[H_A, F'], [F, 0]] (H_A positive definite on Ker F), the dual step rho_j = 2^k_j below 2 mu,
            mu = lambda_min(Z' H_A Z) with Z a basis of Ker F (default: the largest such power of two, scales 1);
  vucondat  the primal-dual method of Vu and Condat (Chambolle-Pock with L = I) with tau = 1/rho and sigma = rho/2:
            M11 from H_A + D, the datapath's shifts are those of sigma_j = rho_j / 2 (q = y + nu/sigma,
            nu += sigma (y - z)) and v = sigma (y + z) - nu, y the last primal iterate (tau sigma = 1/2 < 1).
Assumption 2 of 002 is that of ADMM's iteration; it is checked for method admm only.
Preconditioning (`precondition: true`, 004): the power-of-two Ruiz equilibration of mpc_cores.admm.precondition
(z = D z~, cost times c). Every method iterates on the scaled QP exactly as on the original one with the steps
rho_j / (c D_j^2), so the design flow folds it into the shifts k_j: the same core, other shifts (AMA: rho_j below
2 mu of the scaled QP, then changed likewise).
Integer bits: IV-C2 of 002 gives no analytic bound for the multipliers, so the dynamic signals are sized from
the largest magnitudes seen by the bit-exact model on random and corner parameters (cold and warm-started
sequences) times a safety factor; the static ones (coefficients, w, G~ w) are bounded analytically.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

from mpc_cores.admm.model import ACC_STATES, ESTIMATED, AdmmFixed, momentum_words, wide_widths
from mpc_cores.admm.precondition import Pow2Scaling, ruiz_pow2, scale_qp
from mpc_cores.admm.problem import BOX, FREE, AdmmQP, build_admm_qp
from mpc_cores.admm.scaling import FREE_DROP, cost_scale, scaled
from mpc_cores.design_base import (FixedPointDesign, apply_target, check_run_options, module_suffix,
                                   problems_option, run_options, solver_opt, target_option)
from mpc_cores.errors import MODEL_PRODUCT_BITS, DesignError
from mpc_cores.fixed import bits_for, quantize
from mpc_cores.problem import MpcProblem
from mpc_cores.schema import PART, PART_MULTS
from mpc_cores.target import dsp_count

# Defaults of the example (tuned on masses_rate_soft, closed loop, warm start, Imax = 40).
RHO_DEFAULT = 2.0
METHODS = ("admm", "ama", "vucondat")
SOFT_SCALE_DEFAULT = 16.0
DU_SCALE_DEFAULT = 4.0
SAFETY_DEFAULT = 2.0          # estimated bounds x 2, i.e. one extra integer bit
# signals sized from simulation (IV-C2 of 002) and those with an analytic bound

ANALYTIC = ("coef", "w", "gsum")


@dataclass
class AdmmDesign(FixedPointDesign):
    """qp: the AdmmQP (sparse form (8) of 002)."""
    rho_log2: int
    shift: np.ndarray          # k_j: rho_j = 2^k_j (n,)
    M11f: np.ndarray           # unquantised M11 (n x n)
    Gf: np.ndarray             # unquantised G~ (n x (nw + 1))
    M11: np.ndarray            # words
    G: np.ndarray              # words, last column multiplies the constant word 2^b
    kind: np.ndarray
    lo: np.ndarray             # box words (BOX components, 0 elsewhere), inside the real bounds
    hi: np.ndarray
    soft_c: np.ndarray         # centre and radius words per soft pair (radius shrunk: K^ inside K)
    soft_r: np.ndarray
    wlo: np.ndarray            # accepted w words, containing the real box
    whi: np.ndarray
    safety: float
    output_all: bool = False   # stream all of z (else du_0)
    assumption2: dict = field(default_factory=dict)
    widths: dict = field(default_factory=dict)
    bounds: dict = field(default_factory=dict)      # integer-word bounds per signal
    observed: dict = field(default_factory=dict)    # largest words seen in the sizing runs
    estimated: tuple = ESTIMATED
    problems: int = 1          # K_p, problems interleaved on the row units (mpc_cores.interleave)
    method: str = "admm"       # admm, ama or vucondat (the splitting family of 004)
    mu: float | None = None    # ama: lambda_min of H_A on Ker F (the dual step bound 2 mu), of the scaled QP if any
    scaling: Pow2Scaling | None = None   # the power-of-two preconditioner folded into the steps (precondition)
    accelerated: bool = False  # ama: fast AMA with the gradient restart (mpc_cores.admm.model.AdmmFixed)
    chunks: int = 1            # a row's dot product in `chunks` cycles on lanes = ceil(m / chunks) multipliers
    cost_log2: int = 0         # the cost scaled by 2^-cost_log2 in the data (mpc_cores.admm.scaling)

    @property
    def m(self) -> int:
        """columns of a row: the G~ (w, 1) pass shares the multipliers"""
        return max(self.n, self.nw + 1)

    @property
    def lanes(self) -> int:
        """multipliers of the row unit's dot product"""
        return -(-self.m // self.chunks)

    def label(self) -> str:
        """the design in a table row (make demo)"""
        return f"{'' if self.method == 'admm' else self.method + ', '}b = {self.b}, Imax = {self.iterations}"

    @property
    def N(self) -> int:
        return self.qp.N

    @property
    def rho(self) -> float:
        return 2.0 ** self.rho_log2

    @property
    def rate(self) -> bool:
        """the rate-augmented form: w = (x, u_prev, r), du_0 out; else w = (x, r), u_0 out"""
        return self.qp.rate

    @property
    def rho_vec(self) -> np.ndarray:
        return np.ldexp(1.0, self.shift)

    @property
    def name(self) -> str:
        return self.problem.name

    @property
    def module_name(self) -> str:
        kp = f"_k{self.problems}" if self.problems > 1 else ""
        m = "" if self.method == "admm" else f"_{self.method}"
        c = f"_c{self.chunks}" if self.chunks > 1 else ""
        return f"AdmmCore_{self.name}_n{self.n}_p{self.P}_b{self.b}{kp}{c}{m}{module_suffix(self.target)}"

    def products(self) -> list[tuple[int, int]]:
        """(a, b) bit widths of the multipliers (AdmmCore): the row dot products, coefficient x operand; accelerated:
        the momentum lanes' (mom x (x - prev), and d x (nu - prev) or the squares of x - x^)."""
        w = self.widths
        out = [(w["coef"], max(w["v"], w["w"]))]
        if self.accelerated:
            cur = {"y": max(w["y"], w["z"]), "z": w["z"], "nu": w["nu"]}
            for k in ACC_STATES[self.method]:
                out.append((self.b + 2, cur[k] + 1))
                out.append((w["d"], cur[k] + 1) if self.method == "ama" else (cur[k] + 1, cur[k] + 1))
        return out

    # ---- cycle contract and resources of 002
    @property
    def cycles_per_iteration(self) -> int:
        """L_A of eq. (24) (accelerated: plus the momentum lanes' 1 + l_M); chunks > 1: n_A rows of `chunks` cycles,
        a tree of `lanes` inputs and the two cycles of the chunks' accumulation."""
        mom = 1 + self.lat_mul if self.accelerated else 0
        if self.chunks > 1:
            d = math.ceil(math.log2(self.lanes)) if self.lanes > 1 else 0
            return self.n * self.chunks + self.lat_add * d + self.lat_mul + 6 * self.lat_add + 4 + mom
        d = math.ceil(math.log2(self.n)) if self.n > 1 else 0
        return -(-self.n // self.P) + self.lat_add * d + self.lat_mul + 6 * self.lat_add + 2 + mom

    @property
    def multipliers(self) -> int:
        """Table I of 002: P n_A (the rho shifts need none; chunks > 1: the lanes); accelerated: per momentum lane
        (one per unit, two with soft pairs) two per extrapolated state (AMA: two)."""
        per_lane = 2 * len(ACC_STATES[self.method])
        return (self.P * self.n if self.chunks == 1 else self.lanes) + (per_lane * self.P * (2 if self.qp.ns else 1) if self.accelerated else 0)

    def config(self) -> dict:
        """What an ADMM core generator needs, analogous to FgmDesign.config()."""
        q = self.qp
        return {
            **self.common_config("admm"),
            "nx": q.nx, "ns": q.ns, "N": self.N,
            "rho_log2": self.rho_log2,
            "shift": self.shift.tolist(),
            "M11": self.M11.tolist(), "G": self.G.tolist(),
            "kind": self.kind.tolist(),
            "lo": self.lo.tolist(), "hi": self.hi.tolist(),
            "soft_x": q.soft_x.tolist(), "soft_d": q.soft_d.tolist(),
            "soft_c": self.soft_c.tolist(), "soft_r": self.soft_r.tolist(),
            "wlo": self.wlo.tolist(), "whi": self.whi.tolist(),
            "safety": self.safety, "estimated": list(self.estimated), "method": self.method,
            **({"accelerated": True, "momentum": momentum_words(self.b).tolist()} if self.accelerated else {}),
            **({"problems": self.problems} if self.problems > 1 else {}),
            **({"chunks": self.chunks} if self.chunks > 1 else {}),
            # absent: the rate-augmented form (so that its configurations, and the cores built from them, stay as
            # they were)
            **({} if self.rate else {"rate": False}),
        }




def _pow2_exponent(v, what: str) -> int:
    v = float(v)
    if not (v > 0 and math.isfinite(v)) or math.frexp(v)[0] != 0.5:
        raise DesignError(f"{what} must be a power of two (2^k, k may be negative) so that it is a shift: got {v:g}")
    return math.frexp(v)[1] - 1


def kkt_blocks(qp: AdmmQP, rho_vec: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(M11, G~) from the offline inverse of the KKT matrix of (12a)."""
    n, neq = qp.n, qp.F.shape[0]
    K = np.block([[qp.H + np.diag(rho_vec), qp.F.T], [qp.F, np.zeros((neq, neq))]])
    Minv = np.linalg.inv(K)
    M11 = 0.5 * (Minv[:n, :n] + Minv[:n, :n].T)
    M12 = Minv[:n, n:]
    G = np.hstack([M12 @ qp.b_w - M11 @ qp.h_w, -(M11 @ qp.h0)[:, None]])
    return M11, G


def check_assumption2(qp: AdmmQP, M11_hat: np.ndarray, rho_vec: np.ndarray) -> dict:
    sq = np.sqrt(rho_vec)
    S = sq[:, None] * M11_hat * sq[None, :]
    S = 0.5 * (S + S.T)
    U = scipy.linalg.null_space(qp.F / sq[None, :])
    ev_k = np.linalg.eigvalsh(U.T @ S @ U)
    ev = np.linalg.eigvalsh(S)
    return {"kernel_min": float(ev_k[0]), "kernel_max": float(ev_k[-1]),
            "spectral_radius": float(max(abs(ev[0]), abs(ev[-1]))),
            "ok_i": bool(ev_k[0] > 0 and ev_k[-1] < 1), "ok_ii": bool(max(abs(ev[0]), abs(ev[-1])) < 1)}


def design_admm(problem: MpcProblem, **overrides) -> AdmmDesign:
    """Build the ADMM core description. Keyword overrides take precedence over the spec's `solver:` section:
    frac_bits, P, lat_add, lat_mul, rounding, iterations, warm_start, rho, soft_scale, du_scale, safety,
    sizing_solves (random parameters per sizing run), sizing_seed, problems, method, precondition, accelerated."""
    opt = lambda k, d: solver_opt(problem, overrides, k, d)  # noqa: E731
    # nearest by default: truncating each of the n_A products of a row biases every y by about -n_A/2 LSB per
    # iteration and the multiplier update integrates it (measured in tests/test_admm_model.py)
    b, P, lat_add, lat_mul, rounding, iterations, warm_start, output_all = run_options(
        problem, overrides, frac_bits=18, rounding="nearest", iterations=40)
    safety = float(opt("safety", SAFETY_DEFAULT))
    target = target_option(problem, overrides)
    qp = build_admm_qp(problem)
    n = qp.n
    if not qp.rate and (overrides.get("du_scale") is not None or problem.solver.get("du_scale") is not None):
        raise DesignError("du_scale: the spec has no input_rate section, so there is no du to scale (remove du_scale)")

    check_run_options(n, "n_A", b, P, lat_add, lat_mul, rounding, iterations)
    if not safety >= 1:
        raise DesignError(f"safety must be >= 1 (it multiplies the largest simulated magnitudes): got {safety}")
    if qp.ns and not qp.sigma2 > 0:
        raise DesignError("soft_states.sigma2 must be > 0 (Remark 1 of 002)")

    method = str(opt("method", "admm"))
    if method not in METHODS:
        raise DesignError(f"method must be one of {', '.join(METHODS)}: got {method!r}")
    accelerated = bool(opt("accelerated", False))
    if accelerated and problems_option(problem, overrides) > 1:
        raise DesignError("accelerated needs problems = 1 (its momentum state is kept for one problem)")

    def opt_m(key, default):
        """a penalty option: the override, else the spec's when the spec is written for this method, else the
        method's default (a spec's rho for ADMM does not carry over to AMA)"""
        if overrides.get(key) is not None:
            return overrides[key]
        return problem.solver.get(key, default) if problem.solver.get("method", "admm") == method else default
    # the power-of-two Ruiz preconditioner: a change of the steps to rho_j / (c D_j^2) (mpc_cores.admm.precondition);
    # AMA's step bound mu is then that of the scaled QP, in whose metric rho_j is chosen
    scaling = ruiz_pow2(qp) if bool(opt("precondition", False)) else None
    qs = qp if scaling is None else scale_qp(qp, scaling)
    mu = None
    if method == "ama":
        Z = scipy.linalg.null_space(qs.F)
        mu = float(np.linalg.eigvalsh(Z.T @ qs.H @ Z)[0]) if Z.size else float(np.linalg.eigvalsh(qs.H)[0])
        if not mu > 1e-9:
            raise DesignError(f"method ama needs H_A positive definite on Ker F (the unaugmented step): its smallest "
                              f"eigenvalue there is {mu:.3g}; use method admm or vucondat")
        # the step bound: 2 mu for AMA (Tseng), mu for fast AMA (a gradient method on the dual, whose gradient is
        # 1/mu-Lipschitz: Nesterov's momentum needs the step 1/L; measured, steps in [mu, 2 mu) diverge)
        bound = mu if accelerated else 2 * mu
        kdef = math.floor(math.log2(bound)) - (1 if 2.0 ** math.floor(math.log2(bound)) >= bound else 0)
        k = _pow2_exponent(opt_m("rho", 2.0 ** kdef), "rho")
        s_soft = _pow2_exponent(opt_m("soft_scale", 1.0), "soft_scale")
        s_du = _pow2_exponent(opt_m("du_scale", 1.0), "du_scale") if qp.rate else 0
    else:
        k = _pow2_exponent(opt("rho", RHO_DEFAULT), "rho")
        s_soft = _pow2_exponent(opt("soft_scale", SOFT_SCALE_DEFAULT), "soft_scale")
        s_du = _pow2_exponent(opt("du_scale", DU_SCALE_DEFAULT), "du_scale") if qp.rate else 0
    shift = np.full(n, k, dtype=np.int64)
    shift[qp.soft_x] += s_soft
    shift[qp.soft_d] += s_soft
    shift[: qp.N * qp.nu] += s_du
    # plants whose multipliers dwarf rho: the cost scaled by 2^-s in the data, the free components' penalty lowered
    # (mpc_cores.admm.scaling)
    cost_log2 = cost_scale(qp, 2.0 ** k) if method != "ama" and scaling is None else 0
    if cost_log2:
        qp = scaled(qp, cost_log2)
        shift[qp.kind == FREE] -= FREE_DROP
    rho_vec = np.ldexp(1.0, shift)
    if method == "ama" and not rho_vec.max() < bound:
        what = "mu" if accelerated else "2 mu"
        raise DesignError(f"method ama{' accelerated' if accelerated else ''} needs every rho_j < {what} = {bound:.6g} "
                          f"(mu = lambda_min of H_A on Ker F): got max rho_j = {rho_vec.max():g}; lower rho, "
                          f"soft_scale{' or du_scale' if qp.rate else ''}")
    if scaling is not None:
        shift = shift - scaling.c - 2 * scaling.d
        rho_vec = np.ldexp(1.0, shift)
    if method == "vucondat":
        shift = shift - 1                  # the datapath's shifts: sigma_j = rho_j / 2
    if shift.min() < -b:
        raise DesignError(f"rho_j = 2^{int(shift.min())} is not representable with frac_bits={b} "
                          f"(Assumption 2 of 002 wants rho exact in b bits): increase rho or frac_bits")

    M11f, Gf = kkt_blocks(qp, np.zeros(n) if method == "ama" else rho_vec)
    M11 = quantize(M11f, b)
    G = quantize(Gf, b)
    a2 = check_assumption2(qp, M11 / float(1 << b), rho_vec) if method == "admm" else {}
    if a2 and not a2["ok_i"]:
        raise DesignError(
            f"Assumption 2(i) of 002 fails at frac_bits={b}, rho=2^{k}: D^(1/2) M11^ D^(1/2) on Ker F has eigenvalues "
            f"in [{a2['kernel_min']:.6g}, {a2['kernel_max']:.6g}], not inside (0, 1) (the quantised problem is no longer "
            f"convex); increase frac_bits or choose another rho")
    if a2 and not a2["ok_ii"]:
        raise DesignError(
            f"Assumption 2(ii) of 002 fails at frac_bits={b}, rho=2^{k}: ||D^(1/2) M11^ D^(1/2)|| = {a2['spectral_radius']:.6g} >= 1 "
            f"(the round-off dynamics (18) are not Schur stable); increase frac_bits or choose another rho")

    box = qp.kind == BOX
    lo = np.where(box, quantize(np.where(box, qp.lo, 0.0), b, "ceil"), 0)      # K^ inside K
    hi = np.where(box, quantize(np.where(box, qp.hi, 0.0), b, "floor"), 0)
    if np.any(lo > hi):
        raise DesignError(f"box bounds collapse at frac_bits={b}: some min > max after quantisation")
    soft_c = quantize(qp.soft_c, b)
    soft_r = quantize(qp.soft_r - np.abs(soft_c / float(1 << b) - qp.soft_c), b, "floor")
    if np.any(soft_r <= 0):
        raise DesignError(f"a soft-constraint radius vanishes at frac_bits={b}")
    wlo = quantize(qp.wlo, b, "floor")
    whi = quantize(qp.whi, b, "ceil")

    d = AdmmDesign(problem=problem, qp=qp, b=b, P=P, lat_add=lat_add, lat_mul=lat_mul, rounding=rounding,
                   iterations=iterations, warm_start=warm_start, target=target, rho_log2=k, shift=shift, M11f=M11f, Gf=Gf,
                   M11=M11, G=G, kind=qp.kind.copy(), lo=lo, hi=hi, soft_c=soft_c, soft_r=soft_r, wlo=wlo, whi=whi,
                   safety=safety, output_all=output_all, assumption2=a2, problems=problems_option(problem, overrides),
                   method=method, mu=mu, scaling=scaling, accelerated=accelerated, cost_log2=cost_log2)
    _size_words(d, int(opt("sizing_solves", 48)), int(opt("sizing_seed", 0)))
    d.chunks = _chunks(d, opt("lanes", None))
    apply_target(d, lat_mul, d.products())
    return d


def _chunks(d: AdmmDesign, lanes) -> int:
    """Chunks per row for the `lanes` option: None, one row per cycle (the papers' P n_A multipliers); an integer,
    the fewest chunks (a power of two) whose lanes are at most that; "fit", the fewest whose products fit the
    LFE5U-85F's MULT18X18D (the ECP5 count of mpc_cores.target, whatever the target)."""
    if lanes is None:
        return 1
    if d.P != 1 or d.problems != 1:
        raise DesignError(f"lanes: a row unit with fewer multipliers than columns needs P = 1 and problems = 1 "
                          f"(got P = {d.P}, problems = {d.problems})")
    top = 1 << max(0, (d.m - 1).bit_length())          # the chunks at which a lane is one column
    for c in (1 << i for i in range(top.bit_length())):
        d.chunks = c
        if (lanes == "fit" and dsp_count("ecp5", d.products(), product_counts(d)) <= PART_MULTS
                or lanes != "fit" and d.lanes <= int(lanes)):
            return c
    d.chunks = 1
    raise DesignError(f"lanes={lanes}: no chunking of the rows' {d.m} columns fits "
                      + (f"the {PART}'s {PART_MULTS} MULT18X18D" if lanes == "fit" else "that many multipliers"))


def product_counts(d: AdmmDesign) -> list[int]:
    """how many multipliers of each width pair of d.products() the core has (mpc_cores.admm.report.facts)"""
    n = len(d.products())
    return [d.multipliers] if n == 1 else [d.multipliers - 2 * (n - 1)] + [2] * (n - 1)


def sizing_parameters(d: AdmmDesign, rng: np.random.Generator, count: int) -> np.ndarray:
    """Parameter words for sizing and tests: half uniform in the accepted box, half at random corners of it."""
    u = rng.integers(d.wlo, d.whi + 1, size=(count - count // 2, d.nw))
    c = np.where(rng.integers(0, 2, size=(count // 2, d.nw)) == 1, d.whi, d.wlo)
    return np.vstack([u, c]).astype(np.int64)


def _size_words(d: AdmmDesign, solves: int, seed: int) -> None:
    """Widths: analytic for the static data, simulated (largest magnitude x safety) for the iterates (IV-C2)."""

    one = 1 << d.b
    G = np.abs(d.G).astype(object)
    w1 = [max(abs(int(a)), abs(int(c))) for a, c in zip(d.wlo, d.whi)] + [one]
    gsum = max(sum(g * x // one + 1 for g, x in zip(row, w1)) for row in G)
    bounds = {
        "coef": int(max(np.abs(d.M11).max(), np.abs(d.G).max(), 1)),
        "w": int(max(w1)),
        "gsum": int(gsum),
    }
    # bit-exact runs with wide words: cold solves, then warm-started sequences of random / corner parameters
    model = AdmmFixed(d.config() | {"widths": wide_widths()})
    rng = np.random.default_rng(seed)
    seen = dict.fromkeys(ESTIMATED, 0)
    runs = [(sizing_parameters(d, rng, solves), False)] + [(sizing_parameters(d, rng, solves), True) for _ in range(4)]
    state = None
    for W, warm in runs:
        res = model.solve_batch(W, warm_from=state if warm else None, track=True)
        state = (res.z, res.nu) + ((res.y,) if res.y is not None else ())
        for key in ESTIMATED:
            seen[key] = max(seen[key], int(res.peaks[key]))
    box = d.kind == BOX
    seen["z"] = max(seen["z"], int(np.abs(d.lo[box]).max(initial=0)), int(np.abs(d.hi[box]).max(initial=0)))
    for key in ESTIMATED:
        bounds[key] = int(math.ceil(d.safety * max(seen[key], 1)))
    bounds["sum"] = max(bounds["msum"], bounds["gsum"])          # one dot-product unit for M11 v and G~ w1
    widths = {key: max(2, bits_for(v)) for key, v in bounds.items()}
    prod = widths["coef"] + max(widths["v"], widths["w"])
    if prod > MODEL_PRODUCT_BITS:
        raise DesignError(f"product width {prod} bits exceeds {MODEL_PRODUCT_BITS} (coef {widths['coef']} + operand "
                          f"{max(widths['v'], widths['w'])}): reduce frac_bits")
    for key in ("coef", "w"):
        if widths[key] > 32:
            raise DesignError(f"{key} words of {widths[key]} bits do not fit a 32-bit AXI4-Lite word: reduce frac_bits")
    widths["stream"] = 8 * -(-max(widths["w"], widths["z"]) // 8)
    d.widths = widths
    d.bounds = bounds
    d.observed = seen


def design_ama(problem: MpcProblem, **overrides) -> AdmmDesign:
    """`CORE=ama`: the ADMM core's datapath running the alternating minimisation algorithm."""
    return design_admm(problem, **{**overrides, "method": "ama"})


def design_vucondat(problem: MpcProblem, **overrides) -> AdmmDesign:
    """`CORE=vucondat`: the ADMM core's datapath running the primal-dual method of Vu and Condat."""
    return design_admm(problem, **{**overrides, "method": "vucondat"})
