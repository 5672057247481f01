"""The floating-point test session: which units are generated, which vectors each one gets, and the model's
results for them (computed once, shared by the model-vs-numpy and RTL-vs-model tests).

Every (operator, format) at its default latency gets N_RANDOM random pairs plus the edge cases; the formats of
at most 8 bits, (4, 3) and (2, 3), get every operand pair instead (exhaustive). Latency variants (0, 1, past the
step count) get fewer vectors: they check the pipeline registers, not the arithmetic.
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from verif.float import vectors as V
from mpc_cores.float import model
from mpc_cores.float.model import Format

OPS = ("add", "mul", "div", "sqrt", "cmp")
BINARY32 = Format(8, 23)
BINARY16 = Format(5, 10)
REDUCED = Format(6, 17)
E8M17 = Format(8, 17)  # the interior-point core's format
TINY = Format(4, 3)   # 8 bits: exhaustive
TINY2 = Format(2, 3)  # 6 bits, the narrowest exponent: exhaustive
FORMATS = (BINARY32, BINARY16, REDUCED, E8M17, TINY, TINY2)
N_RANDOM = 100_000
N_LATENCY = 5_000

# (op, format, latency) beyond the defaults: no registers, one, and more registers than steps
LATENCY_VARIANTS = [
    ("add", BINARY16, 0), ("add", BINARY16, 1), ("add", BINARY16, 9),
    ("mul", BINARY16, 0), ("mul", BINARY16, 8),
    ("div", BINARY16, 0), ("div", BINARY16, 1), ("div", BINARY16, 5), ("div", BINARY16, 20),
    ("sqrt", BINARY16, 2), ("sqrt", BINARY16, 17),
    ("cmp", BINARY16, 0), ("cmp", BINARY16, 4),
]
# fully pipelined (latency "steps": a register after every step), in the formats the cores use
PIPELINED = [(op, f, "steps") for f in (E8M17, BINARY32) for op in ("add", "mul", "div", "sqrt")]


def exhaustive_operands(f: Format, op: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    n = 1 << f.width
    if op == "sqrt":
        a = np.arange(n, dtype=np.uint64)
        return np.concatenate([a, a]), np.zeros(2 * n, np.uint64), np.repeat(np.uint64([0, 1]), n)
    a = np.repeat(np.arange(n, dtype=np.uint64), n)
    b = np.tile(np.arange(n, dtype=np.uint64), n)
    ob = np.repeat(np.uint64([0, 1]), n * n)
    return np.concatenate([a, a]), np.concatenate([b, b]), ob


@lru_cache(maxsize=None)
def operands(f: Format, op: str, n_random: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """(a, b, opbit, number of random pairs): edge cases first, then random pairs; exhaustive up to 8 bits."""
    if f.width <= 8:
        a, b, o = exhaustive_operands(f, op)
        return a, b, o, 0
    ea, eb, eo = V.edge_operands(f, op)
    ra, rb, ro = V.random_operands(f, op, n_random, seed)
    return np.concatenate([ea, ra]), np.concatenate([eb, rb]), np.concatenate([eo, ro]), n_random


# round_pack's case counts per model_results call: (format, op, n_random, seed) -> counts
COVERAGE: dict[tuple, dict[str, int]] = {}


@lru_cache(maxsize=None)
def model_results(f: Format, op: str, n_random: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    a, b, o, _ = operands(f, op, n_random, seed)
    for k in model.COVERAGE:
        model.COVERAGE[k] = 0
    r = V.model_results(f, op, a, b, o)
    COVERAGE[(f, op, n_random, seed)] = dict(model.COVERAGE)
    return r


def seed_of(f: Format, op: str) -> int:
    return 1000 * f.expW + 10 * f.manW + OPS.index(op)
