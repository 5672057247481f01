"""The cycle model of interleaved problems (mpc_cores.interleave) and the elaboration of interleaving cores over a
spread of shapes (the RTL tests simulate a few; here the generator must accept every shape the soak draws)."""
from __future__ import annotations

import numpy as np
import pytest

from mpc_cores.errors import DesignError
from mpc_cores.interleave import ANSWER_AFTER, TAKE_TO_TURN, Interleave, core_fields, covering_problems


def test_round_and_turns():
    il = Interleave(K=14, Kp=3, L=34)
    assert il.R == 42                                  # K_p K covers L
    assert Interleave(K=4, Kp=3, L=14).R == 14         # L covers K_p K: idle cycles end the round
    assert Interleave(K=40, Kp=1, L=60).R == 60
    # slot j's turns begin at 1 + j K + q R
    assert il.turn_start(0, 0) == 1 and il.turn_start(2, 0) == 29
    assert il.turn_start(1, 16) == 57 and il.turn_start(1, 15) == 15
    assert all((il.turn_start(j, t) - 1 - j * 14) % 42 == 0 and 0 <= il.turn_start(j, t) - t < 42
               for j in range(3) for t in range(200))


def test_latency_and_throughput():
    il = Interleave(K=14, Kp=3, L=34)
    lo, hi = il.latency_bounds(15)
    assert lo == TAKE_TO_TURN + 15 * 42 + 34 + ANSWER_AFTER and hi == lo + 41
    assert il.saturated(out_words=4, nw=12)            # slack 42 - (34 + 2 + 3) - 3 = 0
    assert il.period(15, 4, 12) == 16 * 42 and il.mac_utilisation(15, 4, 12) == 1.0
    assert not Interleave(K=14, Kp=2, L=34).saturated(4, 12)   # R = L: a round is lost per solve
    assert Interleave(K=14, Kp=2, L=34).period(15, 4, 12) == 17 * 34
    assert covering_problems(14, 34, 4, 12) == 3 and covering_problems(40, 60, 4, 12) == 2
    # one problem: the answer's queue adds a cycle to the latency, not to the period (the next solve starts as the
    # last word enters the queue)
    one = core_fields(40, 60, 1, 15, 4, 12, 944)
    assert one["latency_cycles"] == {"min": 944, "max": 944} and one["throughput_solves_per_cycle"] == 1 / 946


@pytest.mark.parametrize("kind", ["fgm", "admm"])
def test_interleaving_cores_elaborate(kind, tmp_path):
    """Random soak shapes with K_p in 2..4 (P up to n, soft pairs, targets): the generator elaborates every one,
    and core.json's period and latency agree with the front end."""
    from mpc_cores import flow, registry
    from mpc_cores.kind import load
    from mpc_cores.problem import problem_from_dict

    kk = registry.get(kind)
    draw, design = load(kk.soak).draw, load(kk.design_fn)
    rng = np.random.default_rng(5)
    jobs = []
    while len(jobs) < 5:
        i = len(jobs)
        c = draw(rng)
        c.design.update(problems=2 + i % 3, iterations=min(c.design["iterations"], 12))
        try:
            d = design(problem_from_dict(dict(c.spec, name=f"e{i}"), f"e{i}"), **c.design)
        except DesignError:
            continue              # the soak counts these as refused
        if i == 0:             # one row per unit (K = 1): a turn is a single cycle
            d = design(problem_from_dict(dict(c.spec, name=f"e{i}"), f"e{i}"), **dict(c.design, P=d.n))
        jobs.append((d, tmp_path / f"c{i}"))
    cores = flow.generate(kind, jobs)
    for (d, _), core in zip(jobs, cores):
        assert core["problems"] == d.problems > 1
        assert core["period_cycles"] == max(core["cycles_per_iteration"], d.problems * core["rows_per_turn"])
        assert core["latency_cycles"]["max"] == core["latency_cycles"]["min"] + core["period_cycles"] - 1
    assert any(c["P"] == c["n"] for c in cores)
