"""FGM golden models.

FgmFixed is the bit-exact model of the generated core (src/main/scala/fgm/FgmCore.scala): the same integer
words, the same rounding of every product, the same pairwise adder-tree order and the same saturation, so
the RTL must match it word for word, flags included. fgm_float runs Algorithm 1 of 002 in float64.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mpc_cores.fgm.design import FgmDesign
from mpc_cores.fixed import saturate, shift_round, tree_sum


@dataclass
class SolveResult:
    z: np.ndarray               # final iterate words (n,)
    sat: bool                   # an input word was outside the box and saturated
    overflow: bool              # a datapath word saturated
    iterates: list | None = None  # z_0..z_Imax words when recorded
    iterations: int = 0         # iterations run (Imax, or fewer when the exit test held)
    met: bool = False           # the exit test held after the last iteration (ITERATIONS.MET)


class CoreData:
    """The numbers a core is built from: the generator's config.json (FgmDesign.config()), read back."""

    def __init__(self, cfg: dict):
        self.cfg = cfg
        self.n, self.nu, self.nw = int(cfg["n"]), int(cfg["nu"]), int(cfg["nw"])
        self.m = max(self.n, self.nw)
        self.b = int(cfg["frac_bits"])
        self.rounding = cfg["rounding"]
        self.widths = dict(cfg["widths"])
        self.iterations = int(cfg["iterations"])
        self.warm_start = bool(cfg["warm_start"])
        self.early_exit = bool(cfg.get("early_exit", False))
        self.exit_tol = int(cfg.get("exit_tol", 0))


class FgmFixed:
    """Bit-exact model of one core instance, including its warm-start state and run-time writable data."""

    def __init__(self, d: FgmDesign | dict):
        cfg = d.config() if isinstance(d, FgmDesign) else d
        self.d = CoreData(cfg)
        self.A = np.array(cfg["A"], dtype=np.int64).reshape(self.d.n, self.d.n)
        self.F = np.array(cfg["F"], dtype=np.int64).reshape(self.d.n, self.d.nw)
        self.lo = np.array(cfg["lo"], dtype=np.int64)
        self.hi = np.array(cfg["hi"], dtype=np.int64)
        self.xlo = np.array(cfg["xlo"], dtype=np.int64)
        self.xhi = np.array(cfg["xhi"], dtype=np.int64)
        self.beta = int(cfg["beta"])
        self.opb = int(cfg["one_plus_beta"])
        self.z_prev: np.ndarray | None = None    # None: no valid warm start (after reset or a bounds write)

    def reset(self) -> None:
        """Core reset: the warm start is lost, the data memories keep their contents."""
        self.z_prev = None

    def write_bounds(self, lo=None, hi=None) -> None:
        if lo is not None:
            self.lo = np.asarray(lo, dtype=np.int64).copy()
        if hi is not None:
            self.hi = np.asarray(hi, dtype=np.int64).copy()
        self.z_prev = None

    def _dot(self, M: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, bool]:
        d = self.d
        m = d.m
        Mp = np.zeros((M.shape[0], m), dtype=np.int64)
        Mp[:, : M.shape[1]] = M
        vp = np.zeros(m, dtype=np.int64)
        vp[: v.shape[0]] = v
        prods, f1 = saturate(shift_round(Mp * vp[None, :], d.b, d.rounding), d.widths["sum"])
        s, f2 = tree_sum(prods, d.widths["sum"])
        return s, f1 or f2

    def solve(self, w_words, imax: int | None = None, warm: bool | None = None, record: bool = False,
              exit_tol: int | None = None) -> SolveResult:
        """One solve. With the exit test (early_exit), `exit_tol` is EXIT_TOL (default its reset value): the solve
        ends after the first iteration whose step max |z+ - z| and the previous iteration's are below it (the first
        iteration's previous step is 0), else after `imax`."""
        d = self.d
        imax = d.iterations if imax is None else int(imax)
        tol = (d.exit_tol if exit_tol is None else int(exit_tol)) if d.early_exit else 0
        warm = d.warm_start if warm is None else bool(warm)
        w_in = np.asarray(w_words, dtype=np.int64)
        assert w_in.shape == (d.nw,), f"expected {d.nw} words, got {w_in.shape}"
        w = np.clip(w_in, self.xlo, self.xhi)
        sat = bool(np.any(w != w_in))
        h, ovf = self._dot(self.F, w)
        if warm and self.z_prev is not None:
            nu = d.nu
            z = np.concatenate([self.z_prev[nu:], self.z_prev[d.n - nu:]])    # shifted, last block repeated
        else:
            z = np.clip(np.zeros(d.n, dtype=np.int64), self.lo, self.hi)
        y = z.copy()
        its = [z.copy()] if record else None
        prev_ok, met, done = True, False, 0
        for _ in range(imax):
            s, f = self._dot(self.A, y)
            t, ft = saturate(s - h, d.widths["t"])
            zn = np.clip(t, self.lo, self.hi)
            yn, fy = saturate(shift_round(self.opb * zn, d.b, d.rounding) - shift_round(self.beta * z, d.b, d.rounding),
                              d.widths["y"])
            ovf |= f or ft or fy
            ok = int(np.abs(zn - z).max()) < tol
            met, prev_ok = ok and prev_ok, ok
            z, y = zn, yn
            done += 1
            if record:
                its.append(z.copy())
            if met:
                break
        self.z_prev = z.copy()
        return SolveResult(z=z, sat=sat, overflow=ovf, iterates=its, iterations=done, met=met)


def fgm_float(G: np.ndarray, Phi_n: np.ndarray, beta: float, lb: np.ndarray, ub: np.ndarray, w: np.ndarray,
              imax: int, z0: np.ndarray | None = None) -> list[np.ndarray]:
    """Algorithm 1 of 002 in float64 on t = G y - Phi_n w, G = I - H_n; returns z_0..z_imax."""
    z = np.clip(np.zeros(G.shape[0]), lb, ub) if z0 is None else np.asarray(z0, dtype=float)
    y = z.copy()
    h = Phi_n @ w
    out = [z.copy()]
    for _ in range(imax):
        zn = np.clip(G @ y - h, lb, ub)
        y = (1 + beta) * zn - beta * z
        z = zn
        out.append(z.copy())
    return out


def fgm_float_quantised(d: FgmDesign, w_words, imax: int, z0_words=None) -> list[np.ndarray]:
    """Exact-arithmetic iterates on the quantised data of the core (the reference of eq. (20) of 002), in words
    scaled back to reals."""
    one = float(1 << d.b)
    w = np.clip(np.asarray(w_words, dtype=np.int64), d.xlo, d.xhi) / one
    z0 = None if z0_words is None else np.asarray(z0_words) / one
    return fgm_float(d.A / one, d.F / one, d.beta / one, d.lo / one, d.hi / one, w, imax, z0)
