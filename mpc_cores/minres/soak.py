"""Random configurations of the MINRES core for `make soak` (mpc_cores.soak): small KKT systems (N up to about
60), P from eq. (15) or small, Imax, adder and multiplier latencies, binary32 and e8m17, the interior-point form."""
from __future__ import annotations

from mpc_cores.soak.space import Config, SoakSpace, pick, random_spec


def draw(rng) -> Config:
    nx, nu, T = int(rng.integers(1, 4)), int(rng.integers(1, 3)), int(rng.integers(2, 6))
    spec = random_spec(rng, nx, nu, T)
    return Config(spec, dict(P=pick(rng, [0, 0, 1, 2, 3, 4]), iterations=int(rng.integers(3, 13)),
                             lat_add=int(rng.integers(1, 5)), lat_mul=int(rng.integers(1, 5)),
                             format=pick(rng, ["binary32", "e8m17"]), warm=bool(rng.random() < 0.3)))


def cycles_per_solve(core: dict) -> int:
    """A batch (one problem at least) at twice the default Imax, with the flush timeout and paused streams."""
    return core["batch_cycles_imax0"] + 2 * core["iterations"] * core["cycles_per_iteration"] + \
        core["flush_cycles"] + 4 * (core["frame_words"] + core["out_words"])


SOAK = SoakSpace(
    draw=draw, test="bitexact_random", count_knob="CORE_RANDOM", measured="cases",
    cycles_per_solve=cycles_per_solve, solves_per_config=400,
    space=("model: nx in [1, 3], nu in [1, 2], T in [2, 5]; A random, spectral radius in [0.4, 0.98] or "
           "[1.02, 1.2] (even odds); B random; Q, R random diagonals (the KKT matrix's constant part)",
           "design: P from eq. (15) (1 in 3) or in [1, 4], Imax in [3, 12], lat_add and lat_mul in [1, 4], format "
           "binary32 or e8m17, the interior-point core's warm form (30 %)",
           "solves (verif/minres/tb.py bitexact_random): random interior-point weights and right-hand sides (and "
           "equilibration, warm start), batches of 1, P/2, P or 2P problems, random Imax, random idle and "
           "backpressure on both streams"),
)
