"""Random configurations of the FGM core for `make soak` (mpc_cores.soak): input-constrained problems up to
n = N nu = 24 variables, every P from 1 to n, frac_bits, pipeline latencies, roundings, warm start and full output."""
from __future__ import annotations

from mpc_cores.soak.space import (Config, SoakSpace, fixed_point_solve_cycles, pick, problems, random_spec,
                                  target_latency)

N_MAX = 24   # variables n = N nu: the simulated cycles per solve grow with n / P


def draw(rng) -> Config:
    nx, nu = int(rng.integers(1, 7)), int(rng.integers(1, 4))
    N = min(int(rng.integers(2, 11)), N_MAX // nu)
    n = N * nu
    spec = random_spec(rng, nx, nu, N, ny=int(rng.integers(0, min(nx, nu) + 1)))
    P = pick(rng, [1, 1, 2, 3, 4, 5, 8, n])
    design = dict(P=min(P, n), frac_bits=int(rng.integers(8, 19)), lat_add=int(rng.integers(0, 4)),
                  **target_latency(rng, int(rng.integers(0, 4))),
                  rounding=pick(rng, ["truncate", "nearest"]),
                  iterations=int(rng.integers(3, 31)), warm_start=bool(rng.random() < 0.8),
                  output_all=bool(rng.random() < 0.3),
                  problems=problems(rng))
    # the exit test in half the one-problem designs, EXIT_TOL 2^-k of u (bitexact_random also writes others);
    # drawn last, so that a configuration seed keeps the design it had before the test was drawn
    b = design["frac_bits"]
    if design["problems"] == 1 and rng.random() < 0.5:
        design.update(early_exit=True, exit_tol=2.0 ** -int(rng.integers(b // 2, b)))
    return Config(spec, design)

SOAK = SoakSpace(
    draw=draw, test="bitexact_random", count_knob="CORE_RANDOM", measured="cases",
    cycles_per_solve=fixed_point_solve_cycles, solves_per_config=250,
    space=("model: nx in [1, 6], nu in [1, 3], N in [2, 10] with n = N nu <= 24; A random, spectral radius in "
           "[0.4, 0.98] or [1.02, 1.2] (even odds); B random; Q, R random diagonals",
           "constraints: input box (random per input), box of accepted states, 0 to min(nx, nu) tracked states",
           "design: P in {1, 2, 3, 4, 5, 8, n} (at most n), frac_bits in [8, 18], lat_add in [0, 3], target generic "
           "(50 %, lat_mul in [0, 3]), ecp5 or xilinx7 (lat_mul the target's minimum or in [4, 6]), "
           "rounding truncate or nearest, Imax in [3, 30], warm start (80 %), full output (30 %), K_p = 1 (60 %) or "
           "in [2, 4] problems interleaved; the exit test in half the one-problem designs, EXIT_TOL 2^-k with k in "
           "[b / 2, b - 1]",
           "solves (verif/tb.py bitexact_random): random states, 5 % of words outside the box, random warm or cold "
           "start and Imax, random idle and backpressure on both streams; interleaving cores: batches of up to "
           "2 K_p frames for random problem ids, all in flight"),
)
