"""The ADMM family's time-multiplexed row unit (lanes, LANES=fit): the chunk choice, the same answers as one row per
cycle (the chunks' sums are exact and saturate once), the cycle bound, and the command line. The RTL against the
golden model: tests/conftest.py ADMM_CASES rand_soft_n19_c4_l24_ecp5 and rand_soft_n19_c2_admm_acc."""
from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from mpc_cores.admm.design import design_admm
from mpc_cores.admm.model import AdmmFixed
from mpc_cores.errors import DesignError
from mpc_cores.flow import REPO
from mpc_cores.problem import load_spec
from mpc_cores.target import dsp_count

EX = REPO / "examples"


def test_lanes_choose_the_fewest_chunks():
    p = load_spec(EX / "masses_rate_soft.yaml")
    d = design_admm(p, iterations=4, lanes=60)              # m = 216 columns: 4 chunks of 54
    assert (d.chunks, d.lanes, d.multipliers) == (4, 54, 54)
    fit = design_admm(p, iterations=4, lanes="fit")
    assert dsp_count("ecp5", fit.products(), [fit.multipliers]) <= 156
    half = design_admm(p, iterations=4, lanes=2 * fit.lanes)  # one chunk count fewer does not fit
    assert half.chunks == fit.chunks // 2 and dsp_count("ecp5", half.products(), [half.multipliers]) > 156
    depth = math.ceil(math.log2(fit.lanes))
    assert fit.cycles_per_iteration == 216 * fit.chunks + fit.lat_add * depth + fit.lat_mul + 6 * fit.lat_add + 4
    with pytest.raises(DesignError, match="P = 1"):
        design_admm(p, iterations=4, lanes=60, P=2)


def test_chunked_answers_equal_one_row_per_cycle():
    p = load_spec(EX / "masses_rate_soft.yaml")
    one, chunked = design_admm(p, iterations=8), design_admm(p, iterations=8, lanes="fit")
    assert chunked.chunks > 1 and np.array_equal(one.M11, chunked.M11)
    rng = np.random.default_rng(0)
    W = rng.integers(one.wlo, one.whi + 1, size=(16, one.nw))
    a, b = AdmmFixed(one).solve_batch(W), AdmmFixed(chunked).solve_batch(W)
    assert not a.overflow.any() and np.array_equal(a.z, b.z) and np.array_equal(a.nu, b.nu)


def test_command_line_takes_lanes_fit():
    out = subprocess.run([sys.executable, "-m", "mpc_cores", "design", "--core", "admm", "--problem",
                          str(EX / "masses_rate_soft.yaml"), "--lanes", "fit", "--iterations", "4", "--no-check"],
                         capture_output=True, text=True, cwd=REPO)
    assert out.returncode == 0, out.stderr
    assert "Lanes: 27 multipliers take a row of 216 columns in 8 chunks" in out.stdout
