"""Random configurations of the interior-point core for `make soak` (mpc_cores.soak): tiny problems (a solve
simulates thousands of cycles), input and state boxes, tracking, P, I_NW, I_MR, latencies, binary32 and e8m17,
multiplexed (two inputs, one in two)."""
from __future__ import annotations

from mpc_cores.soak.space import Config, SoakSpace, pick, random_spec


def draw(rng) -> Config:
    nx, nu, T = int(rng.integers(1, 3)), int(rng.integers(1, 3)), int(rng.integers(2, 4))
    spec = random_spec(rng, nx, nu, T, ny=int(rng.integers(0, 2)),
                       hard=int(rng.integers(1, nx + 1)) if rng.random() < 0.5 else 0)
    mux = {"multiplexed": True} if nu == 2 and rng.random() < 0.5 else {}
    return Config(spec, dict(P=pick(rng, [0, 1, 2, 3]), newton=int(rng.integers(2, 5)),
                             iterations=int(rng.integers(3, 9)), lat_add=int(rng.integers(1, 5)),
                             lat_mul=int(rng.integers(1, 4)), format=pick(rng, ["binary32", "e8m17"]), **mux))


def cycles_per_solve(core: dict) -> int:
    """A round (its latency, 2P problems from cold starts) at the testbench's largest I_NW (4) and I_MR (9), over the
    answers of a round on average (1.5 P), with the full answer's words on paused streams."""
    scale = max(1.0, 4 / core["i_nw"]) * max(1.0, 10 / (core["iterations"] + 1))
    return int(scale * core["latency_cycles_cold"] / (1.5 * core["P"])) + \
        4 * (core["N"] + core["in_words"] + core["out_words"])


SOAK = SoakSpace(
    draw=draw, test="bitexact_inflight", count_knob="CORE_ROUNDS", measured="answers",
    cycles_per_solve=cycles_per_solve, solves_per_config=625,
    per_count=lambda core: 1.5 * core["P"],   # answers per round: 2P, one round in three a random subset
    space=("model: nx in [1, 2], nu in [1, 2], T in [2, 3]; A random, spectral radius in [0.4, 0.98] or "
           "[1.02, 1.2] (even odds); B random; Q, R random diagonals",
           "constraints: input box; hard boxes on 1 to nx states (50 %); box of accepted states; 0 or 1 tracked "
           "state",
           "design: P from eq. (15) (1 in 4) or in [1, 3], I_NW in [2, 4], I_MR in [3, 8], lat_add in [1, 4], "
           "lat_mul in [1, 3], format binary32 or e8m17; with two inputs, multiplexed (one input's problem per "
           "channel) in one draw of two",
           "solves (verif/ipm/tb.py bitexact_inflight): rounds of samples on the 2P channels in random order (2P "
           "problems in flight, one round in three on a random subset), warm starts per channel, random I_NW in "
           "[1, 4] and I_MR in [1, 9] from the third round on, one round with the whole iterate (CTRL.OUT_ALL), "
           "random idle and backpressure on both streams"),
)
