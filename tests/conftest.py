import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from mpc_cores.admm.design import design_admm  # noqa: E402
from mpc_cores.fgm.design import design_fgm  # noqa: E402
from mpc_cores.flow import REPO, generate_admm, generate_fgm, generate_minres  # noqa: E402
from mpc_cores.problem import load_spec, problem_from_dict  # noqa: E402
from mpc_cores.small import random_spec  # noqa: E402,F401  (tests import it from here)

BUILD = REPO / "build" / "tests" / "fgm"


def _plain(v):
    """numpy scalars and containers as Python values (pytest-xdist sends recorded properties between processes)."""
    if isinstance(v, dict):
        return {str(k): _plain(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    return v.item() if isinstance(v, np.generic) else v


@pytest.fixture
def record_property(record_property):
    """The built-in fixture, with values made serialisable for parallel runs."""
    def record(name, value):
        record_property(name, _plain(value))
    return record


def pytest_addoption(parser):
    parser.addoption("--random-solves", type=int, default=None,
                     help="random solves per core in the bit-exact RTL test (default: per case)")


def random_problem(name: str, nx: int, nu: int, N: int, ny: int, seed: int, **extra):
    """A random stabilisable plant with box bounds, tracking the first ny states; `extra` adds spec sections
    (input_rate, soft_states, hard_states)."""
    return problem_from_dict(random_spec(name, nx, nu, N, ny, seed, **extra), name)


def small_case(kind: str, rounds: int) -> dict:
    """{case id: (problem factory, design overrides, rounds)}: the kind's small core (CoreKind.small) as a case of
    its RTL suite's table, so that the per-kind suites (small_cores) and the RTL suite share its build."""
    from mpc_cores import registry

    s = registry.get(kind).small_core()
    return {s.id: (s.problem, dict(s.overrides), rounds)}


def _soak_config(seed: int):
    """(problem, design overrides) of a `make soak` configuration of the FGM core"""
    from mpc_cores.fgm.soak import draw

    c = draw(np.random.default_rng(seed))
    return problem_from_dict(dict(c.spec, name=f"s{seed}"), f"s{seed}"), c.design


# id -> (problem factory, design overrides, random solves)
CASES = {
    "masses_p1_b16": (lambda: load_spec(REPO / "examples/masses.yaml"), dict(P=1, frac_bits=16), 40),
    "masses_p3_b12_nearest": (lambda: load_spec(REPO / "examples/masses.yaml"),
                              dict(P=3, frac_bits=12, rounding="nearest"), 25),
    "masses_p40_b14_l23": (lambda: load_spec(REPO / "examples/masses.yaml"),
                           dict(P=40, frac_bits=14, lat_add=2, lat_mul=3), 15),
    # ECP5 target: every product on MULT18X18D models (their three registers, then the partial products summed)
    "afm_p2_b16_ecp5": (lambda: load_spec(REPO / "examples/afm_like.yaml"),
                        dict(P=2, frac_bits=16, target="ecp5", lat_mul=4), 25),
    **small_case("fgm", 40),
    # 7-series target: 25 x 18 partial products between the DSP48E1's register stages
    "rand_n7_p2_b14_nearest_x7": (lambda: random_problem("r7", 4, 1, 7, 2, 2),
                                  dict(P=2, frac_bits=14, rounding="nearest", target="xilinx7", lat_mul=4), 40),
    # ECP5 target, one MULT18X18D per product (l_M = 3, the target's minimum, taken when lat_mul is not given)
    "rand_n4_nw9_p1_b12_ecp5": (lambda: random_problem("r4w", 7, 2, 2, 2, 3), dict(P=1, frac_bits=12, target="ecp5"),
                                40),
    # one parameter word (nx = 1, no tracking): a frame is whole the cycle after its only word, so a data write
    # and a frame started together meet at the memories (verif/fgm/tb.py, write_meets_frame)
    "rand_n3_nw1_p1_b12_ecp5": (lambda: random_problem("r1w", 1, 1, 3, 0, 5), dict(P=1, frac_bits=12, target="ecp5"),
                                20),
    "rand_n24_p5_b12_l00": (lambda: random_problem("r24", 4, 2, 12, 1, 4),
                            dict(P=5, frac_bits=12, lat_add=0, lat_mul=0), 30),
    # interleaving (K_p problems on the row units, tuser the problem id): K_p K < L (idle cycles end each round),
    # K_p not a power of two (an id past the last saturates)
    "rand_n4_p1_b12_k3": (lambda: random_problem("r4k", 3, 1, 4, 1, 8), dict(P=1, frac_bits=12, lat_mul=2, problems=3),
                          20),
    "rand_n6_p3_b12_k2": (lambda: random_problem("r6k", 3, 2, 3, 1, 9, inputs={"min": [-1.0, -0.4], "max": [0.8, 0.3]}),
                          dict(P=3, frac_bits=12, problems=2), 20),
    # soak configuration 11000017 (n = 6, P = 5, K_p = 4, l_A = l_M = 3): a first pass fetched while another
    # problem's rows were still in flight took the bounds memory from them (the rows of a unit have different
    # input bounds here)
    "soak_11000017_n6_p5_k4": (lambda: _soak_config(11000017)[0], _soak_config(11000017)[1], 30),
    # the exit test (early_exit): no pipeline registers (its decision adds 5 cycles to L) and one row per unit
    # (K = 1: every row is a pass's first); the ECP5 target at P = 2 (the row units' kept copies of EXIT_TOL), its
    # decision inside the y update's latencies
    "rand_n6_p6_b12_l00_exit": (lambda: random_problem("r6x", 3, 2, 3, 1, 21),
                                dict(P=6, frac_bits=12, lat_add=0, lat_mul=0, early_exit=True), 30),
    "afm_p2_b16_ecp5_exit": (lambda: load_spec(REPO / "examples/afm_like.yaml"),
                             dict(P=2, frac_bits=16, target="ecp5", lat_mul=4, exit_tol=2.0 ** -12), 25),
    # the masses core at P = 3 on the ECP5 target, K_p = 3: every turn busy (K_p K = 42 >= L = 34)
    "masses_p3_b14_k3_ecp5": (lambda: load_spec(REPO / "examples/masses.yaml"),
                              dict(P=3, frac_bits=14, target="ecp5", lat_mul=5, problems=3), 15),
}


def _certified_masses(tol: float):
    from mpc_cores.fgm.certify import design_for_tolerance

    return design_for_tolerance(load_spec(REPO / "examples/masses.yaml"), tol)[0]


# RTL cases of the example problems at full size beyond masses_p1_b16: `make test-slow` (their blocks run in the
# small cases of make test: K = 1 in rand_n4_p4_b10, round to nearest in rand_n7_p2_b14_nearest_x7, K_p = 3 in
# rand_n4_p1_b12_k3, the ecp5 target in afm_p2_b16_ecp5; soft pairs and round to nearest in the random ADMM cases;
# ADMM's K_p = 2 on ECP5 in rand_soft_n19_p3_k2_vucondat's K_p = 2 and rand_rate_n19_p2_ecp5_ama's target; fast ADMM
# with a one-stage pipeline in rand_soft_n19_c2_admm_acc)
SLOW_CASES = {"masses_p40_b14_l23", "masses_p3_b12_nearest", "masses_p3_b14_k3_ecp5", "masses_soft_p4_b18",
              "rand_rate_n19_p2_k2_ecp5", "rand_soft_n19_p3_admm_acc"}


def built_cases(cases, config, slow=SLOW_CASES) -> list:
    """The ids of `cases` a run needs: those in `slow` (by default SLOW_CASES) only when slow tests are selected
    (make test's `-m "not slow"` deselects them, so their cores are not generated)."""
    skip = "not slow" in (config.getoption("markexpr") or "")
    return [c for c in cases if not (skip and c in slow)]


def case_params(ids, slow=SLOW_CASES):
    """The ids as pytest parameters, those in `slow` (by default SLOW_CASES) marked slow."""
    return [pytest.param(c, marks=pytest.mark.slow) if c in slow else c for c in ids]


# Cores with a certified design (make design TOL=...), for the guarantee checks on the RTL.
CERTIFIED = {"masses_tol1e-2": lambda: _certified_masses(1e-2)}


@pytest.fixture(scope="session")
def cores(request):
    """Every core of the suite the run needs (built_cases), elaborated in one generator run."""
    ids = built_cases(CASES, request.config)
    jobs = [(design_fgm(CASES[cid][0](), **CASES[cid][1]), BUILD / cid) for cid in ids]
    jobs += [(make(), BUILD / cid) for cid, make in CERTIFIED.items()]
    generate_fgm(jobs)
    return {cid: BUILD / cid for cid in ids + list(CERTIFIED)}


ADMM_BUILD = REPO / "build" / "tests" / "admm"
from mpc_cores.admm.kind import RATE  # noqa: E402  (the rate limit of the ADMM small cores)
SOFT1 = {"indices": [0], "min": -0.5, "max": 0.5, "sigma1": 8, "sigma2": 1}
SOFT2 = {"indices": [0, 1], "min": -0.8, "max": 0.6, "sigma1": 8, "sigma2": 2}
MASSES_SOFT = REPO / "examples/masses_rate_soft.yaml"

# ADMM cores: id -> (problem factory, design overrides, random solves)
ADMM_CASES = {
    # the example (n_A = 216, 44 soft pairs), P = 4, round to nearest (the design flow's default)
    "masses_soft_p4_b18": (lambda: load_spec(MASSES_SOFT), dict(P=4, iterations=30), 12),
    # n_A = 19, P = 3 (a soft pair can straddle two units' fill), truncation, no pipeline registers
    "rand_soft_n19_p3_l00_trunc": (lambda: random_problem("ra19", 2, 1, 3, 1, 5, input_rate=RATE, soft_states=SOFT1),
                                   dict(P=3, frac_bits=16, rounding="truncate", lat_add=0, lat_mul=0), 40),
    # n_A = 26, two soft states, P = 2, deeper pipeline, ECP5 target (partial products and the rounding offset
    # summed in the fourth multiplier stage)
    "rand_soft_n26_p2_l24_ecp5": (lambda: random_problem("ra26", 3, 1, 3, 2, 6, input_rate=RATE,
                                                         soft_states=SOFT2),
                                  dict(P=2, frac_bits=16, lat_add=2, lat_mul=4, target="ecp5"), 30),
    # the plain sparse form (no input_rate: decision inputs u_k, w = (x, r), u_0 out) on masses, n_A = 128
    "masses_norate_p1_b16": (lambda: load_spec(REPO / "examples/masses.yaml"), dict(P=1, iterations=6), 12),
    # no soft states (box projection only), P = 5 does not divide n_A = 19
    **small_case("admm", 40),
    # interleaving: K_p = 3 problems with soft pairs (a pair's two rows in one turn), idle cycles ending each round
    "rand_soft_n19_p3_k3": (lambda: random_problem("rk19", 2, 1, 3, 1, 5, input_rate=RATE, soft_states=SOFT1),
                            dict(P=3, frac_bits=16, problems=3), 10),
    # K_p = 2 on the ECP5 target, every turn busy
    "rand_rate_n19_p2_k2_ecp5": (lambda: random_problem("rk19e", 3, 1, 4, 1, 7, input_rate=RATE),
                                 dict(P=2, frac_bits=15, problems=2, target="ecp5"), 10),
    # the splitting family of 004 on the same datapath: Vu-Condat (the last y kept per component, v = sigma (y + z)
    # - nu) with soft pairs and K_p = 2; AMA (v = -nu, the unaugmented KKT matrix) on the ECP5 target
    **small_case("vucondat", 10),
    # fast AMA (accelerated: momentum lanes, gradient restart) with soft pairs, both momentum lanes in use
    "rand_soft_n19_p3_ama_acc": (lambda: random_problem("rma19", 2, 1, 3, 1, 5, input_rate=RATE, soft_states=SOFT1),
                                 dict(P=3, frac_bits=16, method="ama", accelerated=True, iterations=30), 12),
    # fast ADMM and fast Vu-Condat (residual restart; z, nu and y, z, nu extrapolated) with soft pairs; ADMM with a
    # one-stage pipeline (l_A = l_M = 0: the next iteration's first row reads the momentum state in the cycle after
    # the operand copy)
    "rand_soft_n19_p3_admm_acc": (lambda: random_problem("rma19", 2, 1, 3, 1, 5, input_rate=RATE, soft_states=SOFT1),
                                  dict(P=3, frac_bits=16, accelerated=True, iterations=30, lat_add=0, lat_mul=0), 12),
    "rand_soft_n19_p3_vucondat_acc": (lambda: random_problem("rma19", 2, 1, 3, 1, 5, input_rate=RATE,
                                                             soft_states=SOFT1),
                                      dict(P=3, frac_bits=16, method="vucondat", accelerated=True, iterations=30), 12),
    **small_case("ama", 12),
    # time-multiplexed lanes: 5 multipliers take each row of 19 columns in 4 chunks (accumulated, then saturated),
    # soft pairs (the previous row's values held across the chunks' cycles), deeper pipeline, ECP5 target
    "rand_soft_n19_c4_l24_ecp5": (lambda: random_problem("rc19", 2, 1, 3, 1, 5, input_rate=RATE, soft_states=SOFT1),
                                  dict(frac_bits=16, lanes=5, lat_add=2, lat_mul=4, target="ecp5"), 20),
    # fast ADMM on 10 lanes (2 chunks) with a one-stage pipeline
    "rand_soft_n19_c2_admm_acc": (lambda: random_problem("rca19", 2, 1, 3, 1, 5, input_rate=RATE, soft_states=SOFT1),
                                  dict(frac_bits=16, lanes=10, accelerated=True, iterations=30, lat_add=0,
                                       lat_mul=0), 12),
}


# The per-kind protocol suites (tests/test_fuzz.py, tests/test_regmap.py, tests/test_assertions.py) run every kind of
# the registry on its small core (small_cores), except those excluded here: (suite, kind) -> why it cannot run.
# tests/test_suites.py asserts that every registry kind runs each suite or has a reason here. None at present.
SUITE_EXCLUSIONS: dict[tuple[str, str], str] = {}


def suite_kinds(suite: str) -> list[str]:
    """The registry kinds the per-kind suite `suite` ("fuzz", "regmap", "assertions") runs, in registry order."""
    from mpc_cores import registry

    return [k for k in registry.names() if (suite, k) not in SUITE_EXCLUSIONS]


@pytest.fixture(scope="session")
def small_cores(cores, admm_cores):
    """The small core of each registry kind (CoreKind.small), as kind -> (out_dir, core.json). Each is a case of its
    kind's RTL suite (conftest.small_case): the FGM and ADMM ones come from those suites' fixtures; the others are
    generated here into their RTL suites' folders, with the same configuration, so the builds are shared."""
    import json

    from mpc_cores import registry
    from mpc_cores.flow import generate

    ready = {**{f"fgm/{c}": d for c, d in cores.items()}, **{f"admm/{c}": d for c, d in admm_cores.items()}}
    dirs, jobs = {}, {}
    for name, kind in registry.kinds().items():
        s = kind.small_core()
        dirs[name] = ready.get(s.case, REPO / "build" / "tests" / s.case)
        if s.case not in ready:
            jobs.setdefault(kind.generator_main, (kind, []))[1].append((kind.design(s.problem(), **s.overrides),
                                                                        dirs[name]))
    for kind, js in jobs.values():
        generate(kind, js)
    return {k: (d, json.loads((d / "core.json").read_text())) for k, d in dirs.items()}


@pytest.fixture(scope="session")
def admm_cores(request):
    """Every ADMM core of the suite the run needs (built_cases), elaborated in one generator run."""
    ids = built_cases(ADMM_CASES, request.config)
    jobs = [(design_admm(ADMM_CASES[cid][0](), **ADMM_CASES[cid][1]), ADMM_BUILD / cid) for cid in ids]
    generate_admm(jobs)
    return {cid: ADMM_BUILD / cid for cid in ids}
