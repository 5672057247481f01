"""Bit-exact model of the interior-point core: Algorithm 1 of 001 as the hardware computes it, in the core's float
format: binary32 on numpy float32 (correctly rounded with gradual underflow, like the float library), any other
format e<E>m<M> on raw words (mpc_cores.float.vector). Every line below is one rounded
operation of the core, in the core's order; the two stages of Fig. 2 of 001 are the two halves of an iteration.

Stage 1 runs the programs of mpc_cores.ipm.program on the interpreter of mpc_cores.ipm.machine; in formulas, the
linearisation of problem p (its iterate z, lu, ll, su, sl; th = z on the boxed variables):
    mu   = acc(lu*su, ll*sl) * inv_ineq                      (7), acc: the streaming accumulator of MINRES
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
    init:  u = bh - d * (A z);  then MinresCoreModel.iterate (nrm2, v_1, ...), x from 0
    iter:  y = d * (A (d * v_j)), the rest as MinresCoreModel.iterate
    Stage 1 forms dz = d * x
Stage 1, update (line 4-7 of Algorithm 1):
    dth = dz on the boxed variables
    dlu = wu*dth + tu    dll = tl - wl*dth    dsu = rGu - dth    dsl = rGl + dth
    q = v / dv for v in (lu, ll, su, sl); candidate -q where dv < 0 (else +inf); amax = min(1, min candidates)
    alpha = tau * amax;  z += alpha*dz;  lu += alpha*dlu; ...
In exact arithmetic A_k z + b_k = bt with b_k the right-hand side of (5) after block elimination, so MINRES from z
computes the Newton direction of 001 exactly; only the diagonal operations are in Stage 1.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mpc_cores.float.model import Format
from mpc_cores.ipm.machine import Machine
from mpc_cores.ipm.program import build
from mpc_cores.ipm.sparse import SparseMpc
from mpc_cores.minres.kkt import const_rom
from mpc_cores.minres.model import MinresCoreModel

f32 = np.float32


@dataclass
class Status:
    iterations: int = 0
    mu: float = 0.0
    residual: float = 0.0      # ||b_k||_2 of the last Newton system (the MINRES init norm, preconditioned)
    nonfinite: bool = False


class IpmModel:
    """The core's arithmetic: the Stage 1 programs (mpc_cores.ipm.program) on the interpreter of the Stage 1
    engine (mpc_cores.ipm.machine) and the warm-started, preconditioned MINRES below, for `slots` problems (each
    slot keeps its iterate between samples: the warm start of 001, unshifted). lat_add: the accumulators' partial
    sums (as MINRES). fmt: the float format of both stages (None: binary32 on numpy float32; any other format on
    raw words, mpc_cores.minres.model.ops_for)."""

    def __init__(self, s: SparseMpc, i_nw: int, i_mr: int, sigma: float = 0.1, tau: float = 0.99,
                 precondition: bool = True, lat_add: int = 4, start_value: float = 1.0, slots: int = 1,
                 warm_floor: float = 1e-2, fmt: Format | None = None):
        p = s.problem
        self.s, self.i_nw, self.i_mr, self.L = s, i_nw, i_mr, lat_add
        self.mr = MinresCoreModel(p.nx, p.nu, p.N, const_rom(p.A, p.B, p.Q, p.R, p.QN, p.N), lat_add, fmt)
        self.fmt = self.mr.fmt
        self.N, self.npr = s.N, len(s.primal)
        self.st1 = build(s, sigma, tau, precondition, start_value, warm_floor)
        self.machine = Machine(slots, self.st1.slot_words, self.st1.const_words, self.st1.tables, lat_add, fmt)
        self.ops = self.machine.ops
        self.started = [False] * slots

    def minres(self, diag, d, bh, z0):
        """Stage 2: MINRES on (D A_k D) y = D bt from y_0 = D^-1 z0 (MinresCoreModel.solve_warm), the operands in
        the memory's representation (float32 values in binary32, raw words otherwise); returns x = y - y_0 in that
        representation and ||r_0|| (a value)."""
        o = self.ops
        r, res = self.mr.solve_warm(*(o.to_float(v) for v in (diag, d, bh, z0)), self.i_mr)
        return o.value(r.x), float(o.to_float(res))

    def words(self, u) -> list[int]:
        """Raw words of the format of values (the words the core sends)."""
        return self.ops.words(self.ops.value(u))

    def solve(self, x, r=None, slot: int = 0, cold: bool = False) -> tuple[np.ndarray, Status]:
        """One sample on problem slot `slot`: u0 (values of the format: float32 in binary32, float64 otherwise)
        and the status."""
        M, P = self.machine, self.st1.programs
        p = self.s.problem
        M.feed(np.asarray(x, dtype=f32) if self.machine.binary32 else np.asarray(x, dtype=float))
        if p.ny:
            M.feed(np.asarray(r, dtype=f32) if self.machine.binary32 else np.asarray(r, dtype=float))
        M.run(P["sample"], slot)
        if cold or not self.started[slot]:
            M.run(P["cold"], slot)
            self.started[slot] = True
        else:
            M.run(P["warm"], slot)
        status = Status()
        for _ in range(self.i_nw):
            M.run(P["linearise"], slot)
            out = M.take()
            npr, N = self.npr, self.N
            diag, d, bh, z0 = out[:npr], out[npr:npr + N], out[npr + N:npr + 2 * N], out[npr + 2 * N:]
            xs, res = self.minres(diag, d, bh, z0)
            M.inq.extend(xs.tolist())
            M.run(P["receive"], slot)
            M.run(P["update"], slot)
            status.residual = res
        M.run(P["output"], slot)
        out = M.take()
        m = p.nu
        status.iterations = self.i_nw
        status.mu = float(M.to_float(out[m]))
        mem = M.mem[slot]
        status.nonfinite = not self.ops.finite(mem[: self.st1.slot["V"] + 4 * len(self.s.bounded)])
        return M.to_float(out[:m]), status

    def iterate(self, slot: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """(z, (lu, ll, su, sl)) of a slot, as values (float32 in binary32, float64 otherwise)."""
        a, nb = self.st1.slot, len(self.s.bounded)
        mem = self.machine.mem[slot]
        return (np.array(self.machine.to_float(mem[a["z"]: a["z"] + self.N])),
                np.array(self.machine.to_float(mem[a["V"]: a["V"] + 4 * nb])))
