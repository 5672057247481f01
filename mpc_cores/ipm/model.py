"""Bit-exact model of the interior-point core: Algorithm 1 of 001 as the hardware computes it, in binary32 (numpy
float32 is correctly rounded with gradual underflow, like the float library). Every line below is one rounded
operation of the core, in the core's order; the two stages of Fig. 2 of 001 are the two halves of an iteration.

Stage 1, linearisation of problem p (its iterate z, lu, ll, su, sl; th = z on the boxed variables):
    mu   = (acc(lu*su) + acc(ll*sl)) * inv_ineq              (7), acc: the streaming accumulator of MINRES
    smu  = sigma * mu
    rGu  = (hi - th) - su          rGl = (th - lo) - sl       (6c)
    rSu  = smu - lu*su             rSl = smu - ll*sl          (6d)
    wu   = lu / su                 wl  = ll / sl              W_k
    tu   = (rSu - lu*rGu) / su     tl  = (rSl - ll*rGl) / sl
    w    = wu + wl;  diag = Hd + w (boxed), Hd (free)         the variable column of A_k
    bt   = ((ll - lu) - (tu - tl)) + w*th (boxed), 0 (free primal), f (equality rows)
    d    = 1 / sqrt(max(off, diag)) (primal), d_const (equality rows)     equilibration; 1 without it
    bh   = d * bt
Stage 2, MINRES warm-started at z (so that its first matvec forms the residuals (6a, 6b)):
    init:  y = d * (A z);  u = bh - y;  then as mpc_cores.minres.model (nrm2, v_1, ...), x from 0
    iter:  y = d * (A (d * v_j)), the rest as mpc_cores.minres.model
    output dz = d * x
Stage 1, update (line 4-7 of Algorithm 1):
    dth = dz on the boxed variables
    dlu = wu*dth + tu    dll = tl - wl*dth    dsu = rGu - dth    dsl = rGl + dth
    q = v / dv for v in (lu, ll, su, sl); candidate -q where dv < 0 (else +inf); amax = min(1, min candidates)
    alpha = tau * amax;  z += alpha*dz;  lu += alpha*dlu; ...
In exact arithmetic A_k z + b_k = bt with b_k the right-hand side of (5) after block elimination, so MINRES from z
computes the Newton direction of 001 exactly; only the diagonal operations are in Stage 1.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mpc_cores.ipm.sparse import Sample, SparseMpc, sample, u0
from mpc_cores.minres.kkt import const_rom
from mpc_cores.minres.model import MinresCoreModel, tree

f32 = np.float32
INF = f32(np.inf)


def acc(terms: np.ndarray, L: int) -> np.float32:
    """mpc_cores.minres.model.acc, vectorised over the L partial sums (the same order and roundings)."""
    t = np.asarray(terms, dtype=f32)
    n = len(t)
    assert n > L, f"the accumulator needs more than L={L} terms, got {n}"
    pad = (-n) % L
    part = np.zeros(L, dtype=f32)
    rows = np.concatenate([t, np.zeros(pad, dtype=f32)]).reshape(-1, L)
    valid = np.concatenate([np.ones(n, bool), np.zeros(pad, bool)]).reshape(-1, L)
    with np.errstate(all="ignore"):
        for r, ok in zip(rows, valid):
            part = np.where(ok, r + part, part)
        order = [(n - L + q) % L for q in range(L)]
        return tree(part[order][None, :])[0] if L > 1 else part[0]


@dataclass
class State:
    """The iterate of one problem (float32), kept in Stage 1 between samples (warm start, unshifted)."""
    z: np.ndarray
    lu: np.ndarray
    ll: np.ndarray
    su: np.ndarray
    sl: np.ndarray

    def copy(self) -> "State":
        return State(*(a.copy() for a in (self.z, self.lu, self.ll, self.su, self.sl)))


@dataclass
class Status:
    iterations: int = 0
    mu: float = 0.0
    residual: float = 0.0      # ||b_k||_2 of the last Newton system (the MINRES init norm, preconditioned)
    nonfinite: bool = False
    alphas: list = field(default_factory=list)


class IpmModel:
    """The core's arithmetic for one problem. lat_add: the accumulators' partial sums (as MINRES)."""

    def __init__(self, s: SparseMpc, i_nw: int, i_mr: int, sigma: float = 0.1, tau: float = 0.99,
                 precondition: bool = True, lat_add: int = 4, start_value: float = 1.0):
        p = s.problem
        self.s, self.i_nw, self.i_mr, self.L = s, i_nw, i_mr, lat_add
        self.sigma, self.tau, self.pre = f32(sigma), f32(tau), precondition
        self.mr = MinresCoreModel(p.nx, p.nu, p.N, const_rom(p.A, p.B, p.Q, p.R, p.QN, p.N), lat_add)
        self.N = s.N
        self.primal = s.primal
        self.brow = s.primal[s.bounded]                 # rows of the boxed variables
        eq = np.ones(s.N, bool)
        eq[s.primal] = False
        self.eq = eq
        self.Hd = np.diag(s.K0)[s.primal].astype(f32)
        off = np.abs(self.mr.matrix(np.zeros(len(s.primal))) - np.diag(np.diag(self.mr.matrix(np.zeros(len(s.primal))))))
        self.off = off.max(axis=1).astype(f32)          # largest off-diagonal of every row (a constant)
        with np.errstate(divide="ignore"):
            self.d_eq = (f32(1) / np.sqrt(self.off[eq])).astype(f32)
        self.inv_ineq = f32(1.0 / s.n_ineq)
        self.start_value = f32(start_value)

    def cold(self) -> State:
        nb = len(self.s.bounded)
        v = np.full(nb, self.start_value, dtype=f32)
        return State(np.zeros(self.N, dtype=f32), v.copy(), v.copy(), v.copy(), v.copy())

    # ---- Stage 1
    def linearise(self, st: State, smp: Sample):
        L = self.L
        lo, hi = smp.lo.astype(f32), smp.hi.astype(f32)
        th = st.z[self.brow]
        lu, ll, su, sl = st.lu, st.ll, st.su, st.sl
        mu = (acc(lu * su, L) + acc(ll * sl, L)) * self.inv_ineq
        smu = self.sigma * mu
        rGu = (hi - th) - su
        rGl = (th - lo) - sl
        rSu = smu - lu * su
        rSl = smu - ll * sl
        wu, wl = lu / su, ll / sl
        tu = (rSu - lu * rGu) / su
        tl = (rSl - ll * rGl) / sl
        w = wu + wl
        diag = self.Hd.copy()
        diag[self.s.bounded] = self.Hd[self.s.bounded] + w
        bt = np.zeros(self.N, dtype=f32)
        bt[self.eq] = smp.f[self.eq].astype(f32)
        bt[self.brow] = ((ll - lu) - (tu - tl)) + w * th
        d = np.ones(self.N, dtype=f32)
        if self.pre:
            d[self.primal] = f32(1) / np.sqrt(np.maximum(self.off[self.primal], diag))
            d[self.eq] = self.d_eq
        bh = d * bt
        return diag, d, bh, (rGu, rGl, wu, wl, tu, tl, mu)

    # ---- Stage 2
    def minres(self, diag, d, bh, z0):
        mr, L = self.mr, self.L
        band = mr.band(diag)
        zero = np.zeros(self.N, dtype=f32)
        y = d * mr.matvec(band, z0)
        u = bh - y
        nrm2 = acc(u * u, L)
        g = np.sqrt(nrm2)
        res = g
        v = u / g
        vprev, w, wprev, x = zero, zero, zero, zero
        c = cp = f32(1.0)
        s = sp = f32(0.0)
        eta = g
        for j in range(1, self.i_mr + 1):
            y = d * mr.matvec(band, d * v)
            delta = acc(v * y, L)
            u = (y - delta * v) - g * vprev
            nrm2 = acc(u * u, L)
            g1 = np.sqrt(nrm2)
            a0 = c * delta - (cp * s) * g
            a1 = np.sqrt(a0 * a0 + nrm2)
            a2 = s * delta + (cp * c) * g
            a3 = sp * g
            c1 = a0 / a1
            s1 = g1 / a1
            ceta = c1 * eta
            eta = -(s1 * eta)
            vnew = u / g1
            wnew = ((v - a3 * wprev) - a2 * w) / a1
            x = x + ceta * wnew
            vprev, v = v, vnew
            wprev, w = w, wnew
            cp, c = c, c1
            sp, s = s, s1
            g = g1
        return d * x, res

    # ---- Stage 1
    def update(self, st: State, dz, saved) -> tuple[State, np.float32]:
        rGu, rGl, wu, wl, tu, tl, _ = saved
        dth = dz[self.brow]
        dlu = wu * dth + tu
        dll = tl - wl * dth
        dsu = rGu - dth
        dsl = rGl + dth
        v = np.concatenate([st.lu, st.ll, st.su, st.sl])
        dv = np.concatenate([dlu, dll, dsu, dsl])
        q = v / dv
        cand = np.where(dv < 0, -q, INF)
        amax = np.minimum(f32(1.0), cand.min()) if len(cand) else f32(1.0)
        a = self.tau * amax
        return State(st.z + a * dz, st.lu + a * dlu, st.ll + a * dll, st.su + a * dsu, st.sl + a * dsl), a

    def solve(self, smp: Sample, start: State | None = None) -> tuple[State, Status]:
        st = (start or self.cold()).copy()
        status = Status()
        with np.errstate(all="ignore"):
            for k in range(self.i_nw):
                diag, d, bh, saved = self.linearise(st, smp)
                dz, res = self.minres(diag, d, bh, st.z)
                st, a = self.update(st, dz, saved)
                status.alphas.append(float(a))
                status.mu, status.residual = float(saved[-1]), float(res)
        status.iterations = self.i_nw
        status.nonfinite = not all(np.all(np.isfinite(a)) for a in (st.z, st.lu, st.ll, st.su, st.sl))
        return st, status
