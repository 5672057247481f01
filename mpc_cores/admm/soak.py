"""Random configurations of the ADMM core for `make soak` (mpc_cores.soak): input boxes and input-rate limits,
soft and hard state boxes in any combination, P, frac_bits, pipeline latencies, roundings, rho."""
from __future__ import annotations

from mpc_cores.soak.space import (Config, SoakSpace, fixed_point_solve_cycles, pick, problems, random_spec,
                                  target_latency)


def _draw(rng) -> Config:
    nx, nu, N = int(rng.integers(1, 5)), int(rng.integers(1, 3)), int(rng.integers(2, 6))
    soft = int(rng.integers(0, min(nx, 2) + 1)) if rng.random() < 0.5 else 0
    hard = int(rng.integers(1, nx - soft + 1)) if nx > soft and rng.random() < 0.4 else 0
    spec = random_spec(rng, nx, nu, N, ny=int(rng.integers(0, min(nx, nu) + 1)), rate=True,
                       soft=soft, hard=hard)
    return Config(spec, dict(P=pick(rng, [1, 2, 3, 4, 5, 6]), frac_bits=int(rng.integers(14, 21)),
                             lat_add=int(rng.integers(0, 4)), **target_latency(rng, int(rng.integers(0, 4))),
                             rounding=pick(rng, ["truncate", "nearest"]), iterations=int(rng.integers(10, 41)),
                             rho=pick(rng, [1.0, 2.0, 4.0]), warm_start=bool(rng.random() < 0.8),
                             output_all=bool(rng.random() < 0.3), problems=problems(rng)))


def draw(rng) -> Config:
    """_draw, with the accelerated method (momentum lanes, restart) in half the one-problem designs, and the row unit
    time-multiplexed (lanes in [2, 12]: a row in chunks) in 40 % of the one-unit, one-problem designs"""
    c = _draw(rng)
    one = c.design.get("problems", 1) == 1
    d = dict(c.design, accelerated=True) if one and rng.random() < 0.5 else dict(c.design)
    if one and d["P"] == 1 and rng.random() < 0.4:
        d["lanes"] = int(rng.integers(2, 13))
    return Config(c.spec, d)


SOAK = SoakSpace(
    draw=draw, test="bitexact_random", count_knob="CORE_RANDOM", measured="cases",
    cycles_per_solve=fixed_point_solve_cycles, solves_per_config=400,
    space=("model: nx in [1, 4], nu in [1, 2], N in [2, 5]; A random, spectral radius in [0.4, 0.98] or "
           "[1.02, 1.2] (even odds); B random; Q, R random diagonals",
           "constraints: input box; input-rate limit (the ADMM form needs one) in [0.1, 0.5], weight in {0.01, "
           "0.05, 0.1}; 0 to 2 soft state boxes (50 %) with sigma1 in {4, 8, 16}, sigma2 in {1, 2}; hard boxes on 1 "
           "to the remaining states (40 %); box of accepted states; 0 to min(nx, nu) tracked states",
           "design: P in [1, 6], frac_bits in [14, 20], lat_add in [0, 3], target generic (50 %, lat_mul in "
           "[0, 3]), ecp5 or xilinx7 (lat_mul the target's minimum or in [4, 6]), rounding truncate or nearest, Imax in [10, 40], rho in {1, 2, 4}, warm start (80 %), full output (30 %), K_p = 1 (60 %) or in [2, 4] problems "
           "interleaved; accelerated (momentum lanes, restart) in half the one-problem designs; lanes in [2, 12] (a row "
           "in chunks) in 40 % of the one-unit, one-problem designs",
           "solves (verif/tb.py bitexact_random): random parameters, 5 % of words outside the box, random warm or "
           "cold start and Imax, random idle and backpressure on both streams; interleaving cores: batches of up "
           "to 2 K_p frames for random problem ids, all in flight"),
)



def _with_method(method: str) -> SoakSpace:
    """ADMM's random space with the design's method set"""
    def draw_m(rng) -> Config:
        c = draw(rng)
        d = dict(c.design, method=method)
        if method == "ama":
            d.pop("rho")               # AMA's step comes from the problem (below 2 mu; accelerated: below mu)
        return Config(c.spec, d)
    return SoakSpace(draw=draw_m, test=SOAK.test, count_knob=SOAK.count_knob, measured=SOAK.measured,
                     cycles_per_solve=SOAK.cycles_per_solve, solves_per_config=SOAK.solves_per_config,
                     space=SOAK.space[:2] + (SOAK.space[2] + f"; method {method}",) + SOAK.space[3:])


AMA_SOAK = _with_method("ama")
VUCONDAT_SOAK = _with_method("vucondat")
