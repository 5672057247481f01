"""The KKT matrix of the interior-point step of 001 (section V, the system after block elimination) for an MPC
problem, reordered as in Fig. 4 of 001 so that it is banded, and its storage schemes (section VI-F).

Notation of 001: n states, m inputs, T horizon (MpcProblem: nx, nu, N). Unknowns per stage k < T:
(lambda_k, x_k, u_k), then (lambda_T, x_T): lambda_k (n) are the multipliers of the dynamics (lambda_0 of the
initial-state equation x_0 = x^), interleaved with the primal variables. The matrix is

    [ H + W   F' ]        H = blkdiag(Q, R, ..., Q, R, QN),  W = diag(w) > 0 on the constrained variables
    [ F       0  ]        F: -x_0 = -x^;  A x_k + B u_k - x_{k+1} = 0

with order N = T(2n+m) + 2n and half-bandwidth M = 2n+m (eq. (14)): entry (i, j) is zero for |i - j| >= M.

Half-CDS: row i, column d in [0, M) holds A[i, i+d] (zero past the last row). Of its M columns only column 0
(the diagonal) changes with the interior-point weights: its primal entries H_ii + w_i are the *variable part*
(T(n+m) + n words per problem); columns 1..M-1 are constant and periodic with period 2n+m, except the rows of
x_T (QN instead of Q). The lambda rows hold zeros and a -1 at d = n only, generated, not stored.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def sizes(n: int, m: int, T: int) -> tuple[int, int]:
    """(N, M) of eq. (14) of 001."""
    return T * (2 * n + m) + 2 * n, 2 * n + m


@dataclass
class Layout:
    """Positions of the unknowns in the interleaved order of Fig. 4."""
    n: int
    m: int
    T: int

    @property
    def period(self) -> int:
        return 2 * self.n + self.m

    @property
    def N(self) -> int:
        return sizes(self.n, self.m, self.T)[0]

    @property
    def M(self) -> int:
        return sizes(self.n, self.m, self.T)[1]

    @property
    def n_primal(self) -> int:
        """Words of the variable part: the diagonal of the primal rows x_0, u_0, ..., x_T."""
        return self.T * (self.n + self.m) + self.n

    def lam(self, k: int) -> int:
        return k * self.period

    def x(self, k: int) -> int:
        return k * self.period + self.n

    def u(self, k: int) -> int:
        return k * self.period + 2 * self.n

    def primal_rows(self) -> np.ndarray:
        """Row index of every primal unknown, in the order of the variable part (x_0, u_0, x_1, ..., x_T)."""
        rows = []
        for k in range(self.T):
            rows += list(range(self.x(k), self.x(k) + self.n)) + list(range(self.u(k), self.u(k) + self.m))
        rows += list(range(self.x(self.T), self.x(self.T) + self.n))
        return np.array(rows, dtype=np.int64)

    def row_kind(self, i: int) -> tuple[str, int]:
        """('lam' | 'x' | 'u' | 'xT', index within its block) of row i."""
        k, r = divmod(i, self.period)
        if r < self.n:
            return "lam", r
        if k == self.T:
            return "xT", r - self.n
        if r < 2 * self.n:
            return "x", r - self.n
        return "u", r - 2 * self.n


def kkt_matrix(A, B, Q, R, QN, T: int, w: np.ndarray | None = None) -> np.ndarray:
    """Dense N x N KKT matrix in the interleaved order (float64). `w`: interior-point weights on the primal
    unknowns in the order of Layout.primal_rows (zero where a variable is unconstrained); None = 0."""
    A, B, Q, R, QN = (np.atleast_2d(np.asarray(a, dtype=float)) for a in (A, B, Q, R, QN))
    n, m = B.shape
    L = Layout(n, m, T)
    K = np.zeros((L.N, L.N))
    for k in range(T):
        xs, us = slice(L.x(k), L.x(k) + n), slice(L.u(k), L.u(k) + m)
        K[xs, xs] = Q
        K[us, us] = R
    xT = slice(L.x(T), L.x(T) + n)
    K[xT, xT] = QN
    eye = np.eye(n)
    for k in range(T + 1):
        lk, xk = slice(L.lam(k), L.lam(k) + n), slice(L.x(k), L.x(k) + n)
        K[lk, xk] = -eye          # -x_0 = -x^, and the -x_{k+1} of the dynamics
        K[xk, lk] = -eye
        if k > 0:
            xp, up = slice(L.x(k - 1), L.x(k - 1) + n), slice(L.u(k - 1), L.u(k - 1) + m)
            K[lk, xp] = A
            K[lk, up] = B
            K[xp, lk] = A.T
            K[up, lk] = B.T
    if w is not None:
        pr = L.primal_rows()
        K[pr, pr] += np.asarray(w, dtype=float)
    return K


def half_bandwidth(K: np.ndarray) -> int:
    """Smallest M with K[i, j] = 0 for |i - j| >= M."""
    i, j = np.nonzero(K)
    return int(np.max(np.abs(i - j))) + 1 if len(i) else 0


def to_half_cds(K: np.ndarray, M: int) -> np.ndarray:
    """N x M half-CDS: C[i, d] = K[i, i+d] (0 past the end)."""
    N = K.shape[0]
    C = np.zeros((N, M), dtype=K.dtype)
    for d in range(M):
        C[: N - d, d] = np.diagonal(K, d)
    return C


def from_half_cds(C: np.ndarray) -> np.ndarray:
    N, M = C.shape
    K = np.zeros((N, N), dtype=C.dtype)
    for d in range(M):
        idx = np.arange(N - d)
        K[idx, idx + d] = C[: N - d, d]
        K[idx + d, idx] = C[: N - d, d]
    return K


def constrained_mask(n: int, m: int, T: int) -> np.ndarray:
    """Primal unknowns that carry an interior-point weight: every input and every state after x_0 (the box of
    the spec); x_0 is fixed by its equation."""
    mask = []
    for k in range(T):
        mask += [k > 0] * n + [True] * m
    mask += [True] * n
    return np.array(mask, dtype=bool)


def random_weights(rng: np.random.Generator, n: int, m: int, T: int, lo: float = 1e-2, hi: float = 1e2) -> np.ndarray:
    """W_k of an interior-point iteration: a random positive weight (log-uniform in [lo, hi]) on every
    constrained variable, 0 elsewhere."""
    mask = constrained_mask(n, m, T)
    w = np.exp(rng.uniform(np.log(lo), np.log(hi), mask.size))
    return np.where(mask, w, 0.0)


@dataclass
class KktSystem:
    """One problem of the core: the constant part (from the MPC problem) and the variable part (diagonal)."""
    layout: Layout
    const_rom: np.ndarray   # (2n+m) x (M-1): columns d = 1..M-1 of the x/u rows of a period, then of x_T
    diag: np.ndarray        # variable part: H_ii + w_i on the primal rows (Layout.primal_rows order)
    K: np.ndarray           # the full matrix (float64, for the references)


def const_rom(A, B, Q, R, QN, T: int) -> np.ndarray:
    """The constant columns stored once (section VI-F, third observation): for the n + m primal rows of one
    period (x_k, u_k; identical for every k < T) and the n rows of x_T, the entries at offsets d = 1..M-1.
    Row r < n + m is period row n + r of stage 0; row n + m + q is x_T row q."""
    n, m = np.atleast_2d(B).shape
    L = Layout(n, m, T)
    K = kkt_matrix(A, B, Q, R, QN, T)
    C = to_half_cds(K, L.M)
    rows = [L.x(0) + r for r in range(n + m)] + [L.x(T) + q for q in range(n)]
    rom = C[rows, 1:].copy()
    # check the periodicity the hardware relies on
    for k in range(T):
        assert np.array_equal(C[L.x(k): L.x(k) + n + m, 1:], rom[: n + m]), "constant columns are not periodic"
    for k in range(T + 1):
        lam = C[L.lam(k): L.lam(k) + n, 1:]
        want = np.zeros_like(lam)
        want[:, n - 1] = -1.0
        assert np.array_equal(lam, want), "lambda rows are not (0, ..., -1 at d = n, ..., 0)"
    return rom


def problem_matrices(p):
    """(A, B, Q, R, QN, T) of an MpcProblem."""
    return p.A, p.B, p.Q, p.R, p.QN, p.N


def kkt_system(p, w: np.ndarray) -> KktSystem:
    A, B, Q, R, QN, T = problem_matrices(p)
    L = Layout(p.nx, p.nu, T)
    K = kkt_matrix(A, B, Q, R, QN, T, w)
    return KktSystem(L, const_rom(A, B, Q, R, QN, T), np.diagonal(K)[L.primal_rows()].copy(), K)


# ---- storage counts (section VI-F)
def dense_cds_words(n: int, m: int, T: int, P: int) -> int:
    """Half-CDS of a dense band, double-buffered for P problems: 2P (T(2n+m)+2n)(2n+m)."""
    N, M = sizes(n, m, T)
    return 2 * P * N * M


def paper_bound_words(n: int, m: int, T: int, P: int) -> int:
    """The structured count of 001 section VI-F: 2P(1 + T(m+n) + n)n + (1+m+n)(m+n)."""
    return 2 * P * (1 + T * (m + n) + n) * n + (1 + m + n) * (m + n)


def structured_words(n: int, m: int, T: int, P: int) -> dict:
    """Words this core stores: the variable column (the primal diagonal; the lambda rows' zeros are generated),
    double-buffered for P problems, and the constant columns once for all problems (one period of n+m primal
    rows plus the n rows of x_T, M-1 columns; the lambda rows' 0 / -1 are generated)."""
    N, M = sizes(n, m, T)
    variable = 2 * P * (T * (n + m) + n)
    constant = (2 * n + m) * (M - 1)
    return {"variable": variable, "constant": constant, "total": variable + constant}


def storage_table(m: int = 3, T: int = 20, ns=(2, 5, 10, 15, 20, 30, 40, 50), P: int | None = None) -> list[dict]:
    """Structured vs dense storage (words) for the closing note: m = 3, T = 20, several n. P defaults to the
    value of eq. (15) with the constants of 001 (k1 = 24, k2 = 154)."""
    rows = []
    for n in ns:
        N, M = sizes(n, m, T)
        PP = P or eq15_paper(N, M)
        s = structured_words(n, m, T, PP)
        d = dense_cds_words(n, m, T, PP)
        b = paper_bound_words(n, m, T, PP)
        rows.append({"n": n, "N": N, "M": M, "P": PP, "structured": s["total"], "paper_bound": b, "dense": d,
                     "saving_structured": 1 - s["total"] / d, "saving_paper": 1 - b / d})
    return rows


def eq15_paper(N: int, M: int, k1: int = 24, k2: int = 154) -> int:
    """P of eq. (15) with the constants of 001's implementation."""
    return -(-(3 * N + k1 * int(np.ceil(np.log2(2 * M - 1))) + k2) // N)
