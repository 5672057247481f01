"""What the block benches share: the blocks of the model (BLOCKS_OUT: the folder of hw.json and blocks_top.sv), a
block's ports by name, the clock and resets, and the cycle discipline.

Cycle discipline: a bench drives a block's inputs for cycle t just after the falling edge (the registers hold the
values the rising edge of t - 1 gave them), then samples every output in ReadOnly (combinational outputs see the
new inputs); the rising edge that ends cycle t takes them. An output the contract calls registered is sampled
both before and after the inputs change (`Block.regs`): the two must agree, so no combinational path reaches it.
"""
from __future__ import annotations

import json
import os
import random
from pathlib import Path

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import FallingEdge, ReadOnly

from verif.blocks import TOP, ports

PERIOD_NS = 10


def out_dir() -> Path:
    return Path(os.environ["BLOCKS_OUT"])


def params(kind: str) -> list[dict]:
    """The parameterisations of block `kind` in the model."""
    hw = json.loads((out_dir() / "hw.json").read_text())
    return [b for b in hw["blocks"] if b["block"] == kind]


def rng(name: str) -> random.Random:
    """A seeded generator per block (BLOCKS_SEED, default 1)."""
    return random.Random(f"{os.environ.get('BLOCKS_SEED', '1')}:{name}")


def signed(v: int, w: int) -> int:
    v &= (1 << w) - 1
    return v - (1 << w) if v >> (w - 1) else v


class Block:
    """Block `name`'s ports of blocks_top: `b.enq_valid` is the handle of <name>_io_enq_valid."""

    def __init__(self, dut, p: dict):
        self.dut, self.p, self.name = dut, p, p["name"]
        self.reset_h = getattr(dut, f"{self.name}_reset")
        self._h = {}

    def h(self, port: str):
        if port not in self._h:
            self._h[port] = getattr(self.dut, f"{self.name}_io_{port}")
        return self._h[port]

    def __getattr__(self, port: str):
        if port.startswith("_") or port in ("dut", "p", "name", "reset_h"):
            raise AttributeError(port)
        return self.h(port)

    def set(self, **vals):
        for k, v in vals.items():
            self.h(k).value = int(v)

    def get(self, port: str) -> int:
        return int(self.h(port).value)

    def regs(self, names) -> dict[str, int]:
        return {n: self.get(n) for n in names}

    def park(self):
        """Every input of the block at 0 and the block in reset: a bench leaves each block so when it is done,
        so that it does not run on (and trip its assertions) while the next block is tested."""
        for p in _top_inputs():
            if p.startswith(f"{self.name}_io_"):
                getattr(self.dut, p).value = 0
        self.reset_h.value = 1

    async def reset(self, cycles: int = 2):
        """Reset the block alone (its inputs left as they are)."""
        self.reset_h.value = 1
        for _ in range(cycles):
            await FallingEdge(self.dut.clock)
        self.reset_h.value = 0


_INPUTS: list[str] | None = None


def _top_inputs() -> list[str]:
    global _INPUTS
    if _INPUTS is None:
        _INPUTS = [p for d, _, p in ports((out_dir() / f"{TOP}.sv").read_text(), TOP) if d == "input" and p != "clock"]
    return _INPUTS


async def begin(dut):
    """Start the clock, every input of every block at 0 and every block in reset for two cycles; returns at the
    falling edge of the first cycle out of reset (the drive point of cycle 0)."""
    for p in _top_inputs():  # before the first edge: a block's assertions hold from its reset on
        getattr(dut, p).value = 1 if p.endswith("_reset") else 0
    cocotb.start_soon(Clock(dut.clock, PERIOD_NS, unit="ns").start())
    for _ in range(3):
        await FallingEdge(dut.clock)
    for p in _top_inputs():
        if p.endswith("_reset"):
            getattr(dut, p).value = 0


async def settle():
    """The outputs of this cycle, with the inputs just driven."""
    await ReadOnly()


async def next_cycle(dut):
    """The drive point of the next cycle."""
    await FallingEdge(dut.clock)


async def each(dut, kind: str, bench):
    """`begin`, then `bench(dut, p)` for every parameterisation p of block `kind`, each from a fresh reset (it
    starts at the drive point of the first cycle out of reset) and parked after."""
    await begin(dut)
    for p in params(kind):
        await Block(dut, p).reset(2)
        await bench(dut, p)
        Block(dut, p).park()
        await next_cycle(dut)


def reset_cycles(r, cycles: int, n: int = 3) -> set[int]:
    """n resets of two cycles at random points of a run of `cycles` (the block in whatever state it is in): the
    cycles with reset high."""
    starts = sorted(r.sample(range(50, cycles - 50, 5), n))
    return {s + i for s in starts for i in range(2)}


def densities(r, t: int, now: tuple[float, float], cycles: int, segment: int, choices: tuple, ready: tuple | None = None,
              bursts: bool = True) -> tuple[float, float]:
    """The (valid, ready) densities of cycle t of a stream bench: a new random pair every `segment` cycles (ready
    from `ready`, default `choices`), every third segment at full rate when `bursts`; valid off and ready on from
    `cycles` on (the drain)."""
    pv, pr = now
    if t % segment == 0:
        pv, pr = r.choice(choices), r.choice(choices if ready is None else ready)
        if bursts and t % (3 * segment) == 0:
            pv = pr = 1.0
    return (0.0, 1.0) if t >= cycles else (pv, pr)


async def reset_cycle(b, dut, model: list, **idle) -> None:
    """A cycle with the block's reset high: its inputs `idle`, the reference model emptied."""
    b.reset_h.value = 1
    b.set(**idle)
    model.clear()
    await next_cycle(dut)
