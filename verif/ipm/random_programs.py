"""Random Stage 1 programs and data for the engine's testbench: every op, vec / scalar / gather operands in both
spaces, vec / scalar / scatter destinations, lengths from 1, addresses anywhere in the regions; no stream hazard
(mpc_cores.ipm.isa.stream_hazards: the interpreter's semantics are the streaming engine's). Words mix the special
values of binary32 (signed zeros, subnormals, infinities, quiet, signalling and payload NaNs, extremes) with
ordinary numbers, so that every unit meets them; or come from a handful of values (ties, signed zeros).
"""
from __future__ import annotations

import random

import numpy as np

from mpc_cores.ipm import isa
from mpc_cores.ipm.isa import Instr, Operand

SPECIAL = [0x00000000, 0x80000000, 0x7F800000, 0xFF800000, 0x7FC00000, 0xFFC00000, 0x7F800001, 0x7FA00000,
           0xFFC12345, 0x00000001, 0x80000001, 0x007FFFFF, 0x807FFFFF, 0x00800000, 0x80800000, 0x7F7FFFFF,
           0xFF7FFFFF, 0x3F800000, 0xBF800000, 0x3F800001, 0x3F7FFFFF, 0x40000000, 0x3F000000]


def random_word(rng: random.Random) -> int:
    r = rng.random()
    if r < 0.2:
        return rng.choice(SPECIAL)
    if r < 0.3:
        return rng.getrandbits(32)
    if r < 0.38:   # subnormal or tiny
        return (rng.getrandbits(1) << 31) | rng.getrandbits(rng.choice((23, 26, 28)))
    v = np.float32(rng.choice((1.0, -1.0)) * 2.0 ** rng.uniform(-8, 8))
    if rng.random() < 0.3:   # short mantissa: exact results, ties
        v = np.float32(np.round(v * 8) / 8)
    return int(np.array([v], dtype=np.float32).view(np.uint32)[0])


# few values, drawn from a handful per run: ties (+0 against -0 in MIN, MAX and MINRED), exact cancellations
FEW = [0x00000000, 0x80000000, 0x00000000, 0x80000000, 0x3F800000, 0x40000000, 0xBF800000, 0x7F800000, 0xFF800000,
       0x7FC00000, 0x00000001, 0x3F800001]


POSITIVE = [0x3F800000, 0x40000000, 0x7F800000, 0x00000001, 0x3F800001]


def random_words(rng: random.Random, n: int, few: bool = False) -> list[int]:
    """n words; `few`: from 2 to 4 values of FEW only, or both zeros and up to two positive values."""
    if few:
        if rng.random() < 0.5:
            pool = [0x00000000, 0x80000000] + rng.sample(POSITIVE, rng.randint(0, 2))
        else:
            pool = rng.sample(FEW, rng.randint(2, 4))
        return [rng.choice(pool) for _ in range(n)]
    return [random_word(rng) for _ in range(n)]


def _operand(rng, space, size, n, tables, dest=False) -> Operand:
    """An operand (or destination) of n elements inside a region of `size` words."""
    modes = ["vec", "scalar", "gather"]
    mode = rng.choices(modes, weights=(5, 2, 3))[0]
    usable = [t for t, tab in enumerate(tables) if len(tab) >= n and max(tab[:n]) < size]
    if mode == "gather" and not usable:
        mode = "vec"
    if mode == "gather":
        t = rng.choice(usable)
        return Operand(space, rng.randrange(size - max(tables[t][:n])), mode="gather", table=t)
    extent = n if (mode == "vec" or dest) else 1
    return Operand(space, rng.randrange(size - extent + 1), mode=mode)


def random_instr(rng, slot_words, const_len, tables, acc_lengths) -> Instr:
    op = rng.choice(isa.OPS)
    n = rng.choice(acc_lengths) if op == "ACC" else rng.choice((1, 2, 3, rng.randint(1, 12), rng.randint(1, 40)))

    def src():
        if rng.random() < 0.3:
            return _operand(rng, "const", const_len, n, tables)
        return _operand(rng, "slot", slot_words, n, tables)

    d = a = b = isa.NONE
    if op != "OUT":
        d = _operand(rng, "slot", slot_words, 1 if op in ("ACC", "MINRED") else n, tables, dest=True)
    if op != "IN":
        a = src()
    if op in isa.BINARY:
        b = src()
    return Instr(op, n, d, a, b)


def random_program(rng, slot_words, const_len, tables, acc_lengths, length) -> list[Instr]:
    prog = []
    while len(prog) < length:
        i = random_instr(rng, slot_words, const_len, tables, acc_lengths)
        if not isa.stream_hazards(i, tables):
            prog.append(i)
    return prog


def random_tables(rng, lengths, span) -> list[list[int]]:
    """Index tables of distinct entries (a scatter writes each word once)."""
    return [sorted(rng.sample(range(span), k)) if rng.random() < 0.5 else rng.sample(range(span), k)
            for k in lengths]
