"""Random configurations of the DGP core for `make soak` (mpc_cores.soak): input boxes and hard state boxes, the
plain and the accelerated form, row units and lanes, pipeline latencies, targets and the accuracy the words are chosen for."""
from __future__ import annotations

from mpc_cores.soak.space import Config, SoakSpace, _box, pick, random_spec, target_latency


def draw(rng) -> Config:
    nx, nu, N = int(rng.integers(1, 4)), int(rng.integers(1, 3)), int(rng.integers(2, 6))
    hard = int(rng.integers(1, nx + 1)) if rng.random() < 0.7 else 0
    spec = random_spec(rng, nx, nu, N, ny=int(rng.integers(0, min(nx, nu) + 1)), hard=hard)
    # a small box of accepted states, so that the state constraints can be met from most of them (the design
    # flow refuses a box with a state from which they cannot)
    spec["states"] = _box(rng, nx, 0.1, 0.5)
    accelerated = bool(rng.random() < 0.6)
    ny = len(spec.get("tracking", {}).get("outputs", []))
    longest = max(N * nu + N * hard, nx + ny)          # the longest matrix row: lanes beyond it are refused
    eps = pick(rng, [1e-2, 3e-3, 1e-3])
    design = dict(lanes=int(rng.integers(1, min(6, longest) + 1)), accelerated=accelerated, eps_g=eps, eps_V=eps,
                  lat_add=int(rng.integers(0, 4)), **target_latency(rng, int(rng.integers(0, 4))),
                  iterations=int(rng.integers(10, 61)) if accelerated else int(rng.integers(40, 301)),
                  warm_start=bool(rng.random() < 0.8), output_all=bool(rng.random() < 0.3))
    # row units last, so that the draws before them stay those of the configurations found before P existed
    design["P"] = min(int(rng.integers(1, 5)), N * nu)
    # the shifted warm start (accelerated form) last, for the same reason
    design["warm_shift"] = bool(rng.random() < 0.5) and accelerated
    # the dual in block RAM (accelerated form) last; with the shifted warm start only where each stage's rows are a
    # multiple of P (a row's shift source in the same unit), the rule design_dgp enforces
    ram = bool(rng.random() < 0.5) and accelerated
    design["ram_state"] = ram and (not design["warm_shift"] or all(k % design["P"] == 0 for k in (nu, hard) if k))
    return Config(spec, design)


def solve_cycles(core: dict) -> int:
    """A bound on the cycles of one solve under bitexact_random: IMAX iterations, the output's divisions, both
    streams pausing."""
    words = core["n"] + 1
    return (core["solve_overhead_cycles"] + core["iterations"] * core["cycles_per_iteration"]
            + words * (core["div_cycles_per_word"] + 4) + 4 * (core["n"] + core["nw"]))


SOAK = SoakSpace(
    draw=draw, test="bitexact_random", count_knob="CORE_RANDOM", measured="cases",
    cycles_per_solve=solve_cycles, solves_per_config=60,
    space=("model: nx in [1, 3], nu in [1, 2], N in [2, 5]; A random, spectral radius in [0.4, 0.98] or "
           "[1.02, 1.2] (even odds); B random; Q, R random diagonals",
           "constraints: input box; hard boxes on 1 to nx states (70 %); box of accepted states with sides in "
           "[0.1, 0.5] (configurations with a state from which the constraints cannot be met are refused by the "
           "design flow); 0 to min(nx, nu) tracked states",
           "design: accelerated (60 %, Imax in [10, 60]) or plain (Imax in [40, 300]); eps_g = eps_V in {1e-2, "
           "3e-3, 1e-3} (the bits of (36)/(37)); lanes in [1, 6]; P in [1, 4] row units (at most n); lat_add in [0, 3]; target generic (50 %, lat_mul "
           "in [0, 3]), ecp5 or xilinx7; warm start (80 %), shifted a stage (accelerated, 50 %); the dual and the bounds in block RAM (accelerated, 50 %, "
           "with the shift where the rows per stage are a multiple of P); full output (30 %)",
           "solves (verif/dgp/tb.py bitexact_random): random parameters, 10 % of words outside the box, random warm "
           "or cold start and IMAX, random idle and backpressure on both streams; words, status word and latency "
           "checked"),
)
