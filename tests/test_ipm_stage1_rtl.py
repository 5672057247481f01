"""The Stage 1 engine of the interior-point core (src/main/scala/ipm/) in Verilator against the interpreter of its
instruction set (mpc_cores/ipm/machine.py): random programs on random data, the interior-point programs of a small
problem and of the oscillating masses on two slots with stream stalls, and the cycle count of every program
(verif/ipm/stage1_tb.py; the masses' engine under the slow marker). One generator run elaborates the engines."""
from __future__ import annotations

import dataclasses
import json
import random

import numpy as np
import pytest

from conftest import built_cases, case_params
from mpc_cores.flow import REPO, GeneratorError, run_generator
from mpc_cores.ipm import isa
from mpc_cores.ipm import stage1_config as sc
from mpc_cores.ipm.isa import Instr, Operand
from mpc_cores.ipm.program import build
from mpc_cores.ipm.sparse import sparse_mpc
from mpc_cores.problem import load_spec, problem_from_dict
from mpc_cores.sim import run_cocotb
from verif.ipm.random_programs import random_program, random_tables, random_words

BUILD = REPO / "build" / "tests" / "ipm_stage1"
SCENARIOS = 3   # cocotb tests in verif/ipm/stage1_tb.py
IPM = dict(i_nw=2, i_mr=6, sigma=0.1, tau=0.99, precondition=True, start_value=1.0, warm_floor=1e-2, slots=2)
RANDOM_PROGRAMS, RANDOM_RUNS = 36, 4


def small_problem() -> dict:
    """n = 2, m = 1, T = 3, one tracked output: a random stable plant with input and state boxes."""
    rng = np.random.default_rng(5)
    A = rng.standard_normal((2, 2))
    A *= 0.95 / max(abs(np.linalg.eigvals(A)))
    return {"name": "small", "model": {"A": A.tolist(), "B": rng.standard_normal((2, 1)).tolist()},
            "cost": {"Q": 1.0, "R": 0.5}, "horizon": 3, "inputs": {"min": -1.0, "max": 0.8},
            "states": {"min": -3.0, "max": 3.0}, "tracking": {"outputs": [0], "min": -1.0, "max": 1.0}}


def stage1(s):
    return build(s, IPM["sigma"], IPM["tau"], IPM["precondition"], IPM["start_value"], IPM["warm_floor"])


def with_random(st, count: int, acc: list, seed: int):
    """`st` with `count` random programs in the same ROM, over 40 extra constants and two extra tables."""
    rng = random.Random(seed)
    const = np.concatenate([st.const_words.astype(np.float32),
                            np.array(random_words(rng, 40), dtype=np.uint32).view(np.float32)])
    tables = list(st.tables) + random_tables(rng, (16, 24), 60)
    progs = dict(st.programs)
    names = [f"rand{k}" for k in range(count)]
    for k in names:
        progs[k] = random_program(rng, st.slot_words, len(const), tables, acc, rng.randint(2, 8))
    return dataclasses.replace(st, const_words=const, tables=tables, programs=progs), names


def small_engine():
    """The small problem's programs and random programs (every op), default latencies."""
    prob = small_problem()
    st, names = with_random(stage1(sparse_mpc(problem_from_dict(prob, "small"))), RANDOM_PROGRAMS, [6, 9], 7)
    assert {i.op for k in names for i in st.programs[k]} == set(isa.OPS)
    cfg = sc.config(st, "small", slots=IPM["slots"], debug=True)
    tb = {"random": {"programs": names, "runs": RANDOM_RUNS},
          "ipm": dict(IPM, problem=prob, lat_add=cfg["lat_add"], samples=2, compare_every_program=True)}
    return cfg, tb


def masses_engine():
    """The masses' programs (N = 216) and a few random ones with other latencies (comparator combinational)."""
    spec = REPO / "examples/masses.yaml"
    st, names = with_random(stage1(sparse_mpc(load_spec(spec))), 12, [5, 80], 8)
    lat = dict(add=3, mul=2, div=10, sqrt=12, cmp=0)
    cfg = sc.config(st, "masses", slots=IPM["slots"], lat=lat, debug=True)
    tb = {"random": {"programs": names, "runs": 2},
          "ipm": dict(IPM, spec=str(spec), lat_add=3, samples=2, compare_every_program=False)}
    return cfg, tb


ENGINES = {"small": small_engine, "masses": masses_engine}
# make test-slow: the masses' engine (every op and the interior-point programs run in the small one)
SLOW = {"masses"}


@pytest.fixture(scope="module")
def engines(request):
    built = {k: ENGINES[k]() for k in built_cases(ENGINES, request.config, SLOW)}
    hws = sc.generate([(cfg, BUILD / k) for k, (cfg, _) in built.items()])
    for k, (cfg, tb) in built.items():
        (BUILD / k / "tb.json").write_text(json.dumps(tb))
    return {k: (BUILD / k, built[k][0], hw) for k, hw in zip(built, hws)}


def test_encoding_roundtrip():
    rng = random.Random(3)
    tables = random_tables(rng, (5, 9), 30)
    for _ in range(500):
        i = random_program(rng, 100, 50, tables, [6], 1)[0]
        assert sc.decode(isa.encode(i)) == dataclasses.replace(i, note="")


def test_stream_hazards():
    """An element reading what an earlier element wrote is refused; in place and behind are fine."""
    S = lambda a, mode="vec", t=0: Operand("slot", a, mode, t)   # noqa: E731
    assert isa.stream_hazards(Instr("ADD", 4, d=S(10), a=S(10), b=S(20)), []) == []
    assert isa.stream_hazards(Instr("ADD", 4, d=S(10), a=S(11), b=S(20)), []) == []
    assert isa.stream_hazards(Instr("ADD", 4, d=S(10), a=S(9), b=S(20)), []) == [(0, 1), (1, 2), (2, 3)]
    assert isa.stream_hazards(Instr("MUL", 3, d=S(0), a=S(1, "scalar"), b=S(5)), []) == [(1, 2)]
    assert isa.stream_hazards(Instr("MOV", 2, d=S(0, "gather", 0), a=S(0)), [[1, 0]]) == [(0, 1)]
    assert isa.stream_hazards(Instr("ACC", 6, d=S(0), a=S(0)), []) == []
    with pytest.raises(ValueError, match="reads a word that element 0 writes"):
        sc.check({"p": [Instr("SUB", 3, d=S(1), a=S(0), b=S(0))]}, [], sc.DEFAULT_LAT)


def test_generator_refusals(tmp_path):
    cfg, _ = small_engine()
    bad = {
        "const_dest": dict(cfg, programs=[{"name": "p", "code": [hex(isa.encode(
            Instr("MOV", 1, d=Operand("const", 0), a=Operand("slot", 0))))]}]),
        "beyond": dict(cfg, programs=[{"name": "p", "code": [hex(isa.encode(
            Instr("MOV", 8, d=Operand("slot", cfg["slot_words"] - 4), a=Operand("slot", 0))))]}]),
        "acc_short": dict(cfg, programs=[{"name": "p", "code": [hex(isa.encode(
            Instr("ACC", 4, d=Operand("slot", 0), a=Operand("slot", 0))))]}]),
    }
    args = []
    for k, c in bad.items():
        (tmp_path / f"{k}.json").write_text(json.dumps(c))
        args += [str(tmp_path / f"{k}.json"), str(tmp_path / k)]
    with pytest.raises(GeneratorError) as e:
        run_generator(sc.MAIN, args)
    msg = str(e.value)
    assert "const_dest.json: requirement failed: instruction 0 (MOV): the destination must be in slot space" in msg
    assert "beyond.json: requirement failed: instruction 0 (MOV): destination reaches word" in msg
    assert "acc_short.json: requirement failed: instruction 0: ACC needs more than lat_add=4 terms" in msg


@pytest.mark.parametrize("eid", case_params(ENGINES, SLOW))
def test_engine_matches_interpreter(eid, engines):
    out, cfg, hw = engines[eid]
    measure = out / "measured.jsonl"
    measure.unlink(missing_ok=True)
    tests, failed = run_cocotb(out / f"{hw['module']}.sv", hw["module"], "verif.ipm.stage1_tb", out / "sim",
                               {"STAGE1_OUT": str(out), "STAGE1_MEASURE": str(measure)})
    assert tests == SCENARIOS, f"{tests} cocotb tests ran, expected {SCENARIOS}"
    assert failed == 0, f"{failed} of {tests} scenarios failed: see {out / 'sim' / 'sim.log'}"
    rec = {r["test"]: r for r in map(json.loads, measure.read_text().splitlines())}
    lat = {k: cfg[f"lat_{k}"] for k in ("add", "mul", "div", "sqrt", "cmp")}
    progs = sc.programs(cfg)
    cyc = rec["cycles"]
    assert set(cyc["measured"]) == set(progs) | {"chain"}
    for k, v in progs.items():
        assert cyc["measured"][k] == isa.cycles(v, lat) == cyc["hw"][k], k
    assert cyc["measured"]["chain"] == sum(cyc["isa"][k] for k in cyc["chain"])
    assert rec["ipm_programs"]["programs"] > 0
    spec = json.loads((out / "tb.json").read_text())["random"]
    assert rec["random_programs"]["runs"] == len(spec["programs"]) * spec["runs"]
