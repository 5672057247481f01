"""Interpreter of the Stage 1 instruction set (mpc_cores.ipm.isa): the bit-exact model of the Stage 1 engine in
its float format. binary32 runs on numpy float32 (memory words are float32 values; the RTL's words compare after
canonicalising NaN, words()); any other format e<E>m<M> runs on raw words (uint64) with the arithmetic of
mpc_cores.minres.model.ops_for (mpc_cores.float.vector), every computed NaN the canonical quiet NaN as in the RTL.

Compares (MIN, MAX, SELNEG, MINRED) are IEEE 754 orders on the operands' exact values, as float.FCompare: +0 and
-0 are equal, a NaN operand is unordered (every compare false); Stage1Alu then gives
  min(a, b) = b < a ? b : a       max(a, b) = a < b ? b : a       NaN if a or b is NaN
  selneg(a, b) = b < +0 ? -a (sign flipped) : +inf                NaN if a is NaN (a NaN b gives +inf)
  minred: the first element strictly below every earlier one      NaN if any element is NaN
The input stream (inq) holds values of the format's representation: float values in binary32 (rounded to
float32); in other formats float values (rounded to the format) or raw words (integers, kept as they are). The
output stream (outq) gets float32 values in binary32 and raw words otherwise (take(): the array, out_words():
the words with NaN canonical).
"""
from __future__ import annotations

from collections import deque

import numpy as np

from mpc_cores.float.model import Format
from mpc_cores.ipm.isa import Instr, Operand
from mpc_cores.minres.model import F32Ops, acc, ops_for
from mpc_cores.minres.model import words as minres_words

f32 = np.float32
INF = f32(np.inf)


def words(x) -> list[int]:
    """Raw binary32 words of a value or an array (canonical quiet NaN)."""
    return minres_words(np.atleast_1d(np.asarray(x, dtype=f32)))


class Machine:
    """One Stage 1 engine: `slots` private regions of `slot_words` words, the constant region (`const`: float
    values, rounded to the format) and the tables; `fmt` the float format (None: binary32); `ops` (optional) the
    arithmetic instead of ops_for(fmt), e.g. WordOps(binary32) to check the float32 path against raw words.
    `const_banks` (the multiplexed core): the constant region is that many banks of one layout, slot s reading bank
    s mod const_banks."""

    def __init__(self, slots: int, slot_words: int, const: np.ndarray, tables: list[np.ndarray], lat_add: int,
                 fmt: Format | None = None, ops=None, const_banks: int = 1):
        self.ops = ops or ops_for(fmt)
        self.fmt = self.ops.fmt
        self.binary32 = isinstance(self.ops, F32Ops)
        self.mem = self.ops.zeros((slots, slot_words))
        self.const = self.ops.value(np.asarray(const, dtype=f32) if self.binary32 else const)
        self.tables = [np.asarray(t, dtype=np.int64) for t in tables]
        self.lat_add = lat_add
        self.const_banks = int(const_banks)
        self.inq: deque = deque()
        self.outq: list = []
        self.nan = self.ops.value(np.nan)      # the canonical quiet NaN
        self.inf = self.ops.value(np.inf)

    # ---- representation
    def set_const_words(self, ws) -> None:
        """The constant region from raw words of the format (kept bit for bit, as the engine's ROM)."""
        self.const = self.ops.from_words(ws)

    def value(self, x):
        """float values rounded to the format, in the memory's representation."""
        return self.ops.value(x)

    def to_float(self, x) -> np.ndarray:
        """Values of memory words (float32 in binary32, float64 otherwise)."""
        return self.ops.to_float(np.asarray(x, dtype=self.mem.dtype))

    def words(self, x) -> list[int]:
        """Raw words of memory words (canonical quiet NaN)."""
        return self.ops.words(np.atleast_1d(np.asarray(x, dtype=self.mem.dtype)))

    def feed(self, values) -> None:
        """Values onto the input stream, rounded to the format."""
        self.inq.extend(self.ops.value(np.atleast_1d(np.asarray(values))).tolist())

    def take(self) -> np.ndarray:
        """The output stream so far (memory representation), emptied."""
        out = np.asarray(self.outq, dtype=self.mem.dtype)
        self.outq.clear()
        return out

    def out_words(self) -> list[int]:
        """The output stream so far as raw words of the format, emptied."""
        return self.words(self.take())

    def _in(self, items: list) -> np.ndarray:
        if self.binary32:
            return np.array(items, dtype=f32)
        v = np.asarray(items)
        return self.ops.value(v) if v.dtype.kind == "f" else self.ops.from_words(v)

    # ---- memory
    def _space(self, o: Operand, slot: int) -> np.ndarray:
        if o.space == "slot":
            return self.mem[slot]
        size = len(self.const) // self.const_banks
        bank = slot % self.const_banks
        return self.const[bank * size: (bank + 1) * size]

    def read(self, o: Operand, n: int, slot: int) -> np.ndarray:
        m = self._space(o, slot)
        if o.mode == "vec":
            return m[o.addr: o.addr + n].copy()
        if o.mode == "scalar":
            return np.full(n, m[o.addr], dtype=m.dtype)
        return m[o.addr + self.tables[o.table][:n]].copy()

    def write(self, o: Operand, v: np.ndarray, slot: int) -> None:
        assert o.space == "slot", "constants are read-only"
        m = self.mem[slot]
        v = np.asarray(v, dtype=m.dtype)
        if o.mode == "vec" or o.mode == "scalar":
            m[o.addr: o.addr + len(v)] = v
        else:
            m[o.addr + self.tables[o.table][: len(v)]] = v

    # ---- execution
    def step(self, i: Instr, slot: int) -> None:
        n, op, o = i.n, i.op, self.ops
        if op == "IN":
            self.write(i.d, self._in([self.inq.popleft() for _ in range(n)]), slot)
            return
        a = self.read(i.a, n, slot)
        if op == "OUT":
            self.outq.extend(a.tolist())
            return
        with np.errstate(all="ignore"):
            if op in ("ADD", "SUB", "MUL", "DIV", "MIN", "MAX", "SELNEG"):
                b = self.read(i.b, n, slot)
            if op in ("MIN", "MAX", "SELNEG", "MINRED", "MOV"):
                av = o.to_float(a)           # exact values: IEEE order, +0 == -0, NaN unordered
            if op in ("MIN", "MAX", "SELNEG"):
                bv = o.to_float(b)
            if op == "ADD":
                r = o.add(a, b)
            elif op == "SUB":
                r = o.sub(a, b)
            elif op == "MUL":
                r = o.mul(a, b)
            elif op == "DIV":
                r = o.div(a, b)
            elif op == "SQRT":
                r = o.sqrt(a)
            elif op == "MOV":
                # binary32 keeps a NaN's bits (words() canonicalises them); raw words get the canonical NaN
                r = a if self.binary32 else np.where(np.isnan(av), self.nan, a)
            elif op == "MIN":
                r = np.where(np.isnan(av) | np.isnan(bv), self.nan, np.where(bv < av, b, a))
            elif op == "MAX":
                r = np.where(np.isnan(av) | np.isnan(bv), self.nan, np.where(av < bv, b, a))
            elif op == "SELNEG":
                r = np.where(np.isnan(av), self.nan, np.where(bv < 0, o.neg(a), self.inf))
            elif op == "ACC":
                r = np.array([acc(a, self.lat_add, o)], dtype=self.mem.dtype)
            elif op == "MINRED":
                if np.isnan(av).any():
                    r = np.array([self.nan], dtype=self.mem.dtype)
                else:
                    r = a[[int(np.argmin(av))]]   # first of equal values (+0 == -0)
            else:
                raise ValueError(op)
        self.write(i.d, np.asarray(r, dtype=self.mem.dtype), slot)

    def run(self, program: list[Instr], slot: int) -> None:
        for i in program:
            self.step(i, slot)
