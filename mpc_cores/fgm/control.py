"""The FGM core's controller of the closed loop (mpc_cores.closedloop): its bit-exact golden model."""
from __future__ import annotations

import numpy as np

from mpc_cores.closedloop import Controller
from mpc_cores.fgm.model import FgmFixed
from mpc_cores.fixed import quantize


class FixedController(Controller):
    """The bit-exact golden model: the words the core would send back."""
    name = "golden"

    def __init__(self, design, imax: int | None = None, warm: bool | None = None):
        self.d = design
        self.model = FgmFixed(design)
        self.imax = imax
        self.warm = warm
        self.words: list[list[int]] = []
        self.iterations: list[int] = []     # per step, the iterations run (fewer than Imax after the exit test)

    def w_words(self, x, r) -> np.ndarray:
        return quantize(np.concatenate([x, r]), self.d.b)

    async def step(self, x, r):
        res = self.model.solve(self.w_words(x, r), imax=self.imax, warm=self.warm)
        u = res.z[: self.d.nu]
        self.words.append([int(v) for v in u])
        self.iterations.append(res.iterations)
        return u / (1 << self.d.b)
