"""The MINRES core's schedule as the generator computes it (minres.MinresParams), so that a design flow can plan
with it before generation; mpc_cores.minres.report checks it against the generator's hw.json."""
from __future__ import annotations

import math


def _log2ceil(x: int) -> int:
    """chisel3.util.log2Ceil: bits of x - 1 (0 for x = 1)."""
    return (x - 1).bit_length()


def schedule(N: int, M: int, K: int, lat: dict, P: int, warm: bool) -> dict:
    """P (0: eq. (15) of the core), the slot S, cycles per iteration P S and the batch's cycles at Imax = 0
    (a batch of Imax iterations takes batch_cycles_imax0 + Imax P S; back to back, batches start (Imax + 1) P S
    apart)."""
    la, lm, ld, ls = lat["lat_add"], lat["lat_mul"], lat["lat_div"], lat["lat_sqrt"]
    lat_matvec = 1 + lm + la * _log2ceil(K)
    acc_tail = la + 2 + la * _log2ceil(la)
    lat_b = lm + 2 * la
    lat_scalar = 4 * lm + 2 * la + ls + ld
    lat_cx = 2 * lm + 3 * la + ld
    t_row = M + (lm if warm else 0)
    t_b = t_row + N - 1 + lat_matvec + lm + acc_tail
    t_s = t_b + N - 1 + lat_b + lm + acc_tail
    t_c = t_s + lat_scalar + 1
    need = t_c + ld + 1
    p_auto = math.ceil(need / N)
    P = P or p_auto
    S = max(N, math.ceil(need / P))
    return {"P": P, "P_eq15": p_auto, "slot_cycles": S, "cycles_per_iteration": P * S,
            "batch_cycles_imax0": P * S - S + t_c + N + lat_cx}
