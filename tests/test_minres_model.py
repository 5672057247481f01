"""MINRES: the KKT system of the interior-point step in the banded order of Fig. 4 of 001 (order and bandwidth of
eq. (14)), the storage scheme of section VI-F, and the golden models (bit-exact binary32 model of the core,
float64 MINRES, direct solve)."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from conftest import random_problem
from mpc_cores.minres import band as band_mod
from mpc_cores.minres.band import band_pattern
from mpc_cores.minres.kkt import (Layout, const_rom, dense_cds_words, from_half_cds, half_bandwidth, kkt_matrix,
                              paper_bound_words, random_weights, sizes, storage_table, structured_words,
                              to_half_cds)
from mpc_cores.errors import DesignError
from mpc_cores.float.model import Format
from mpc_cores.minres.design import design_minres
from mpc_cores.minres.model import F32Ops, MinresCoreModel, WordOps, acc, minres64, tree, words

SHAPES = [(1, 1, 1), (1, 1, 5), (2, 1, 3), (3, 2, 4), (4, 1, 2), (2, 3, 6), (8, 4, 10), (5, 3, 20)]


def system(n, m, T, seed):
    p = random_problem(f"k{n}{m}{T}", n, m, T, 0, seed)
    rng = np.random.default_rng(seed)
    w = random_weights(rng, n, m, T, 0.1, 10.0)
    K = kkt_matrix(p.A, p.B, p.Q, p.R, p.QN, T, w)
    rom = const_rom(p.A, p.B, p.Q, p.R, p.QN, T)
    diag = np.diagonal(K)[Layout(n, m, T).primal_rows()]
    return p, K, rom, diag, rng


@pytest.mark.parametrize("n,m,T", SHAPES)
def test_kkt_order_bandwidth_and_structure(n, m, T):
    """N = T(2n+m) + 2n and M = 2n+m (eq. (14)), measured on the matrix; symmetric, indefinite; half-CDS round
    trip; the constant columns repeat with period 2n+m (const_rom checks it) and only column 0 varies with W."""
    p, K, rom, diag, rng = system(n, m, T, 1)
    N, M = sizes(n, m, T)
    assert K.shape == (N, N)
    assert half_bandwidth(K) == M
    assert np.array_equal(K, K.T)
    ev = np.linalg.eigvalsh(K)
    assert ev.min() < 0 < ev.max(), "the KKT matrix is indefinite"
    C = to_half_cds(K, M)
    assert np.array_equal(from_half_cds(C), K)
    K2 = kkt_matrix(p.A, p.B, p.Q, p.R, p.QN, T, random_weights(rng, n, m, T))
    C2 = to_half_cds(K2, M)
    assert np.array_equal(C[:, 1:], C2[:, 1:]), "columns 1..M-1 must not depend on W"
    assert not np.array_equal(C[:, 0], C2[:, 0])


def test_kkt_solves_the_mpc_step():
    """With W = 0 the KKT system is the optimality system of the equality-constrained MPC QP: its primal part
    matches the unconstrained LQ solution from x0 (states follow the dynamics)."""
    n, m, T = 3, 2, 6
    p = random_problem("lq", n, m, T, 0, 3)
    L = Layout(n, m, T)
    K = kkt_matrix(p.A, p.B, p.Q, p.R, p.QN, T)
    x0 = np.array([1.0, -0.5, 0.25])
    rhs = np.zeros(L.N)
    rhs[L.lam(0): L.lam(0) + n] = -x0
    z = np.linalg.solve(K, rhs)
    x = [z[L.x(k): L.x(k) + n] for k in range(T + 1)]
    u = [z[L.u(k): L.u(k) + m] for k in range(T)]
    assert np.allclose(x[0], x0)
    for k in range(T):
        assert np.allclose(x[k + 1], p.A @ x[k] + p.B @ u[k])


def test_storage_counts():
    """Structured count <= the bound of 001 <= dense-band CDS; the bound's saving is about 75% (m = 3, T = 20,
    as 001 claims) and ours more, since only the diagonal varies with box constraints."""
    for n in (1, 2, 5, 10, 20, 40):
        for P in (1, 4, 8):
            s = structured_words(n, 3, 20, P)["total"]
            assert s <= paper_bound_words(n, 3, 20, P) <= dense_cds_words(n, 3, 20, P)
    rows = storage_table()
    for r in rows:
        if r["n"] >= 5:
            assert 0.73 < r["saving_paper"] < 0.78, r
        assert r["saving_structured"] > r["saving_paper"]


def test_tree_and_accumulator_order():
    """tree() pairs (0,1), (2,3), ... with an odd element passed on; acc() uses L partial sums."""
    t = np.array([[1e8, 1.0, -1e8, 1.0, 3.0]], dtype=np.float32)
    f = np.float32
    assert tree(t)[0] == ((f(1e8) + f(1.0)) + (f(-1e8) + f(1.0))) + f(3.0)
    x = np.arange(1, 10, dtype=np.float32) * np.float32(0.1)
    s = np.float32(0)
    for v in x:
        s = v + s
    assert acc(x, 1) == s
    part = [x[0] + x[2] + x[4] + x[6] + x[8], x[1] + x[3] + x[5] + x[7]]
    assert acc(x, 2) == part[1] + part[0]  # terms 7, 8 arrive last: buckets 1 then 0


@pytest.mark.parametrize("n,m,T", [(1, 1, 5), (2, 1, 3), (3, 2, 4), (8, 4, 10)])
def test_model_matrix_and_convergence(n, m, T):
    """The core model multiplies by the float32 KKT matrix; float64 MINRES reaches the direct solve; the bit-exact
    binary32 model follows float64 MINRES and its error to the direct solve falls as iterations grow."""
    p, K, rom, diag, rng = system(n, m, T, 2)
    mdl = MinresCoreModel(n, m, T, rom, lat_add=4)
    d32 = diag.astype(np.float32)
    K32 = mdl.matrix(d32)
    assert np.array_equal(K32, K.astype(np.float32).astype(float))
    v = rng.standard_normal(mdl.N).astype(np.float32)
    assert np.allclose(mdl.matvec(mdl.band(d32), v), K32 @ v, rtol=1e-5, atol=1e-5)
    b = rng.standard_normal(mdl.N).astype(np.float32)
    xs = np.linalg.solve(K32, b.astype(float))
    rel = lambda x: np.linalg.norm(x - xs) / np.linalg.norm(xs)  # noqa: E731
    its = [max(1, mdl.N // 8), mdl.N // 2, mdl.N, 2 * mdl.N]
    e64 = [rel(minres64(K32, b, i)) for i in its]
    e32 = [rel(mdl.solve(d32, b, i).x) for i in its]
    assert e64[-1] < 1e-8, e64
    assert e32[-1] < 1e-3 and e32[-1] < 0.1 * e32[0], e32
    # early iterations: binary32 model close to float64 MINRES
    assert rel(mdl.solve(d32, b, its[0]).x - minres64(K32, b, its[0]) + xs) < 1e-3


def test_model_flags_nonfinite():
    n, m, T = 2, 1, 3
    p, K, rom, diag, rng = system(n, m, T, 4)
    mdl = MinresCoreModel(n, m, T, rom, lat_add=4)
    b = rng.standard_normal(mdl.N).astype(np.float32)
    d = diag.astype(np.float32)
    assert not mdl.solve(d, b, 5).flag
    d2 = d.copy()
    d2[3] = np.nan
    assert mdl.solve(d2, b, 5).flag
    b2 = b.copy()
    b2[0] = np.inf
    assert mdl.solve(d, b2, 5).flag
    r = mdl.solve(d, np.zeros_like(b), 3)   # b = 0: 0/0 in the normalisation, flagged, not a hang
    assert r.flag and all(w == 0x7FC00000 for w in words(r.x))


def test_word_arithmetic_equals_float32_path():
    """The binary32 fast path (numpy float32) and the word arithmetic of mpc_cores.float.vector give the same words
    for a whole solve."""
    n, m, T = 2, 1, 3
    p, K, rom, diag, rng = system(n, m, T, 5)
    fast = MinresCoreModel(n, m, T, rom, lat_add=3)
    assert isinstance(fast.ops, F32Ops)
    slow = MinresCoreModel(n, m, T, rom, lat_add=3)
    slow.ops = WordOps(Format(8, 23))
    slow.rom = slow.ops.value(rom)
    slow.coefs = [slow.ops.value(c) for c in fast.coefs]
    for k in range(3):
        b = rng.standard_normal(fast.N)
        assert fast.solve(diag, b, 4 + 3 * k).words == slow.solve(diag, b, 4 + 3 * k).words


def test_model_e8m17():
    """The e8m17 model (18-bit significands) converges, less far than binary32, and flags non-finite data; its
    words are 26 bits wide."""
    n, m, T = 3, 2, 4
    p, K, rom, diag, rng = system(n, m, T, 6)
    f = Format(8, 17)
    mdl, m32 = MinresCoreModel(n, m, T, rom, 4, f), MinresCoreModel(n, m, T, rom, 4)
    b = rng.standard_normal(mdl.N)
    Kf = mdl.matrix(diag)
    xs = np.linalg.solve(Kf, mdl.ops.to_float(mdl.ops.value(b)))
    rel = lambda x: np.linalg.norm(x - xs) / np.linalg.norm(xs)  # noqa: E731
    r = mdl.solve(diag, b, 2 * mdl.N)
    e17, e32 = rel(r.x), rel(m32.solve(diag, b, 2 * mdl.N).x)
    assert not r.flag and e17 < 3e-2 and e32 < e17, (e17, e32)
    assert all(0 <= w < 1 << 26 for w in r.words)
    d2 = np.array(diag, dtype=float)
    d2[1] = np.inf
    assert mdl.solve(d2, b, 3).flag
    assert all(w == f.qnan for w in mdl.solve(diag, np.zeros(mdl.N), 3).words)


@pytest.mark.parametrize("fmt,rule", [
    ("e9m23", "format must fit the 32-bit stream word (1 + E + M <= 32): got e9m23, 33 bits"),
    ("e1m10", "format e1m10: FloatFormat: exponent width expW must be in [2, 16]: got expW=1"),
    ("e6m25", "format e6m25: the bit-exact model float.vector: needs manW <= 24"),
    ("f32", "format must be binary32, binary16 or e<E>m<M> (e.g. e8m17): got 'f32'"),
])
def test_format_refusals(fmt, rule):
    p = random_problem("fr", 2, 1, 3, 0, 1)
    with pytest.raises(DesignError) as e:
        design_minres(p, format=fmt)
    assert rule in str(e.value)


def test_format_from_spec_and_override():
    p = random_problem("fs", 2, 1, 3, 0, 1)
    assert design_minres(p).format == "binary32" and design_minres(p).lat["lat_div"] == 16
    d = design_minres(dataclasses.replace(p, solver={"minres_format": "e8m17"}))
    assert (d.format, d.lat["lat_div"], d.lat["lat_sqrt"]) == ("e8m17", 13, 13)
    assert design_minres(p, format="binary32").format == "binary32"
    assert max(d.config()["rom"][0]) < 1 << 26


@pytest.mark.parametrize("n,m,T", SHAPES)
def test_band_pattern_rows(n, m, T):
    """The sparse rows (mpc_cores.minres.band) rebuild the KKT matrix exactly, K is the most nonzeros of a row
    (at most 2M - 1), and a slot never takes two offsets within one key."""
    p, K, rom, diag, rng = system(n, m, T, 7)
    pat = band_pattern(n, m, T, rom)
    mdl = MinresCoreModel(n, m, T, rom, lat_add=4)
    rows_nnz = int(np.max(np.count_nonzero(K, axis=1)))
    assert pat.K == rows_nnz <= 2 * Layout(n, m, T).M - 1
    assert np.array_equal(mdl.matrix(diag.astype(np.float32)), K.astype(np.float32).astype(float))
    for offs in pat.offsets:
        used = [o for o in offs if o is not None]
        assert len(used) == len(set(used))


def test_band_pattern_masses_and_refusals():
    """masses: a lambda row holds A, B and a -1, so K = n + m + 1 = 13 products per row instead of 2M - 1 = 39. A
    pattern that drops a nonzero, or gives a slot a wrong coefficient, is refused."""
    from mpc_cores.problem import load_spec
    from mpc_cores.minres.kkt import problem_matrices
    p = load_spec(Path(__file__).resolve().parents[1] / "examples/masses.yaml")
    A, B, Q, R, QN, T = problem_matrices(p)
    rom = const_rom(A, B, Q, R, QN, T)
    pat = band_pattern(p.nx, p.nu, T, rom)
    assert pat.K == p.nx + p.nu + 1 == 13
    C = band_mod.const_cds(p.nx, p.nu, T, rom)
    primal = np.zeros(Layout(p.nx, p.nu, T).N, dtype=bool)
    primal[Layout(p.nx, p.nu, T).primal_rows()] = True
    band_mod._check(pat, C, primal)
    q = next(q for q, offs in enumerate(pat.offsets) if -1 in offs)
    dropped = [list(o) for o in pat.offsets]
    dropped[q][dropped[q].index(-1)] = None
    with pytest.raises(AssertionError, match="differs from the band"):
        band_mod._check(dataclasses.replace(pat, offsets=tuple(map(tuple, dropped))), C, primal)
    wrong = pat.coefs.copy()
    wrong[q, list(pat.offsets[q]).index(-1)] *= 2
    with pytest.raises(AssertionError, match="differs from the band"):
        band_mod._check(dataclasses.replace(pat, coefs=wrong), C, primal)
