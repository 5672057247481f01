"""The golden model of a generated interior-point core, from its config.json alone: the Stage 1 programs it was
built with on the interpreter (mpc_cores.ipm.stage1_config.machine, 2P slots) and its MINRES in the warm form
(MinresCoreModel.solve_warm), in the core's order: per sample sample, cold or warm, I_NW times (linearise, MINRES,
update), output. The answer is what the core streams: u0 (m words), mu, with CTRL.OUT_ALL the whole iterate z (N
words, deviations from the steady state) and the steady state (x_s, u_s) (n + m words), then ||r_0|| of the last
Newton system and the status word (bit 0 non-finite, bit 1 not converged, bits 31:16 the Newton iterations).

Multiplexed (config `multiplexed`): channel c solves input c mod `inputs` (its Stage 1 constant bank and MINRES
table); `solve_copy` sends x^, (x_s, u_s,i) and F, and the answer carries the T planned moves after u0 and mu."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mpc_cores.ipm import stage1_config
from mpc_cores.ipm.mux_loop import data, plan_of
from mpc_cores.minres.model import MinresCoreModel


@dataclass
class Answer:
    words: list          # u0 (m), mu, (OUT_ALL: z (N), x_s (n), u_s (m)), ||r_0|| as raw words of the format
    status: int          # the status word
    u: np.ndarray        # u0 as float values

    @property
    def nonfinite(self) -> bool:
        return bool(self.status & 1)

    @property
    def converged(self) -> bool:
        return not self.status & 2


class IpmCoreModel:
    """The model of the core of config.json `cfg`; P its MINRES batch size (2P channels; None: all 64 channels the
    id word can name, for a configuration whose P the generator chooses)."""

    def __init__(self, cfg: dict, P: int | None = None):
        self.cfg = cfg
        self.n, self.m, self.ny = cfg["n"], cfg["m"], cfg["ny"]
        self.i_nw = cfg["i_nw"]
        self.i_mr = cfg["minres"]["iterations"]
        self.mu_tol, self.res_tol = cfg["mu_tol"], cfg["res_tol"]
        self.slots = 2 * P if P else 64
        self.machine = stage1_config.machine(dict(cfg["stage1"], slots=self.slots))
        self.progs = stage1_config.programs(cfg["stage1"])
        self.mr = MinresCoreModel.from_config(cfg["minres"])
        self.ops = self.machine.ops
        self.N, self.npr = self.mr.N, len(self.mr.primal)
        self.W = self.mr.fmt.width
        self.started = [False] * self.slots
        self.multiplexed = bool(cfg.get("multiplexed", False))
        self.T = cfg["minres"]["T"]

    def reset(self) -> None:
        self.__init__(self.cfg, self.slots // 2 if self.slots < 64 else None)

    def _run(self, name: str, slot: int) -> None:
        self.machine.run(self.progs[name], slot)

    def _le(self, w: int, tol: int) -> bool:
        """the core's compare: a non-negative word at most tol (-0 passes, NaN fails)"""
        sign = 1 << (self.W - 1)
        return w == sign or (not w & sign and w <= tol)

    def solve(self, slot: int, x, r=None, warm: bool = True, x_words: list | None = None,
              out_all: bool = False) -> Answer:
        """One sample on channel `slot`: x, r as float values (rounded to the format) or x_words as the raw words
        sent (x then r); `out_all`: the answer carries z and the steady state (CTRL.OUT_ALL)."""
        M, o = self.machine, self.ops
        data = x_words if x_words is not None else self.mr.to_words(
            np.concatenate([np.atleast_1d(x), np.atleast_1d(r if r is not None else [])]))
        vals = o.from_words(data)
        bad = not o.finite(vals)
        M.inq.extend(np.atleast_1d(vals).tolist())
        self._run("sample", slot)
        self._run("warm" if warm and self.started[slot] else "cold", slot)
        self.started[slot] = True
        res = o.zero
        for _ in range(self.i_nw):
            self._run("linearise", slot)
            out = M.take()
            npr, N = self.npr, self.N
            diag, d, bh, z0 = out[:npr], out[npr:npr + N], out[npr + N:npr + 2 * N], out[npr + 2 * N:]
            r_, res = self.mr.solve_warm(*(o.to_float(v) for v in (diag, d, bh, z0)), self.i_mr,
                                         table=self.mr.table_of(slot))
            bad = bad or r_.flag
            M.inq.extend(np.atleast_1d(o.from_words(r_.words)).tolist())
            self._run("receive", slot)
            self._run("update", slot)
        self._run("output_all" if out_all else "output", slot)
        out = M.take()
        words = M.words(out) + o.words(np.atleast_1d(res))
        bad = bad or not o.finite(out)
        conv = self._le(words[self.m], self.mu_tol) and self._le(words[-1], self.res_tol)
        if bad:
            self.started[slot] = False
        status = (self.i_nw << 16) | (0 if conv else 2) | int(bad)
        return Answer(words, status, o.to_float(out[: self.m]))

    def solve_copy(self, slot: int, x, ss, F, warm: bool = True) -> Answer:
        """Multiplexed: one copy on channel `slot` (input slot mod inputs): x^ (n), the steady state (x_s, u_s,i)
        (n + 1) and the known term F (T x n, stage by stage) as float values."""
        assert self.multiplexed, "solve_copy needs a multiplexed core"
        return self.solve(slot, None, warm=warm, x_words=self.mr.to_words(data(x, ss, F)))

    def plan(self, a: Answer) -> np.ndarray:
        """Multiplexed: the T planned moves of an answer (deviations from u_s,i), float values"""
        return plan_of(self.ops, a.words, self.T)
