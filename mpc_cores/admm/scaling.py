"""The cost scale of an ADMM-family design for plants whose multipliers dwarf the penalty.

ADMM converges in a number of iterations that grows with the ratio of the optimal multipliers nu* to rho z*: the
papers' rho = 2 suits the oscillating masses, whose |nu*| stays below a few hundred, but not, say, an aircraft whose
altitude steps of hundreds of metres weigh against a pitch limit of 0.35 rad (cessna: median |nu*|_inf = 3e5). Scaling
the cost by 2^-s divides nu* by 2^s and leaves z* as it is; in the core's data (H, h) rather than in the shifts
(rho 2^s), so that M11 stays near 1/rho and the words stay narrow. The components no constraint pins (states tied
to the rest only by the dynamics) then take a penalty 2^-FREE_DROP smaller, as OSQP gives its free rows the
smallest rho: a large rho there only slows the multipliers' travel through the dynamics.

The rule applies when the median of |nu*|_inf over parameters of the accepted box exceeds GATE times rho; below it
(every gallery plant but cessna) the design is that of 002.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import osqp

from mpc_cores.admm.problem import FREE, AdmmQP, _osqp

#: the rule applies above a median |nu*|_inf of GATE rho
GATE = 2.0 ** 10
#: the scaled multipliers' median, 2^TARGET_LOG2
TARGET_LOG2 = 3
#: the free components' penalty 2^-FREE_DROP times the rest's
FREE_DROP = 14


def multiplier_median(qp: AdmmQP, samples: int = 24, seed: int = 0) -> float:
    """median over `samples` parameters of the accepted box (those OSQP solves) of |nu*|_inf on the constrained
    components, nu* = -(H z* + h(w)) - F' lambda*"""
    rng = np.random.default_rng(seed)
    con = qp.kind != FREE
    out = []
    for _ in range(samples):
        w = rng.uniform(qp.wlo, qp.whi)
        res = _osqp(qp, w, hard=False, eps=1e-9)
        if res.info.status_val != osqp.SolverStatus.OSQP_SOLVED:
            continue
        z = np.asarray(res.x)
        nu = -(qp.H @ z + qp.h(w)) - qp.F.T @ np.asarray(res.y[: qp.F.shape[0]])
        out.append(float(np.abs(nu[con]).max(initial=0.0)))
    return float(np.median(out)) if out else 0.0


def cost_scale(qp: AdmmQP, rho: float) -> int:
    """s of the cost scale 2^-s: 0 (the design of 002) unless the median multiplier exceeds GATE rho"""
    m = multiplier_median(qp)
    if not m > GATE * rho:
        return 0
    return max(0, round(math.log2(m)) - TARGET_LOG2)


def scaled(qp: AdmmQP, s: int) -> AdmmQP:
    """the QP with its cost scaled by 2^-s (the same minimiser; multipliers 2^-s times)"""
    if s == 0:
        return qp
    f = 2.0 ** -s
    return dataclasses.replace(qp, H=f * qp.H, h_w=f * qp.h_w, h0=f * qp.h0)
