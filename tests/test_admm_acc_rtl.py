"""RTL of the accelerated ADMM-family cores (`accelerated: true`: the momentum lanes and the restart test of
fast AMA, fast ADMM and accelerated Vu-Condat) against the bit-exact golden model, every scenario of
verif/admm/tb.py; the cases are tests/conftest.py's ADMM_CASES ending in _acc."""
from __future__ import annotations

import pytest

from conftest import ADMM_CASES, case_params
from test_admm_rtl import test_rtl_matches_golden_model as _check

ACC = [c for c in ADMM_CASES if c.endswith("_acc")]


@pytest.mark.parametrize("cid", case_params(ACC))
def test_accelerated_rtl_matches_golden_model(cid, admm_cores, request):
    import json

    core = json.loads((admm_cores[cid] / "core.json").read_text())
    assert core["accelerated"] and core["momentum_cycles"] == 1 + core["lat_mul"]
    _check(cid, admm_cores, request)
