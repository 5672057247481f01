"""The design flow's guarantees checked on the RTL of a certified core (make design TOL=1e-2 on masses)."""
from __future__ import annotations

import json

from mpc_cores.sim import run_cocotb


def test_certified_core_meets_its_bounds_on_rtl(cores):
    out = cores["masses_tol1e-2"]
    core = json.loads((out / "core.json").read_text())
    cert = core["certificate"]
    assert cert["tol"] == 1e-2 and cert["total_error_bound"] <= 1e-2
    measure = out / "measured.jsonl"
    measure.unlink(missing_ok=True)
    tests, failed = run_cocotb(out / core["sv"], core["module"], "verif.fgm.guarantee_tb", out / "sim",
                               {"CORE_OUT": str(out), "GUARANTEE_CASES": "40", "CORE_MEASURE": str(measure)})
    assert (tests, failed) == (1, 0), f"see {out / 'sim' / 'sim.log'}"
    rec = json.loads(measure.read_text().splitlines()[-1])
    assert rec["cases"] == 40
    # the bounds hold with room, and the comparison is not vacuous
    assert 0 < rec["roundoff_observed"] <= rec["roundoff_bound"]
    assert 0 < rec["total_observed"] <= rec["total_bound"]
    print(f"round-off bound/observed = {rec['roundoff_bound'] / rec['roundoff_observed']:.1f}, "
          f"total bound/observed = {rec['total_bound'] / rec['total_observed']:.1f}")
