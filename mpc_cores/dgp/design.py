"""DGP front end: from an MPC problem with state constraints to the quantised data and word widths of the core.

The dual box (14)-(15) of 003: d_i >= max(y*_i, 1) with y* the dual solutions over the accepted box of w = (x, r),
found by solving the QP (OSQP; where it stops short, an LP decides feasibility and the dual active-set method
solves a feasible QP: mpc_cores.dgp.problem.solve_qp) at every vertex of that box (4096 of them at most, else 4096
random vertices) and at random interior points, times a margin (`dual_margin`, 2 by default); the projection box
is [0, alpha d] with alpha = 2, the choice of (22). This is sampled, not the certified bound of Remark 1 of 003: y*
is piecewise affine in w and may peak inside the box.

Fraction bits p from (36) and integer bits r from (37), on the scaled problem (L = 1, mpc_cores.dgp.problem):
  p >= log2( m sqrt(n) / ( sqrt(eps / L_V + (n / m) (2 D / L_V)^2) - sqrt(n / m) 2 D / L_V ) ) - 1,
       eps = min(eps_g sigma, eps_V), m = 2 mc one-sided rows, D = ||d||_2, L_V = lambda_max(Q);
  r >= log2(max(y^, z^, g^) + 1) + 1,  y^ = alpha ||d||_inf, z^ = max_i z^_i, g^ = max_i (sum_j |G_ij| dz^_j + b^_i),
       dz^_i = sum_j |K_ij| alpha max(d+_j, d-_j) (|z_i - e_i|: the iteration takes s = G (z - e) against the bounds
       relative to G e, bound_rows), z^_i = dz^_i + e^_i, e^ and b^ the largest |e(w)| and |bounds(w)| over the box:
       (37) taken row by row (its z^ = ||E||_inf y^ + ||e||_inf and g^ = ||A||_inf z^ + ||b||_inf bound the same
       words, less tightly: they pair the largest dual with the longest row, and count y+ and y- both).
Every data word (y, v, z, s, g and the bounds) has r + p bits, as in section VI of 003. The accelerated form's
extrapolated dual is clipped to the same box [0, alpha d], so (37) holds for it unchanged; (36) is applied as it
stands (the accelerated form's round-off is checked by simulation, docs/dgp.md).

Warm start: the plain form's guarantee on V (Corollary 1 of 003) needs y(0) = 0, so its default is cold; the
accelerated form's gap test bounds V(z) - V* from any start, so its default is warm.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from mpc_cores.design_base import (FixedPointDesign, apply_target, module_suffix, run_options, solver_opt,
                                   target_option)
from mpc_cores.dgp.problem import DgpQP, dgp_qp, solve_qp
from mpc_cores.errors import DesignError
from mpc_cores.fixed import bits_for, quantize
from mpc_cores.problem import MpcProblem
from mpc_cores.schema import PART, PART_BLOCKS, PART_MULTS
from mpc_cores.target import dp16kd, dsp_count, min_lat_mul

ALPHA = 2.0
BETA_TABLE = 256          # accelerated form: beta_k = k / (k + 3) for k < 256, then beta_255
DEFAULT_EPS = 1e-3


@dataclass
class DgpDesign(FixedPointDesign):
    """qp: the DgpQP. Words: b = p fraction bits; widths['data'] = r + p."""
    output_all: bool
    accelerated: bool
    lanes: int                   # multipliers of each row unit (a row of c columns: at most ceil(c / lanes) cycles)
    eps_g: float
    eps_V: float
    margin: float
    d: np.ndarray                # dual box (2 mc,), scaled units: (upper rows, lower rows)
    K: np.ndarray                # words, n x mc
    G: np.ndarray                # words, mc x n
    Fe: np.ndarray               # words, n x nw
    Lb: np.ndarray               # words, mc x nw: the bound rows Lw - G Fe (bound_rows)
    lo0: np.ndarray              # words, mc
    hi0: np.ndarray
    ud: np.ndarray               # words, 2 mc: alpha d
    eg: int                      # eps_g word (scaled units)
    eV: int                      # eps_V word (the accelerated form's duality-gap test)
    beta: np.ndarray             # words, BETA_TABLE (accelerated form)
    xlo: np.ndarray              # accepted box of w words
    xhi: np.ndarray
    out_lo: np.ndarray = None    # words, n: the quantised input box the output words are clamped to (z's format)
    out_hi: np.ndarray = None
    warm_shift: bool = False     # a warm start takes the previous dual shifted a stage (shift_sources)
    ram_state: bool = False      # the dual and the bounds in block RAM (DgpParams.ramState; accelerated form)
    bits36: int = 0              # p from (36)
    bits37: int = 0              # r from (37)
    analysis: dict = field(default_factory=dict)
    widths: dict = field(default_factory=dict)

    @property
    def mc(self) -> int:
        return self.qp.mc

    @property
    def m(self) -> int:
        return 2 * self.qp.mc

    @property
    def name(self) -> str:
        return self.problem.name

    @property
    def module_name(self) -> str:
        acc = ("a" if self.accelerated else "p") + ("s" if self.warm_shift else "") + ("r" if self.ram_state else "")
        units = f"u{self.P}" if self.P > 1 else ""
        return (f"DgpCore_{self.name}_n{self.n}_m{self.m}_l{self.lanes}{units}_b{self.b}{acc}"
                f"{module_suffix(self.target)}")

    def label(self) -> str:
        return (f"p = {self.b}, Imax = {self.iterations}, {'accelerated' if self.accelerated else 'plain'}"
                + (", shifted warm start" if self.warm_shift else "") + (", dual in block RAM" if self.ram_state else ""))

    # ---- cycle contract (mirrors DgpParams.scala; the tests check both against simulation)
    @property
    def chunks(self) -> dict:
        c = self.lanes
        return {"F": -(-self.nw // c), "K": -(-self.mc // c), "G": -(-self.n // c)}

    @property
    def rounds(self) -> dict:
        """rows per row unit: pass K (and Fe), pass G (and Lb); unit u takes the rows u, u + P, ..."""
        return {"K": -(-self.n // self.P), "G": -(-self.mc // self.P)}

    def schedule(self, M: np.ndarray) -> list[list[int]]:
        """The chunks each round of a pass over the rows of M issues (DgpParams.schedule): those in which one of
        the round's rows (rows r P .. r P + P - 1, one per unit) has a nonzero coefficient, ascending; a round with
        none issues chunk 0. The chunks left out are zero in every unit's row, so the sums are the dense ones."""
        M = np.asarray(M)
        rounds = -(-M.shape[0] // self.P)
        out = []
        for r in range(rounds):
            cols = np.nonzero(M[r * self.P:(r + 1) * self.P].any(axis=0))[0]
            out.append(sorted({int(c) // self.lanes for c in cols}) or [0])
        return out

    @property
    def issue_cycles(self) -> dict:
        """per pass: the chunks its rounds issue (first pass: the rows of Fe, then those of Lb)"""
        def count(M):
            return sum(len(cs) for cs in self.schedule(M))
        return {"F": count(self.Fe) + count(self.Lb), "K": count(self.K), "G": count(self.G)}

    @property
    def dense_issue_cycles(self) -> dict:
        """issue_cycles without the chunk schedule: every round takes every chunk of its rows"""
        ch, r = self.chunks, self.rounds
        return {"F": (r["K"] + r["G"]) * ch["F"], "K": r["K"] * ch["K"], "G": r["G"] * ch["G"]}

    @property
    def row_latency(self) -> int:
        """issue to the row's sum: the chunk's copies at the lanes (1), the lanes' words and their pass select (2),
        the operand's copies at the units (1; the memory's read runs beside), the tree, the accumulator (1)"""
        depth = math.ceil(math.log2(self.lanes)) if self.lanes > 1 else 0
        return 4 + self.lat_mul + self.lat_add * depth + 1

    @property
    def element_lat_mul(self) -> int:
        """stages of the accelerated element stage's products (DgpParams.latMulE): l_M, and where the target sums
        partial products, at least 2 beyond its DSP pipeline (the DSP outputs land in fabric registers)"""
        w = self.widths
        need = min_lat_mul(self.target, [(w["data"], w["data"]), (w["beta"], w["data"])])
        return max(self.lat_mul, need + 2) if need >= 4 else self.lat_mul

    @property
    def element_latency(self) -> int:
        """from a row of pass G's sum to the test's sums that count it: plain 5; accelerated 8 + element_lat_mul
        (DgpParams)"""
        return 8 + self.element_lat_mul if self.accelerated else 5

    @property
    def gap_cycles(self) -> dict:
        """after pass K: the row latency; after pass G: the row latency, the element stage and the sums over the
        units (ceil(log2 P) registered levels)"""
        units = math.ceil(math.log2(self.P)) if self.P > 1 else 0
        return {"K": self.row_latency, "G": self.row_latency + self.element_latency + units}

    @property
    def cycles_per_iteration(self) -> int:
        i, g = self.issue_cycles, self.gap_cycles
        return i["K"] + g["K"] + i["G"] + g["G"] + 1

    @property
    def zero_start_gap(self) -> int:
        """cycles from the first pass's last issue to the decision on a zero start (DgpParams.gapZ): its bound rows
        feed the element stage (s = 0) a stage after their sums, so pass G's gap and a cycle"""
        return self.gap_cycles["G"] + 1

    @property
    def zero_start_saving(self) -> int:
        """cycles a zero start (the starting dual all zero: every cold start) saves: its first iteration (z = e,
        s = G (z - e) = 0) runs the element stage on the first pass's bound rows, so passes K and G, their gaps and
        the decision are replaced by the zero start's gap and the decision"""
        return self.cycles_per_iteration - self.zero_start_gap - 1

    @property
    def div_cycles(self) -> int:
        return 0 if self.accelerated else self.widths["sum"] + 4

    @property
    def solve_overhead(self) -> int:
        """the frame's take (3), the first pass's issue, the plain form's first division; accelerated, the answer's
        flag and its output queue (2) (DgpParams.solveOverhead)"""
        return 3 + self.issue_cycles["F"] + self.div_cycles + (2 if self.accelerated else 0)

    def cycles_to_output(self, iters, zero_start=False):
        """from the handshake of the last input word to the first output word, for a solve of `iters` iterations
        (arrays broadcast); zero_start: its starting dual was all zero (DgpResult.zero_start), which skips the first
        pass K"""
        c = (self.solve_overhead + np.asarray(iters, dtype=np.int64) * self.cycles_per_iteration
             - np.asarray(zero_start, dtype=np.int64) * self.zero_start_saving)
        return int(c) if c.ndim == 0 else c

    @property
    def multipliers(self) -> int:
        return self.P * (self.lanes + (6 if self.accelerated else 0))

    def memories(self) -> list[tuple]:
        """(words, lanes, bits per lane, built from primitives): per row unit its matrix memory, its rows of Fe,
        Lb, K and G chunk by chunk (DgpCore; inferred by synthesis); with ram_state also, per unit, the memories of
        y, of the extrapolated dual's candidate and of the bounds (a row per element of the unit, two data words)"""
        mat = [(self.issue_cycles["F"] + self.issue_cycles["K"] + self.issue_cycles["G"], self.lanes,
                self.widths["coef"], False)] * self.P
        state = [(self.rounds["G"], 2, self.widths["data"], self.target == "ecp5")] * (3 * self.P)
        return mat + (state if self.ram_state else [])

    def products(self) -> list[tuple[int, int]]:
        """(a, b) bit widths of the multipliers: the row unit (coefficient x operand word), and the accelerated
        form's beta_k x (y - y_prev)."""
        w = self.widths
        out = [(w["coef"], w["op"])]
        if self.accelerated:
            out += [(w["data"], w["data"]), (w["beta"], w["data"])]
        return out

    def config(self) -> dict:
        """The JSON the Chisel generator and the golden model read."""
        return {
            **self.common_config("dgp"),
            "mc": self.mc, "lanes": self.lanes, "accelerated": self.accelerated,
            "K": self.K.tolist(), "G": self.G.tolist(), "Fe": self.Fe.tolist(), "Lb": self.Lb.tolist(),
            "lo0": self.lo0.tolist(), "hi0": self.hi0.tolist(), "ud": self.ud.tolist(), "eg": int(self.eg), "eV": int(self.eV),
            "beta": self.beta.tolist(), "xlo": self.xlo.tolist(), "xhi": self.xhi.tolist(),
            "restart_shift": restart_shifts(self.widths),
            "out_lo": self.out_lo.tolist(), "out_hi": self.out_hi.tolist(),
            "shift_src": shift_sources(self.qp, self.problem).tolist() if self.warm_shift else [],
            **({"ram_state": True} if self.ram_state else {}),
        }


def _stage_blocks(qp: DgpQP, p: MpcProblem) -> list[tuple[int, int, int]]:
    """The rows stage by stage (dgp_qp): (first row, end, rows per stage) of the input box and of the state box."""
    blocks = [(0, qp.n_input_rows, qp.nu)]
    if qp.mc > qp.n_input_rows:
        blocks.append((qp.n_input_rows, qp.mc, (qp.mc - qp.n_input_rows) // p.N))
    return blocks


def stage_envelope(d: np.ndarray, qp: DgpQP, p: MpcProblem) -> np.ndarray:
    """The dual box of the shifted warm start: each row's d raised to the largest of the same row at its later
    stages, so that d does not grow from a row to its shift source's (shift_sources: the row a stage later), and the
    shifted start of a dual in the box lies in the box without a clip."""
    out = np.array(d, dtype=float)
    for h in (0, qp.mc):
        for lo, hi, per in _stage_blocks(qp, p):
            v = out[h + lo:h + hi].reshape(-1, per)
            out[h + lo:h + hi] = np.maximum.accumulate(v[::-1], axis=0)[::-1].ravel()
    return out


def shift_sources(qp: DgpQP, p: MpcProblem) -> np.ndarray:
    """The shifted warm start: for each dual word (upper rows, then lower rows), the word of the previous solve's
    final dual it starts from, or -1 for zero. The rows are stage by stage (the input box at stages 0..N-1, then the
    state box at stages 1..N, dgp_qp), and the next solve's stage k is the previous one's stage k + 1, so a row takes
    the same row a stage later; the last stage's rows start from zero. The model clips each word to its own dual box
    (min(y_src, ud)), so that the start lies in the box from which the gap test bounds V(z) - V*; with the design's
    stage_envelope no word exceeds it, and the core loads the source words as they are."""
    src = np.full(qp.mc, -1, dtype=np.int64)
    for lo, hi, per in _stage_blocks(qp, p):
        src[lo:hi - per] = np.arange(lo + per, hi)
    return np.concatenate([src, np.where(src >= 0, src + qp.mc, -1)])


def bound_rows(qp: DgpQP) -> np.ndarray:
    """Lb = Lw - G Fe (mc x nw, scaled): the bounds relative to G e, lo0 + Lb w <= G (z - e) <= hi0 + Lb w, so that
    the iteration's pass G multiplies z - e = K v, which a zero start's first iteration (v = 0) has all zero"""
    return qp.Lw - qp.G @ qp.Fe


def output_box(problem: MpcProblem, b: int, W: int) -> tuple[np.ndarray, np.ndarray]:
    """The box the output words (z = (u_0, ..., u_N-1), p fraction bits) are clamped to as they leave the core: the
    input box quantised inward (lo up, hi down: a clamped word meets the box exactly), within the W-bit data word.
    Only the output is clamped; the iteration's z (and the averaged primal's sum) stay unclamped."""
    wmin, wmax = -(1 << (W - 1)), (1 << (W - 1)) - 1
    lo = np.clip(quantize(np.tile(problem.umin, problem.N), b, "ceil"), wmin, wmax)
    hi = np.clip(quantize(np.tile(problem.umax, problem.N), b, "floor"), wmin, wmax)
    return lo, np.maximum(hi, lo)


def restart_shifts(widths: dict) -> list[int]:
    """Right shifts that bring g and y_new - y to 18-bit operands for the restart test's products."""
    return [max(0, widths["data"] - 18), max(0, widths["data"] + 1 - 18)]


_DUALS_CACHE: dict = {}


def sample_duals(qp: DgpQP, p: MpcProblem, samples: int = 256, seed: int = 0) -> np.ndarray:
    """Largest dual (upper rows, lower rows) over the vertices of the box of w = (x, r) (every one up to 4096,
    else 4096 random ones) and `samples` random points of it (solve_qp); refuses a state of the box for which an LP
    proves the QP infeasible. Cached per problem data within a process."""
    import hashlib

    key = hashlib.sha256(b"".join(np.ascontiguousarray(a, dtype=float).tobytes() for a in
                                  (qp.Q, qp.Phi, qp.G, qp.lo0, qp.hi0, qp.Lw, p.xmin, p.xmax, p.rmin, p.rmax))
                         + f"{samples},{seed}".encode()).hexdigest()
    if key in _DUALS_CACHE:
        return _DUALS_CACHE[key].copy()
    rng = np.random.default_rng(seed)
    nx = p.nx
    wlo = np.concatenate([p.xmin, p.rmin])
    whi = np.concatenate([p.xmax, p.rmax])
    nw = len(wlo)
    verts = range(1 << nw) if nw <= 12 else rng.integers(0, 1 << min(nw, 62), 4096)
    pts = [np.where([(int(v) >> i) & 1 for i in range(nw)], whi, wlo) for v in verts]
    pts += [rng.uniform(wlo, whi) for _ in range(samples)]
    ymax = np.zeros(qp.m)
    for w in pts:
        a = solve_qp(qp, w, eps=1e-7)
        x = np.round(w[:nx], 4).tolist()
        if a.status == "infeasible":
            raise DesignError(f"the QP is infeasible at the state x = {x} of the accepted box (an LP proves it: the "
                              f"largest slack on the constraints is {a.margin / qp.sigma:.4g} < 0); shrink `states` "
                              f"to a box of states from which the constraints can be met")
        if a.status != "solved":
            raise DesignError(f"OSQP failed to solve the QP at the state x = {x} of the accepted box, which an LP "
                              f"shows feasible (slack {a.margin / qp.sigma:.4g}; OSQP: {a.status})")
        ymax = np.maximum(ymax, np.concatenate([a.yp, a.ym]))
    _DUALS_CACHE[key] = ymax
    return ymax.copy()


#: data words: the golden model's and the C solver's products are exact in 64 bits
DATA_MAX = 40
# bits of the answer's status word (iterations 15:0, met 16, sat 17, overflow 18): the stream word holds it whole
STATUS_WORD_BITS = 19
#: fraction bits where (36) and (37) together ask more than DATA_MAX (the design check may add more)
UNCERTIFIED_BITS = 16


def product_counts(d) -> list[int]:
    """how many multipliers of each width pair of DgpDesign.products() the core has"""
    return [d.P * d.lanes] + ([4 * d.P, 2 * d.P] if d.accelerated else [])


def _fit_lanes(d: DgpDesign) -> int:
    """`lanes: fit`: the most multipliers per row unit (up to the longest row) whose products and matrix memories
    fit the LFE5U-85F (ECP5 counts of mpc_cores.target) with the design's P row units"""
    for lanes in range(max(d.n, d.mc, d.nw), 0, -1):
        d.lanes = lanes
        if dsp_count("ecp5", d.products(), product_counts(d)) <= PART_MULTS and dp16kd(d.memories()) <= PART_BLOCKS:
            return lanes
    raise DesignError(f"lanes=fit: not even one multiplier per row unit fits the {PART} with P={d.P} "
                      f"({PART_MULTS} MULT18X18D, {PART_BLOCKS} DP16KD)")


def bits_36(n: int, m: int, D: float, LV: float, eps: float) -> float:
    a = math.sqrt(n / m) * 2 * D / LV
    return math.log2(m * math.sqrt(n) / (math.sqrt(eps / LV + a * a) - a)) - 1


def design_dgp(problem: MpcProblem, **overrides) -> DgpDesign:
    """Build the DGP core description. Keyword overrides take precedence over the spec's `solver:` section:
    frac_bits, int_bits, eps_g, eps_V, tol (both eps), accelerated, lanes, iterations, warm_start, warm_shift,
    output_all, target, lat_add, lat_mul, dual_margin, ram_state."""
    opt = lambda k, dflt: solver_opt(problem, overrides, k, dflt)  # noqa: E731
    for k in ("input_rate", "soft_states"):
        if getattr(problem, k, None) is not None:
            raise DesignError(f"the DGP core takes input and hard state constraints (Gz <= g + E x of 003): the spec "
                              f"also has {k}; use the ADMM core for it")
    _, P, lat_add, lat_mul, _, iterations, warm_start, output_all = run_options(
        problem, overrides, frac_bits=0, rounding="nearest", iterations=200)
    rounding = str(opt("rounding", "nearest"))
    if rounding != "nearest":
        raise DesignError(f"the DGP core rounds to nearest, as (36) of 003 assumes: got rounding={rounding!r}")
    tol = opt("tol", None)
    eps_g = float(opt("eps_g", tol if tol is not None else DEFAULT_EPS))
    eps_V = float(opt("eps_V", tol if tol is not None else DEFAULT_EPS))
    if not (eps_g > 0 and eps_V > 0):
        raise DesignError(f"eps_g and eps_V must be > 0: got eps_g={eps_g}, eps_V={eps_V}")
    accelerated = bool(opt("accelerated", True))
    warm_shift = bool(opt("warm_shift", False))
    if warm_shift and not accelerated:
        raise DesignError("warm_shift needs the accelerated form: the plain form's bound on V (Corollary 1 of 003) "
                          "holds from a cold start only")
    ram_state = bool(opt("ram_state", False))
    if ram_state and not accelerated:
        raise DesignError("ram_state needs the accelerated form (the plain form keeps its sums in registers)")
    if solver_opt(problem, overrides, "warm_start", None) is None:
        warm_start = accelerated           # the plain form's V guarantee needs a cold start (Corollary 1 of 003)
    lanes_opt = opt("lanes", 8)
    lanes = 8 if lanes_opt == "fit" else int(lanes_opt)
    margin = float(opt("dual_margin", 2.0))
    if margin < 1:
        raise DesignError(f"dual_margin must be >= 1 (d_i >= max(y*_i, 1), (14) of 003): got {margin}")
    if not 1 <= iterations <= 65535:
        raise DesignError(f"iterations must be in [1, 65535]: got {iterations}")
    if lat_add < 0 or (lat_mul or 0) < 0:
        raise DesignError(f"lat_add and lat_mul must be >= 0: got lat_add={lat_add}, lat_mul={lat_mul}")
    target = target_option(problem, overrides)
    qp = dgp_qp(problem)
    n, mc, nw = qp.n, qp.mc, qp.nw
    if not 1 <= lanes <= max(n, mc, nw):
        raise DesignError(f"lanes must be in [1, {max(n, mc, nw)}] (the longest row): got lanes={lanes}")
    if not 1 <= P <= max(n, mc):
        raise DesignError(f"P (row units) must be in [1, {max(n, mc)}] (the most rows of a pass): got P={P}")
    if ram_state and warm_shift:
        per = sorted({blk[2] for blk in _stage_blocks(qp, problem)})
        if any(k % P for k in per):
            raise DesignError(f"ram_state with warm_shift needs the rows per stage to be a multiple of P (a row's "
                              f"shift source in the same row unit's memory): rows per stage {per}, P={P}")

    d = np.maximum(margin * sample_duals(qp, problem), 1.0)
    if warm_shift:
        d = stage_envelope(d, qp, problem)
    D = float(np.linalg.norm(d))
    LV = float(np.linalg.eigvalsh(qp.Q)[-1])
    m = 2 * mc
    eps = min(eps_g * qp.sigma, eps_V)
    p36 = math.ceil(bits_36(n, m, D, LV, eps))

    wlo = np.concatenate([problem.xmin, problem.rmin])
    whi = np.concatenate([problem.xmax, problem.rmax])
    wabs = np.maximum(np.abs(wlo), np.abs(whi))
    K, Fe = qp.K, qp.Fe
    yhat = ALPHA * float(d.max())
    # (37) row by row: the dual words lie in [0, alpha d], so |v_j| = |y+_j - y-_j| <= alpha max(d+_j, d-_j) and
    # |z_i| <= sum_j |K_ij| |v_j| + |e_i|, |s_i| <= sum_j |G_ij| |z_j|; the norms of (37) bound the same sums by
    # ||E||_inf ||y||_inf and ||A||_inf ||z||_inf, which pair the largest dual with the longest row
    # the iteration takes s = G (z - e) against the bounds relative to G e (bound_rows), |z_i - e_i| <= dz_i
    Lb = bound_rows(qp)
    evec = np.abs(Fe) @ wabs
    ehat = float(evec.max())
    dzvec = np.abs(K) @ (ALPHA * np.maximum(d[:mc], d[mc:]))
    zvec = dzvec + evec
    zhat = float(zvec.max())
    bnd = np.maximum(np.abs(qp.lo0) + np.abs(Lb) @ wabs, np.abs(qp.hi0) + np.abs(Lb) @ wabs)
    ghat = float(np.max(np.abs(qp.G) @ dzvec + bnd))
    r37 = math.ceil(math.log2(max(yhat, zhat, ghat) + 1) + 1)
    r = int(opt("int_bits", r37))
    if r < r37:
        raise DesignError(f"int_bits={r} is below the {r37} integer bits (37) of 003 requires "
                          f"(max(y^, z^, g^) = {max(yhat, zhat, ghat):.4g}): the words could overflow")
    # p from (36), unless the data word would then exceed DATA_MAX bits: (36) is a worst case over the dual box
    # (log2 of 4 n sqrt(m) D / eps); the default then takes UNCERTIFIED_BITS fraction bits (the other fixed-point
    # kinds' default; the design check adds more where the loop needs them) and says that the (eps_g, eps_V)
    # guarantee is not certified
    b = int(opt("frac_bits", p36 if r + p36 <= DATA_MAX else min(UNCERTIFIED_BITS, DATA_MAX - r)))
    if b < 1:
        raise DesignError(f"frac_bits must be >= 1: got {b}")

    one = 1 << b
    xlo = quantize(wlo, b, "floor")
    xhi = quantize(whi, b, "ceil")
    beta = np.array([int(round(k / (k + 3) * one)) for k in range(BETA_TABLE)], dtype=np.int64)
    dsn = DgpDesign(problem=problem, qp=qp, b=b, P=P, lat_add=lat_add, lat_mul=lat_mul, rounding=rounding,
                    iterations=iterations, warm_start=warm_start, target=target, output_all=output_all,
                    accelerated=accelerated, warm_shift=warm_shift, ram_state=ram_state, lanes=lanes, eps_g=eps_g, eps_V=eps_V,
                    margin=margin, d=d,
                    K=quantize(K, b), G=quantize(qp.G, b), Fe=quantize(Fe, b), Lb=quantize(Lb, b),
                    lo0=quantize(qp.lo0, b, "ceil"), hi0=quantize(qp.hi0, b, "floor"),
                    ud=quantize(ALPHA * d, b, "floor"), eg=int(math.floor(eps_g * qp.sigma * one)),
                    eV=int(math.floor(eps_V * one)), beta=beta,
                    xlo=xlo, xhi=xhi, bits36=p36, bits37=r37,
                    analysis={"D": D, "L_V": LV, "eps": eps, "sigma": qp.sigma, "y_hat": yhat, "z_hat": zhat,
                              "g_hat": ghat, "e_hat": ehat, "d_max": float(d.max()), "m": m})
    _size_words(dsn, r)
    if lanes_opt == "fit":
        dsn.lanes = _fit_lanes(dsn)
    dsn.out_lo, dsn.out_hi = output_box(problem, b, dsn.widths["data"])
    apply_target(dsn, lat_mul, dsn.products())
    return dsn


def _size_words(d: DgpDesign, r: int) -> None:
    """Word widths: data r + p bits; the row sums' accumulator from the sum of |rounded products| over a row."""
    W = r + d.b
    coefs = [d.K, d.G, d.Fe, d.Lb]
    cb = int(max(int(np.abs(c).max()) if c.size else 0 for c in coefs))
    one = 1 << d.b
    dmax = (1 << (W - 1)) - 1
    xmax = int(max(np.abs(d.xlo).max(), np.abs(d.xhi).max()))
    # a row's products: |rnd(c v)| <= |c| |v| / 2^p + 1, v a data word, a w word in the first pass, or in pass G
    # the difference z - e of two data words
    vmax = [max(dmax, xmax), 2 * dmax + 1, max(dmax, xmax), max(dmax, xmax)]
    acc = max(int(np.abs(c).sum(axis=1).max()) * v // one + c.shape[1] + 1 for c, v in zip(coefs, vmax) if c.size)
    if W > DATA_MAX or bits_for(cb) > 32:
        raise DesignError(f"data words of {W} bits (at most {DATA_MAX}) or coefficients of {bits_for(cb)} bits (at most 32) "
                          f"exceed the exact products of the golden model and the C solver: raise eps_g / eps_V or "
                          f"shrink the state box")
    if max(bits_for(xmax), W) > 64:
        raise DesignError(f"{W}-bit data words exceed the 64-bit stream: reduce eps_g / eps_V or the state box")
    sums = bits_for(dmax * 65536)          # Sz, Sg and T over IMAX <= 65535 iterations
    # the stream word also carries the answer's status word (iterations 15:0, met 16, sat 17, overflow 18)
    d.widths = {"data": W, "coef": bits_for(cb), "x": bits_for(xmax), "op": max(W + 1, bits_for(xmax)),
                "acc": bits_for(acc + (1 << (W - 1))), "sum": sums + 1, "beta": bits_for(one),
                "stream": 8 * -(-max(W, bits_for(xmax), STATUS_WORD_BITS) // 8)}


def write_tol_spec(kind, problem_path, tol: float, overrides: dict, out=None):
    """`make design CORE=dgp TOL=...`: the design for eps_g = eps_V = TOL (bits from (36) and (37) of 003), its
    report, and the spec `make verilog` takes (to `out`, default build/design/<name>_dgp_tol<tol>.yaml)."""
    from pathlib import Path

    import yaml

    from mpc_cores.problem import load_spec

    p = load_spec(problem_path)
    d = design_dgp(p, **{**overrides, "tol": float(tol), "eps_g": float(tol), "eps_V": float(tol)})
    print(kind.design_report(d))
    spec = yaml.safe_load(Path(problem_path).read_text())
    spec.setdefault("name", p.name)
    spec["solver"] = dict(spec.get("solver") or {}, eps_g=float(tol), eps_V=float(tol), frac_bits=d.b,
                          int_bits=d.widths["data"] - d.b, iterations=d.iterations, accelerated=d.accelerated,
                          lanes=d.lanes, P=d.P)
    out = Path(out or f"build/design/{p.name}_dgp_tol{tol:g}.yaml")
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(f"# Designed by `make design CORE=dgp TOL={tol:g}` from {problem_path}: fraction bits from (36) "
                   f"and integer bits from (37) of 003\n# for an (eps_V, eps_g) = ({tol:g}, {tol:g}) solution.\n"
                   + yaml.safe_dump(spec, sort_keys=False))
    print(f"wrote {out}  (next: make verilog CORE=dgp PROBLEM={out})")
    return out
