"""Software baselines of the MINRES core on this CPU: scipy.sparse.linalg.minres and the float64 MINRES of
mpc_cores/minres/model.py (`minres64`, the core's iteration) on the KKT systems the testbench makes (H + W with
random interior-point weights, random b, both rounded to binary32), timed per solve at the core's Imax, and the
accuracy of the core's bit-exact binary32 model on them."""
from __future__ import annotations

import gc
import time
from dataclasses import dataclass

import numpy as np
from tqdm import tqdm

WEIGHTS = (0.1, 10.0)   # log-uniform interior-point weights, as verif/minres/tb.py draws them


@dataclass
class Systems:
    """KKT systems of one problem as the testbench makes them: diag = H_ii + w_i (random interior-point weights,
    log-uniform in WEIGHTS), b standard normal, both rounded to binary32; K the binary32 matrix the core uses."""
    diag: list
    b: list
    K: list                      # dense float64 N x N (binary32 values)
    imax: int
    model: object                # MinresCoreModel


def make_systems(d, count: int, seed: int = 1) -> Systems:
    from mpc_cores.minres.kkt import random_weights
    from mpc_cores.minres.model import MinresCoreModel

    rng = np.random.default_rng(seed)
    model = MinresCoreModel(d.n, d.m, d.T, d.rom, d.lat["lat_add"])
    diags, bs, Ks = [], [], []
    for _ in range(count):
        w = random_weights(rng, d.n, d.m, d.T, *WEIGHTS)
        diag = (np.asarray(d.h_diag) + w).astype(np.float32)
        diags.append(diag)
        bs.append(rng.standard_normal(model.N).astype(np.float32))
        Ks.append(model.matrix(diag))
    return Systems(diags, bs, Ks, d.iterations, model)


def rel_residual(K: np.ndarray, x: np.ndarray, b: np.ndarray) -> float:
    b = np.asarray(b, dtype=float)
    return float(np.linalg.norm(b - K @ np.asarray(x, dtype=float)) / np.linalg.norm(b))


class ScipyMinres:
    """scipy.sparse.linalg.minres on the CSR matrix, rtol = 0 and maxiter = Imax: it runs Imax iterations unless
    its own tests find the residual at machine precision first (the iterations are counted)."""
    name = "scipy.sparse.linalg.minres"

    def __init__(self, K: np.ndarray, imax: int):
        import scipy.sparse as sp

        self.A = sp.csr_matrix(K)
        self.imax = imax
        self.iters = 0

    def __call__(self, b: np.ndarray) -> np.ndarray:
        from scipy.sparse.linalg import minres

        self.iters = 0

        def cb(_):
            self.iters += 1

        x, _ = minres(self.A, np.asarray(b, dtype=float), rtol=0.0, maxiter=self.imax, callback=cb)
        return x


class NumpyMinres:
    """The float64 MINRES of mpc_cores/minres/model.py (`minres64`, the core's iteration) on the dense matrix, Imax
    iterations."""
    name = "numpy MINRES float64 (minres64)"

    def __init__(self, K: np.ndarray, imax: int):
        self.K = np.ascontiguousarray(K)
        self.imax = imax
        self.iters = imax

    def __call__(self, b: np.ndarray) -> np.ndarray:
        from mpc_cores.minres.model import minres64

        return minres64(self.K, b, self.imax)


SOLVERS = (("scipy", ScipyMinres), ("numpy", NumpyMinres))


def time_software(s: Systems, repeats: int) -> dict:
    """Wall time per solve (us) of each software solver on every system, `repeats` passes; the solver is set up
    per system outside the timing (matrix conversion), the solve timed with time.perf_counter (a progress bar on
    stderr counts the solves)."""
    out = {}
    bar = tqdm(total=len(SOLVERS) * repeats * len(s.b), desc="MINRES software timing", unit="solve", disable=None)
    for key, cls in SOLVERS:
        times = np.zeros((repeats, len(s.b)))
        res, iters = [], []
        for r in range(repeats):
            for k, (K, b) in enumerate(zip(s.K, s.b)):
                solver = cls(K, s.imax)
                gc.collect()
                gc.disable()
                try:
                    t0 = time.perf_counter()
                    x = solver(b)
                    times[r, k] = time.perf_counter() - t0
                finally:
                    gc.enable()
                if r == 0:
                    res.append(rel_residual(K, x, b))
                    iters.append(solver.iters)
                bar.update()
        out[key] = {"name": cls.name, "times_us": times * 1e6, "residual_max": max(res),
                    "residual_median": float(np.median(res)), "iterations": iters}
    bar.close()
    return out


def merge_times(a: dict | None, b: dict | None) -> dict | None:
    """Two timing sessions (before and after the hardware jobs) as one: every pass kept."""
    if a is None or b is None:
        return a or b
    return {k: dict(a[k], times_us=np.vstack([a[k]["times_us"], b[k]["times_us"]])) for k in a}


def median_us(times_us: np.ndarray) -> float:
    """The smallest per-pass median time per solve: other processes on the machine only ever add time."""
    return float(np.median(np.atleast_2d(times_us), axis=1).min())


def model_accuracy(s: Systems, count: int) -> dict:
    """Relative residual ||b - K x|| / ||b|| of the core's bit-exact binary32 model at Imax (the core's own
    output words) and of the float64 MINRES, on the first `count` systems, and of a direct solve."""
    from mpc_cores.minres.model import minres64

    core, f64, direct = [], [], []
    for K, diag, b in list(zip(s.K, s.diag, s.b))[:count]:
        r = s.model.solve(diag, b, s.imax)
        core.append(rel_residual(K, r.x, b) if not r.flag else float("nan"))
        f64.append(rel_residual(K, minres64(K, b, s.imax), b))
        direct.append(rel_residual(K, np.linalg.solve(K, np.asarray(b, dtype=float)), b))
    return {"systems": len(core), "core_max": max(core), "core_median": float(np.median(core)),
            "f64_max": max(f64), "direct_max": max(direct),
            "cond": float(np.median([np.linalg.cond(K) for K in s.K[:count]]))}

