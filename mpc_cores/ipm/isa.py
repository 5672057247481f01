"""Stage 1 of the interior-point core (001, section VI-C): a sequential floating-point vector machine and its
instruction set. The programs (mpc_cores.ipm.program) and this interpreter are the contract between the RTL
(src/main/scala/ipm/) and the bit-exact model.

Memory. Each problem slot has a private data region of `slot_words` words ("slot" space); one shared region holds
the problem's constants ("const" space). Index tables (read-only) give gather and scatter patterns. An operand is
  vec      element i at addr + i
  scalar   the word at addr for every i (broadcast)
  gather   element i at addr + table[i]
and a destination is vec (addr + i), scatter (addr + table[i]) or, for the reductions, the single word addr.

Instructions stream n elements, one per cycle, through one unit; every result is one rounded operation of the
float library (mpc_cores/float/model.py):
  ADD a+b   SUB a-b   MUL a*b   DIV a/b   SQRT sqrt(a)   MOV a
  MIN  min(a, b)   MAX max(a, b)     IEEE order, a when equal (+0 and -0 are equal); NaN if either is NaN
  SELNEG  -a where b < 0, else +inf  (b = -0 is not < 0); the line-search candidate of a ratio a = v / dv
  ACC     sum of a[0..n-1] by the streaming accumulator of MINRES (lat_add partial sums, mpc_cores.minres.model.acc)
  MINRED  min of a[0..n-1], the first of equal values; NaN if any is NaN
  IN      n words of the input stream into the destination      OUT  a[0..n-1] to the output stream
Every NaN result is the canonical quiet NaN. Instructions run one after another (each waits until the previous
one's last result is written), so a program's cycle count is fixed: PROGRAM_START + the sum over its instructions
of n + the unit's latency + ISSUE_GAP (IN and OUT: latency 0, without backpressure).
The interpreter reads all n elements of an instruction before it writes any; the engine streams them, so an
element must not read a slot word that an earlier element of the same instruction writes (stream_hazards).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

OPS = ("ADD", "SUB", "MUL", "DIV", "SQRT", "MOV", "MIN", "MAX", "SELNEG", "ACC", "MINRED", "IN", "OUT")
SPACES = ("slot", "const")
MODES = ("vec", "scalar", "gather")
ISSUE_GAP = 7      # cycles an instruction adds to n + latency: the engine's table, address, memory, select and operand stages
PROGRAM_START = 1  # cycles a program adds to its instructions': its first instruction word is decoded ahead


@dataclass(frozen=True)
class Operand:
    space: str = "slot"
    addr: int = 0
    mode: str = "vec"
    table: int = 0          # index table of gather / scatter

    def __post_init__(self):
        assert self.space in SPACES and self.mode in MODES, self


NONE = Operand()


@dataclass(frozen=True)
class Instr:
    op: str
    n: int
    d: Operand = NONE
    a: Operand = NONE
    b: Operand = NONE
    note: str = ""

    def __post_init__(self):
        assert self.op in OPS and self.n >= 1, self


def latency(op: str, lat: dict) -> int:
    """Cycles from an element entering the unit to its result written (lat: add, mul, div, sqrt, cmp)."""
    return {"ADD": lat["add"], "SUB": lat["add"], "MUL": lat["mul"], "DIV": lat["div"], "SQRT": lat["sqrt"],
            "MOV": 1, "MIN": lat["cmp"], "MAX": lat["cmp"], "SELNEG": lat["cmp"],
            "ACC": lat["add"] + 1 + lat["add"] * max(0, int(np.ceil(np.log2(lat["add"])))) if lat["add"] > 1
            else lat["add"] + 1, "MINRED": 2, "IN": 0, "OUT": 0}[op]


BINARY = ("ADD", "SUB", "MUL", "DIV", "MIN", "MAX", "SELNEG")   # the ops that read operand b


def stream_hazards(i: Instr, tables) -> list[tuple[int, int]]:
    """Pairs (k, j), k < j, where element j of `i` reads a slot word that element k writes: the interpreter reads
    the old word, the streaming engine may read the new one. A program is valid for the engine without them
    (reductions write once, after their last read)."""
    if i.op in ("OUT", "ACC", "MINRED"):
        return []

    def addrs(o: Operand, dest: bool = False) -> list[int]:
        if o.mode == "gather":
            return [o.addr + int(t) for t in tables[o.table][: i.n]]
        if o.mode == "scalar" and not dest:
            return [o.addr] * i.n
        return [o.addr + k for k in range(i.n)]   # a scalar destination is written as a vector

    first = {}
    for k, a in enumerate(addrs(i.d, True)):
        first.setdefault(a, k)
    reads = [] if i.op == "IN" else [i.a] + ([i.b] if i.op in BINARY else [])
    return [(first[a], j) for o in reads if o.space == "slot"
            for j, a in enumerate(addrs(o)) if first.get(a, j) < j]


def cycles(program: list[Instr], lat: dict) -> int:
    """Cycles of a program without stream stalls."""
    return PROGRAM_START + sum(i.n + latency(i.op, lat) + ISSUE_GAP for i in program)


# ---- encoding of the instruction ROM (the generator reads the words from config.json)
OP_W, N_W, ADDR_W, TABLE_W = 4, 16, 16, 3
_OPERAND_W = 1 + 2 + ADDR_W + TABLE_W


def _enc_operand(o: Operand) -> int:
    assert 0 <= o.addr < (1 << ADDR_W) and 0 <= o.table < (1 << TABLE_W), o
    return SPACES.index(o.space) | (MODES.index(o.mode) << 1) | (o.addr << 3) | (o.table << (3 + ADDR_W))


def encode(i: Instr) -> int:
    """op [3:0], n [19:4], then the operands d, a, b of 22 bits each (space, mode, addr, table)."""
    assert i.n < (1 << N_W), i
    w = OPS.index(i.op) | (i.n << OP_W)
    for k, o in enumerate((i.d, i.a, i.b)):
        w |= _enc_operand(o) << (OP_W + N_W + k * _OPERAND_W)
    return w


INSTR_W = OP_W + N_W + 3 * _OPERAND_W
