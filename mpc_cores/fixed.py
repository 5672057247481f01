"""Fixed-point helpers shared by the golden models: integer words with `b` fraction bits, in numpy int64.

The operations mirror src/main/scala/fixed/FixedOps.scala word for word: rounding of products (truncate =
floor, nearest = add half an LSB then floor), saturation to a signed width with a flag, and the pairwise
adder-tree reduction of linalg/DotProductTree.scala.
"""
from __future__ import annotations

import numpy as np

ROUNDING_MODES = ("truncate", "nearest")


def bits_for(bound: int) -> int:
    """Signed width that holds every integer in [-bound, bound] (FixedOps.bitsFor)."""
    return abs(int(bound)).bit_length() + 1


def wmin(width: int) -> int:
    return -(1 << (width - 1))


def wmax(width: int) -> int:
    return (1 << (width - 1)) - 1


def quantize(x, b: int, mode: str = "nearest") -> np.ndarray:
    """Real values to integer words with b fraction bits ('nearest', 'floor' or 'ceil'); beyond +-2^62 (wider than
    any word the design flows accept, which refuse such widths) clipped there rather than wrapped by the cast."""
    s = np.asarray(x, dtype=float) * (1 << b)
    f = {"nearest": np.round, "floor": np.floor, "ceil": np.ceil}[mode]
    return np.clip(f(s), -(2.0 ** 62), 2.0 ** 62).astype(np.int64)


def to_real(q, b: int) -> np.ndarray:
    return np.asarray(q, dtype=float) / (1 << b)


def shift_round(p: np.ndarray, shift: int, mode: str) -> np.ndarray:
    """p / 2^shift back to fewer fraction bits (FixedOps.shiftRound)."""
    if shift == 0:
        return p
    if mode == "truncate":
        return p >> shift
    if mode == "nearest":
        return (p + (1 << (shift - 1))) >> shift
    raise ValueError(f"rounding must be one of {ROUNDING_MODES}, got {mode!r}")


def saturate(x: np.ndarray, width: int) -> tuple[np.ndarray, bool]:
    """Clamp into a signed `width`-bit word; the flag tells whether anything was clamped."""
    lo, hi = wmin(width), wmax(width)
    c = np.clip(x, lo, hi)
    return c, bool(np.any(c != x))


def tree_sum(terms: np.ndarray, width: int) -> tuple[np.ndarray, bool]:
    """Reduce the last axis pairwise, (0,1), (2,3), ..., an odd last element passing on, saturating every
    partial sum to `width` bits, in the order of linalg/DotProductTree.scala."""
    level = terms
    flag = False
    while level.shape[-1] > 1:
        m = level.shape[-1]
        pairs = level[..., : m - (m % 2)]
        s, f = saturate(pairs[..., 0::2] + pairs[..., 1::2], width)
        flag |= f
        level = np.concatenate([s, level[..., m - 1 :]], axis=-1) if m % 2 else s
    return level[..., 0], flag


def run_time_fields(d, stream_width: int) -> dict:
    """The core.json entries every fixed-point design has: stream width, pipeline latencies, rounding, and the
    reset values of the run-time settings (IMAX, CTRL.WARM_START, CTRL.OUT_ALL)."""
    return {"stream_width": stream_width, "lat_add": d.lat_add, "lat_mul": d.lat_mul, "target": d.target,
            "rounding": d.rounding,
            "iterations": d.iterations, "warm_start": d.warm_start, "output_all": d.output_all}
