"""ADMM controllers for the closed loop of mpc_cores/closedloop.py (same interface: `async step(x, r) -> u`).

The ADMM core solves the sparse QP (8) of 002. With input-rate augmentation (a spec with input_rate; the design's
and the QP's `rate`) its parameter is w = (x, u_prev, r) and the first nu words of the z it returns are du_0, so
every controller here keeps the previously applied input u_prev itself (zero before the first step) and applies
u = clip(u_prev + du_0, umin, umax), which meets the rate and input limits even when z is not converged. Without
it the parameter is w = (x, r), z starts with u_0 and the controller applies clip(u_0, umin, umax)
(mpc_cores.admm.model.applied_input).

  AdmmOsqpController   float64, the soft-constrained QP (8) solved to optimality by OSQP (the reference)
  AdmmFixedController  the bit-exact golden model of the core (mpc_cores.admm.model.AdmmFixed), warm-started
  AdmmFloatController  Algorithm 2 of 002 in float64 with the same rho_j, Imax and warm start

The cost of a run is mpc_cores.closedloop.loop_stage_cost summed over the steps: tracking, du weight and the soft
penalty on the plant's actual violation of the soft state limits.

An RTL controller reuses AdmmFixedController: it overrides `solve_words` (send the words of `w_words`, return the
nu words received) and inherits the rest, so both record `.words` the same way.
"""
from __future__ import annotations

import numpy as np

from mpc_cores.admm.design import AdmmDesign
from mpc_cores.admm.model import AdmmFixed, AdmmFloat
from mpc_cores.admm.problem import AdmmQP, build_admm_qp, solve_soft_qp_osqp
from mpc_cores.closedloop import Controller, Trajectory, reference_schedule
from mpc_cores.fixed import quantize
from mpc_cores.problem import MpcProblem


def admm_references(problem: MpcProblem, steps: int, hold: int, seed: int = 0) -> np.ndarray:
    """Piecewise-constant references uniform in 80 % of the reference box, a new one every `hold` steps, with no
    holdability filter: on masses_rate_soft |r| up to 0.8 exceeds the soft position limits 0.5, so the soft
    limits, the input box and the rate limit are all active for long stretches (Fig. 5 of 002)."""
    return reference_schedule(problem, steps, hold, seed, holdable=0.0)


def parameters(traj: Trajectory, rate: bool = True) -> np.ndarray:
    """The parameters the controller was given along a run: w_k = (x_k, u_{k-1}, r_k) (u_{-1} = 0) in the
    rate-augmented form, (x_k, r_k) otherwise."""
    if not rate:
        return np.hstack([traj.x[:-1], traj.r])
    up = np.vstack([np.zeros((1, traj.u.shape[1])), traj.u[:-1]])
    return np.hstack([traj.x[:-1], up, traj.r])


def rate_and_box_ok(problem: MpcProblem, traj: Trajectory, tol: float = 1e-9) -> bool:
    """Every applied input inside the input box and within the rate limit of the previous one."""
    up = np.vstack([np.zeros((1, problem.nu)), traj.u[:-1]])
    du = traj.u - up
    r = problem.input_rate
    return bool(np.all(traj.u <= problem.umax + tol) and np.all(traj.u >= problem.umin - tol)
                and (r is None or (np.all(du <= r.dumax + tol) and np.all(du >= r.dumin - tol))))


class _AdmmController(Controller):
    """rate: the QP's form (rate-augmented: w = (x, u_prev, r), du_0 out; else w = (x, r), u_0 out)."""

    def __init__(self, problem: MpcProblem, nu: int, rate: bool = True):
        self.problem = problem
        self.nu = nu
        self.rate = bool(rate)
        self.u_prev = np.zeros(nu)

    def reset(self) -> None:
        self.u_prev = np.zeros(self.nu)

    def _w(self, x, r) -> np.ndarray:
        """the parameter of the form (AdmmQP.w)"""
        return np.concatenate([x, self.u_prev, r] if self.rate else [x, r])

    def _apply(self, v0: np.ndarray) -> np.ndarray:
        # = mpc_cores.admm.model.applied_input(d, v0, u_prev): v0 is du_0 (rate form) or u_0
        p = self.problem
        v0 = np.asarray(v0, dtype=float)[: self.nu]
        u = np.clip(self.u_prev + v0 if self.rate else v0, p.umin, p.umax)
        self.u_prev = u
        return u


class AdmmOsqpController(_AdmmController):
    """Double precision: the soft-constrained QP (8) solved to optimality by OSQP."""
    name = "osqp"

    def __init__(self, problem: MpcProblem | AdmmQP, eps: float = 1e-10):
        self.qp = problem if isinstance(problem, AdmmQP) else build_admm_qp(problem)
        super().__init__(self.qp.problem, self.qp.nu, self.qp.rate)
        self.eps = eps

    async def step(self, x, r):
        return self._apply(solve_soft_qp_osqp(self.qp, self._w(x, r), eps=self.eps))


class AdmmFixedController(_AdmmController):
    """The bit-exact golden model of the core: the du_0 (or u_0) words it would send back, recorded in `.words`.
    imax / warm override the design's iterations / warm_start (the core's IMAX register and CTRL.WARM_START)."""
    name = "golden"

    def __init__(self, design: AdmmDesign, imax: int | None = None, warm: bool | None = None):
        super().__init__(design.problem, design.nu, design.rate)
        self.d = design
        self.b = design.b
        self.model = AdmmFixed(design)
        self.imax = imax
        self.warm = warm
        self.words: list[list[int]] = []
        self.overflow_steps = 0      # solves in which a datapath word saturated
        self.sat_steps = 0           # solves in which a parameter word was outside the accepted box

    def w_words(self, x, u_prev, r) -> np.ndarray:
        """The nw parameter words streamed to the core with b fraction bits: w = (x, u_prev, r) in the
        rate-augmented form, (x, r) otherwise."""
        return quantize(np.concatenate([x, u_prev, r] if self.rate else [x, r]), self.b)

    async def solve_words(self, w: np.ndarray) -> np.ndarray:
        """The first nu words of z (du_0, or u_0) for parameter words w; the golden model here, the core in an RTL
        loop."""
        res = self.model.solve(w, imax=self.imax, warm=self.warm)
        self.overflow_steps += res.overflow
        self.sat_steps += res.sat
        return res.z[: self.nu]

    async def step(self, x, r):
        v0 = np.asarray(await self.solve_words(self.w_words(x, self.u_prev, r)), dtype=np.int64)[: self.nu]
        self.words.append([int(v) for v in v0])
        return self._apply(v0 / float(1 << self.b))

    def reset(self) -> None:
        super().reset()
        self.model.reset()


async def rtl_controller(dut, problem: MpcProblem):
    """The closed-loop testbench's entry (CoreKind.rtl_controller_fn) for the ADMM datapath: the fixed-point cores'
    driver (mpc_cores.driver.TB), reset, and the RTL controller."""
    from mpc_cores.driver import TB

    tb = TB(dut, seed=21)
    await tb.reset()
    return tb, AdmmRtlController(tb, problem)


class AdmmRtlController(AdmmFixedController):
    """The generated ADMM core in Verilator, driven by the cocotb testbench `tb` (verif.tb.TB): the words of
    `w_words` go out on s_axis, du_0 (or u_0: core.json's `rate`) comes back on m_axis; the rest is
    AdmmFixedController's."""
    name = "rtl"

    def __init__(self, tb, problem: MpcProblem):
        # core.json written before the plain form existed: rate-augmented
        _AdmmController.__init__(self, problem, tb.nu, bool(tb.core.get("rate", True)))
        self.tb = tb
        self.b = int(tb.core["frac_bits"])
        self.imax = self.warm = None
        self.words = []
        self.overflow_steps = self.sat_steps = 0

    async def solve_words(self, w: np.ndarray) -> np.ndarray:
        await self.tb.send(w)
        return np.array((await self.tb.recv())[: self.nu], dtype=np.int64)

    def reset(self) -> None:
        _AdmmController.reset(self)


class AdmmFloatController(_AdmmController):
    """Algorithm 2 of 002 in float64 with the design's rho_j, on the exact data (quantised=False) or on the
    quantised data of the core (quantised=True)."""
    name = "float64"

    def __init__(self, design: AdmmDesign, imax: int | None = None, warm: bool | None = None,
                 quantised: bool = False):
        super().__init__(design.problem, design.nu, design.rate)
        self.d = design
        self.model = AdmmFloat(design, quantised=quantised)
        self.imax = imax
        self.warm = warm

    async def step(self, x, r):
        z, _, _ = self.model.solve(self._w(x, r), imax=self.imax, warm=self.warm)
        return self._apply(z[: self.nu])

    def reset(self) -> None:
        super().reset()
        self.model.prev = None


__all__ = ["AdmmFixedController", "AdmmFloatController", "AdmmRtlController", "AdmmOsqpController", "admm_references", "parameters",
           "rate_and_box_ok"]
