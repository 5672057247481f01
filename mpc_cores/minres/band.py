"""The rows of the banded KKT matrix as the core's matrix-vector product sees them: sparse, with one pattern per
row key.

The band of the KKT matrix (mpc_cores.minres.kkt) is 2M - 1 wide, but a row holds few nonzeros: a lambda row
the -1 of x_k and A, B of the previous stage; an x row Q, A' and a -1; a u row R and B'. Which offsets o (column
i + o of row i) can be nonzero depends only on the row's position in its period, r = i mod (2n + m), and on
whether the row is in the last stage (x_T has QN): the row *key*, r or 2n + m + r. The core multiplies each row
by K slots, K the largest number of nonzeros of a key: slot s of key q takes the window word at offset
`offsets[q][s]` (None: an unused slot, a zero product) times the constant `coefs[q][s]`, or times the row's
variable diagonal where the offset is 0. The products are summed by the pairwise tree in slot order.

Slots are assigned so that few distinct offsets share a slot over all keys (each slot's window multiplexer is
as narrow as it can be made greedily); within the rule "one offset per slot per key", any assignment computes
the same matrix, and the tree order of the slots is part of the bit-exact contract with the RTL.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mpc_cores.minres.kkt import Layout


def const_cds(n: int, m: int, T: int, rom: np.ndarray) -> np.ndarray:
    """N x M half-CDS of the constant part (float64): columns d = 1..M-1 from the ROM (x, u and x_T rows), the
    -1 at d = n of the lambda rows, column 0 zero (the variable diagonal), zero past the last row."""
    L = Layout(n, m, T)
    N, M = L.N, L.M
    rom = np.asarray(rom, dtype=float)
    assert rom.shape == (2 * n + m, M - 1), f"rom must be {(2 * n + m, M - 1)}: got {rom.shape}"
    C = np.zeros((N, M))
    for i in range(N):
        kind, q = L.row_kind(i)
        if kind == "lam":
            C[i, n] = -1.0
        else:
            C[i, 1:] = rom[{"x": q, "u": n + q, "xT": n + m + q}[kind]]
    for d in range(1, M):
        C[N - d:, d] = 0.0
    return C


def row_key(L: Layout, i: int) -> int:
    """The key of row i: its position in the period, offset by 2n + m in the last stage."""
    k, r = divmod(i, L.period)
    return r if k < L.T else L.period + r


@dataclass(frozen=True)
class BandPattern:
    n: int
    m: int
    T: int
    offsets: tuple   # per key: K entries, the offset of the slot or None
    coefs: np.ndarray  # keys x K: the constant coefficient (float64; 0 for the diagonal slot and unused slots)

    @property
    def layout(self) -> Layout:
        return Layout(self.n, self.m, self.T)

    @property
    def K(self) -> int:
        return len(self.offsets[0])

    @property
    def keys(self) -> int:
        return len(self.offsets)

    def rows(self):
        """Per row i and slot s (N x K arrays): the column i + o (clipped), whether the product is taken (a used
        slot whose column is inside the matrix), the constant coefficient, and whether it is the diagonal."""
        L = self.layout
        N, K = L.N, self.K
        col = np.zeros((N, K), dtype=np.int64)
        ok = np.zeros((N, K), dtype=bool)
        coef = np.zeros((N, K))
        diag = np.zeros((N, K), dtype=bool)
        for i in range(N):
            q = row_key(L, i)
            for s, o in enumerate(self.offsets[q]):
                if o is None:
                    continue
                col[i, s] = min(max(i + o, 0), N - 1)
                ok[i, s] = 0 <= i + o < N
                coef[i, s] = self.coefs[q][s]
                diag[i, s] = o == 0
        return col, ok, coef, diag

    def config(self, encode) -> dict:
        """The generator's view: offsets (null for an unused slot) and the coefficients as raw words."""
        return {"band_offsets": [list(o) for o in self.offsets],
                "band_coefs": [[int(w) for w in encode(np.asarray(c, dtype=float))] for c in self.coefs]}

    @property
    def constant_words(self) -> int:
        """Constant coefficients the core holds (used slots other than the diagonal)."""
        return sum(o is not None and o != 0 for row in self.offsets for o in row)


def band_pattern(n: int, m: int, T: int, rom: np.ndarray) -> BandPattern:
    """The sparse rows of the KKT matrix whose constant part is `rom` (values of the format: a coefficient that
    rounds to zero is no product). Checks that the pattern reproduces every entry of the band."""
    return band_patterns(n, m, T, [rom])[0]


def band_patterns(n: int, m: int, T: int, roms) -> list[BandPattern]:
    """One pattern for several matrices of the same layout (the multiplexed interior-point core's channels, one
    B column each): the slots and offsets are those of the union of their nonzeros, so one window and one tree
    serve them all, and each matrix has its own coefficients (0 where its entry is zero: a product of 0). With one
    matrix this is `band_pattern`."""
    L = Layout(n, m, T)
    N, M, per = L.N, L.M, L.period
    Cs = [const_cds(n, m, T, r) for r in roms]
    primal = np.zeros(N, dtype=bool)
    primal[L.primal_rows()] = True
    nkeys = per + 2 * n
    found: list[list[dict[int, float]]] = [[dict() for _ in range(nkeys)] for _ in Cs]

    def note(c, q, o, v):
        prev = found[c][q].setdefault(o, v)
        assert prev == v, f"key {q}, offset {o}: coefficients {prev} and {v} differ between rows"

    for c, C in enumerate(Cs):
        for i in range(N):
            q = row_key(L, i)
            if primal[i]:
                note(c, q, 0, 0.0)
            for o in range(1, M):
                if i + o < N and C[i, o] != 0:
                    note(c, q, o, C[i, o])
                if i - o >= 0 and C[i - o, o] != 0:
                    note(c, q, -o, C[i - o, o])
    union = [set().union(*(f[q] for f in found)) for q in range(nkeys)]
    K = max(len(u) for u in union)
    # greedy: the largest keys first, each offset into a free slot that already takes it, else into the free
    # slot with the fewest offsets so far
    cand: list[set[int]] = [set() for _ in range(K)]
    offsets: list[list] = [[None] * K for _ in range(nkeys)]
    coefs = np.zeros((len(Cs), nkeys, K))
    for q in sorted(range(nkeys), key=lambda q: (-len(union[q]), q)):
        free = list(range(K))
        for o in sorted(union[q]):
            hit = [s for s in free if o in cand[s]]
            s = hit[0] if hit else min(free, key=lambda s: (len(cand[s]), s))
            cand[s].add(o)
            free.remove(s)
            offsets[q][s] = o
            for c in range(len(Cs)):
                coefs[c, q, s] = found[c][q].get(o, 0.0)
    pats = [BandPattern(n, m, T, tuple(tuple(o) for o in offsets), coefs[c]) for c in range(len(Cs))]
    for pat, C in zip(pats, Cs):
        _check(pat, C, primal)
    return pats


def _check(pat: BandPattern, C: np.ndarray, primal: np.ndarray) -> None:
    """Every nonzero of the band is one used slot with its coefficient, and no slot adds anything else."""
    L = pat.layout
    N, M = L.N, L.M
    dense = np.zeros((N, N))
    for d in range(M):
        idx = np.arange(N - d)
        dense[idx, idx + d] = C[: N - d, d]
        dense[idx + d, idx] = C[: N - d, d]
    col, ok, coef, diag = pat.rows()
    rebuilt = np.zeros((N, N))
    for i in range(N):
        for s in range(pat.K):
            if ok[i, s]:
                assert rebuilt[i, col[i, s]] == 0, f"row {i}: column {col[i, s]} in two slots"
                rebuilt[i, col[i, s]] = 1.0 if diag[i, s] else coef[i, s]
    off = ~np.eye(N, dtype=bool)
    assert np.array_equal(rebuilt[off], dense[off]), "the pattern differs from the band off the diagonal"
    assert np.array_equal(np.diagonal(rebuilt) != 0, primal), "the diagonal slots are not the primal rows"
