"""Interpreter of the Stage 1 instruction set (mpc_cores.ipm.isa) in binary32: the bit-exact model of the Stage 1
engine. Memory words are numpy float32; the RTL's words compare after canonicalising NaN (words()).
"""
from __future__ import annotations

from collections import deque

import numpy as np

from mpc_cores.ipm.isa import Instr, Operand
from mpc_cores.minres.model import acc
from mpc_cores.minres.model import words as minres_words

f32 = np.float32
INF = f32(np.inf)


def words(x) -> list[int]:
    """Raw binary32 words of a value or an array (canonical quiet NaN)."""
    return minres_words(np.atleast_1d(np.asarray(x, dtype=f32)))


class Machine:
    """One Stage 1 engine: `slots` private regions of `slot_words` words, the constant region and the tables."""

    def __init__(self, slots: int, slot_words: int, const: np.ndarray, tables: list[np.ndarray], lat_add: int):
        self.mem = np.zeros((slots, slot_words), dtype=f32)
        self.const = np.asarray(const, dtype=f32)
        self.tables = [np.asarray(t, dtype=np.int64) for t in tables]
        self.lat_add = lat_add
        self.inq: deque = deque()
        self.outq: list = []

    def _space(self, o: Operand, slot: int) -> np.ndarray:
        return self.mem[slot] if o.space == "slot" else self.const

    def read(self, o: Operand, n: int, slot: int) -> np.ndarray:
        m = self._space(o, slot)
        if o.mode == "vec":
            return m[o.addr: o.addr + n].copy()
        if o.mode == "scalar":
            return np.full(n, m[o.addr], dtype=f32)
        return m[o.addr + self.tables[o.table][:n]].copy()

    def write(self, o: Operand, v: np.ndarray, slot: int) -> None:
        assert o.space == "slot", "constants are read-only"
        m = self.mem[slot]
        v = np.asarray(v, dtype=f32)
        if o.mode == "vec" or o.mode == "scalar":
            m[o.addr: o.addr + len(v)] = v
        else:
            m[o.addr + self.tables[o.table][: len(v)]] = v

    def step(self, i: Instr, slot: int) -> None:
        n, op = i.n, i.op
        if op == "IN":
            self.write(i.d, np.array([self.inq.popleft() for _ in range(n)], dtype=f32), slot)
            return
        a = self.read(i.a, n, slot)
        if op == "OUT":
            self.outq.extend(a.tolist())
            return
        with np.errstate(all="ignore"):
            if op in ("ADD", "SUB", "MUL", "DIV", "MIN", "MAX", "SELNEG"):
                b = self.read(i.b, n, slot)
            if op == "ADD":
                r = a + b
            elif op == "SUB":
                r = a - b
            elif op == "MUL":
                r = a * b
            elif op == "DIV":
                r = a / b
            elif op == "SQRT":
                r = np.sqrt(a)
            elif op == "MOV":
                r = a
            elif op == "MIN":
                r = np.where(np.isnan(a) | np.isnan(b), f32(np.nan), np.where(b < a, b, a))
            elif op == "MAX":
                r = np.where(np.isnan(a) | np.isnan(b), f32(np.nan), np.where(a < b, b, a))
            elif op == "SELNEG":
                r = np.where(np.isnan(a), f32(np.nan), np.where(b < 0, -a, INF))
            elif op == "ACC":
                r = np.array([acc(a, self.lat_add)], dtype=f32)
            elif op == "MINRED":
                if np.isnan(a).any():
                    r = np.array([np.nan], dtype=f32)
                else:
                    r = a[[int(np.argmin(a))]]   # first of equal values (+0 == -0)
            else:
                raise ValueError(op)
        self.write(i.d, np.asarray(r, dtype=f32), slot)

    def run(self, program: list[Instr], slot: int) -> None:
        for i in program:
            self.step(i, slot)
