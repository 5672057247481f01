"""Integer bits of the DGP core: (37) of 003 taken row by row (mpc_cores.dgp.design) against its norm form, and the
words at the corners of the dual box, where the bound is reached: no data word saturates."""
from __future__ import annotations

import math

import numpy as np

from mpc_cores.dgp.design import ALPHA, bound_rows, design_dgp
from mpc_cores.dgp.model import DgpFixed
from mpc_cores.flow import REPO
from mpc_cores.problem import load_spec


def _norm_bits(d) -> int:
    """r of (37) with the norms: z^ = ||E||_inf y^ + ||e||_inf, g^ = ||A||_inf ||E||_inf y^ + ||b||_inf (the core's
    s = G (z - e) against the bounds relative to G e)"""
    p, qp = d.problem, d.qp
    wabs = np.maximum(np.abs(np.concatenate([p.xmin, p.rmin])), np.abs(np.concatenate([p.xmax, p.rmax])))
    yhat = ALPHA * float(d.d.max())
    dzhat = 2 * float(np.abs(qp.K).sum(axis=1).max()) * yhat           # |z - e|, the operand of pass G
    zhat = dzhat + float((np.abs(qp.Fe) @ wabs).max())
    bnd = np.maximum(np.abs(qp.lo0), np.abs(qp.hi0)) + np.abs(bound_rows(qp)) @ wabs
    ghat = float(np.abs(qp.G).sum(axis=1).max()) * dzhat + float(bnd.max())
    return math.ceil(math.log2(max(yhat, zhat, ghat) + 1) + 1)


def test_row_bound_below_norm_bound():
    d = design_dgp(load_spec(REPO / "examples/masses_state.yaml"))
    assert d.bits37 <= _norm_bits(d) - 1
    assert d.widths["data"] == d.b + d.bits37 <= 40


def test_dual_box_corners_do_not_saturate():
    """For every i, the dual at the corner of [0, ud] and the parameter at the vertex of its box that maximise
    (and minimise) z_i: one iteration of the core's model flags no saturated word, and |z_i| comes within a
    factor 2 of the row bound z^_i (the bound is reached up to the parameter's share)."""
    d = design_dgp(load_spec(REPO / "examples/masses_state.yaml"))
    m = DgpFixed(d, clamp=False)                                  # the iteration's z (the output clamp aside)
    mc, one = d.mc, float(1 << d.b)
    W, Y = [], []
    for i in range(d.n):
        for sgn in (1, -1):
            k = sgn * d.K[i]
            W.append(np.where(sgn * d.Fe[i] >= 0, d.xhi, d.xlo))
            Y.append(np.concatenate([np.where(k > 0, d.ud[:mc], 0), np.where(k < 0, d.ud[mc:], 0)]))
    res = m.solve_batch(np.array(W), imax=1, y0=np.array(Y))
    assert not res.overflow.any()
    zmax = np.abs(res.z).max(axis=0) / one
    assert np.all(zmax <= (1 << (d.bits37 - 1)))
    assert zmax.max() >= d.analysis["z_hat"] / 2
