"""Interior-point controllers for the closed loop of mpc_cores/closedloop.py (same interface: `async step(x, r) -> u0`),
both on channel 0 of the core, warm-started from the channel's previous iterate (the core's reset default):

  IpmModelController  the bit-exact golden model of the generated core (mpc_cores.ipm.core_model.IpmCoreModel,
                      from the design's config.json)
  IpmRtlController    the Verilator model of the generated core, through its AXI interfaces (inside cocotb, with
                      the kind's testbench driver IpmTB)

Both record `.words` per step in one layout: the answer words (u0 (m words), mu, ||r_0||) then the status word, so
the demo compares the two lists as they are. A multiplexed core (parallel multiplexed MPC): each step runs the
rounds of mpc_cores.ipm.mux_loop, the m copies of a round on channels 0 .. m - 1 together, and records every
answer of the step in channel order. `rtl_controller(dut, problem)` is the kind's entry for the closed-loop
testbench (mpc_cores.closedloop_tb, CoreKind.rtl_controller_fn).
"""
from __future__ import annotations

import numpy as np

from mpc_cores.closedloop import Controller
from mpc_cores.ipm.mux_loop import CoreMux, data, plan_of, run_step

CHANNEL = 0


def _u(ops, words, m: int) -> np.ndarray:
    """u0 as float values from the first m answer words"""
    return np.asarray(ops.to_float(ops.from_words(words[:m])), dtype=float)


class IpmModelController(Controller):
    """The golden model of the core the design generates (P = max(1, d.P): P = 0, eq. (15), is resolved by the
    generator and does not change the answers of one channel)."""
    name = "golden"

    def __init__(self, d, warm: bool = True):
        from mpc_cores.ipm.core_model import IpmCoreModel

        self.d = d
        self.model = IpmCoreModel(d.config(), max(1, d.P))
        self.m = d.problem.nu
        self.warm = warm
        self.words: list[list[int]] = []
        self.not_converged = 0       # answers flagged not converged or not finite
        self.mux = CoreMux(d.problem, None) if d.multiplexed else None

    async def _round(self, frames):
        moves = []
        for i, x, ss, F in frames:
            a = self.model.solve_copy(i, x, ss, F, warm=self.warm)
            self.not_converged += int(a.nonfinite or not a.converged)
            self.words[-1] += [int(w) for w in a.words] + [int(a.status)]
            moves.append(self.model.plan(a))
        return moves

    async def step(self, x, r):
        if self.mux:
            self.words.append([])
            if not self.warm:   # cold: no stored plan either, every step a first sample
                self.mux.plan = None
            return await run_step(self.mux, np.asarray(x, dtype=float), np.asarray(r, dtype=float), self._round)
        a = self.model.solve(CHANNEL, np.asarray(x, dtype=float), np.asarray(r, dtype=float), warm=self.warm)
        self.not_converged += int(a.nonfinite or not a.converged)
        self.words.append([int(w) for w in a.words] + [int(a.status)])
        return np.asarray(a.u, dtype=float)


class IpmRtlController(Controller):
    """The generated core in Verilator: one frame (id word, x, r) on channel 0 per step, its answer awaited."""
    name = "rtl"

    def __init__(self, tb, problem=None):
        self.tb = tb
        self.m = tb.m
        self.tag = 0
        self.words: list[list[int]] = []
        self.mux = CoreMux(problem, None) if tb.mux else None

    async def _round(self, frames):
        """the round's frames sent together (channels 0 .. m - 1), their answers awaited, in channel order"""
        tags = {}
        for i, x, ss, F in frames:
            self.tag = (self.tag + 1) & 0xFFFFFF
            tags[self.tag] = i
            await self.tb.send(i, self.tag, self.tb.model.mr.to_words(data(x, ss, F)))
        got = {}
        for _ in frames:
            ch, tag, words, status = await self.tb.recv()
            assert tags.get(tag) == ch and ch not in got, f"answer on channel {ch} tag {tag}: not one sent"
            got[ch] = (words, status)
        moves = []
        for i, *_ in frames:
            words, status = got[i]
            self.words[-1] += [int(w) for w in words] + [int(status)]
            moves.append(plan_of(self.tb.model.ops, words, self.tb.T))
        return moves

    async def step(self, x, r):
        if self.mux:
            self.words.append([])
            return await run_step(self.mux, np.asarray(x, dtype=float), np.asarray(r, dtype=float), self._round)
        self.tag = (self.tag + 1) & 0xFFFFFF
        await self.tb.send(CHANNEL, self.tag, self.tb.words(np.asarray(x, dtype=float), np.asarray(r, dtype=float)))
        ch, tag, words, status = await self.tb.recv()
        assert (ch, tag) == (CHANNEL, self.tag), \
            f"answer on channel {ch} tag {tag}, expected channel {CHANNEL} tag {self.tag}"
        self.words.append([int(w) for w in words] + [int(status)])
        return _u(self.tb.model.ops, words, self.m)


async def rtl_controller(dut, problem):
    """The closed-loop testbench's entry (CoreKind.rtl_controller_fn): the kind's testbench driver (IpmTB, named by
    the registry's string, so the product package does not import the testbenches), reset, and its controller."""
    from mpc_cores import registry
    from mpc_cores.kind import load

    tb = load(f"{registry.get('ipm').testbench}:IpmTB")(dut, seed=21)
    await tb.reset()
    return tb, IpmRtlController(tb, problem)
