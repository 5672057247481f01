"""RTL of the generated MINRES core against the bit-exact golden model (mpc_cores/minres/model.py) in Verilator,
through AXI4-Stream and AXI4-Lite; the cycle contract; core.json of the masses core (the issue's example);
generator refusals.

One generator run elaborates every core of this file, another the refused configurations (session fixture); each
RTL case builds its Verilator model once and runs the scenarios of verif/minres/tb.py.
"""
from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from conftest import random_problem, small_case
from mpc_cores.flow import REPO, GeneratorError, generate_minres, run_generator
from mpc_cores.minres.design import design_minres
from mpc_cores.problem import load_spec
from mpc_cores.sim import run_cocotb

BUILD = REPO / "build" / "tests" / "minres"
SCENARIOS = 3  # cocotb tests in verif/minres/tb.py

# id -> (problem factory, design overrides, random problems); P = 0: eq. (15)
RTL_CASES = {
    **small_case("minres", 24),
    "n1_m2_t4_p2_l21": (lambda: random_problem("rb", 1, 2, 4, 0, 6), dict(P=2, iterations=6, lat_add=2, lat_mul=1), 10),
    # one problem per batch, slots stretched far beyond N (S = 192, N = 19): a pass of the previous batch is still
    # counting its idle end when the next batch starts
    "n2_m1_t3_p1": (lambda: random_problem("rc", 2, 1, 3, 0, 7), dict(P=1, iterations=6), 16),
    # the reduced format e8m17 (26-bit words, an 18-bit significand: one MULT18X18D per product), its default
    # divide and square-root latencies (13), random upper bits on the input stream; target ecp5 (the vector
    # memories' DP16KD primitives, simulated through their behavioural model)
    "n2_m1_t3_e8m17": (lambda: random_problem("rd", 2, 1, 3, 0, 8), dict(P=3, iterations=8, format="e8m17",
                                                                         target="ecp5"), 16),
    # the interior-point core's form: warm start at z0, equilibration d, ||r_0|| after x, iterations and the
    # closing of partial batches on ports
    "n2_m1_t3_warm": (lambda: random_problem("re", 2, 1, 3, 0, 9), dict(P=2, iterations=7, warm=True), 16),
    # the multiplexed interior-point core's form: two matrices of one layout (two random plants), each problem
    # multiplying by the one its id chooses (random ids)
    "n2_m1_t3_tables": (lambda: random_problem("rf", 2, 1, 3, 0, 10),
                        dict(P=3, iterations=7, warm=True,
                             channels=[random_problem(f"rf{k}", 2, 1, 3, 0, 12 + k) for k in range(2)]), 12),
}
OTHER = {
    "masses_p4": (lambda: load_spec(REPO / "examples/masses.yaml"), dict(P=4)),
}


@pytest.fixture(scope="session")
def minres_cores():
    jobs = {cid: (f(), ov) for cid, (f, ov, _) in RTL_CASES.items()}
    jobs.update({cid: (f(), ov) for cid, (f, ov) in OTHER.items()})
    designs = {cid: design_minres(p, **ov) for cid, (p, ov) in jobs.items()}
    generated = generate_minres([(d, BUILD / cid) for cid, d in designs.items()])
    cores = {cid: (BUILD / cid, core) for cid, core in zip(designs, generated)}
    # refused configurations in one generator run
    args = []
    base = designs["n2_m1_t3_pauto"].config()
    bad = {"lat_add0": dict(base, lat_add=0), "p_big": dict(base, P=65),
           "band_shape": dict(base, band_offsets=base["band_offsets"][:-1]), "fmt_wide": dict(base, exp_width=9, man_width=23),
           "fmt_exp": dict(base, exp_width=1, man_width=10)}
    bdir = BUILD / "refused"
    bdir.mkdir(parents=True, exist_ok=True)
    for k, cfg in bad.items():
        (bdir / f"{k}.json").write_text(json.dumps(cfg))
        args += [str(bdir / f"{k}.json"), str(bdir / k)]
    with pytest.raises(GeneratorError) as e:
        run_generator("minres.MinresMain", args)
    return cores, str(e.value), bdir, list(bad)


def test_generator_refusals(minres_cores):
    _, msg, bdir, bad = minres_cores
    assert "lat_add0.json: requirement failed: lat_add must be >= 1" in msg
    assert "p_big.json: requirement failed: P must be in [1, 64]" in msg
    assert "band_shape.json: requirement failed: band_offsets and band_coefs must be" in msg
    assert ("fmt_wide.json: requirement failed: the float format must fit the 32-bit stream word (1 + expW + manW "
            "<= 32): got expW=9, manW=23 (33 bits)") in msg
    assert "fmt_exp.json: requirement failed: FloatFormat: exponent width expW must be in [2, 16]: got expW=1" in msg
    assert not any((bdir / k).exists() for k in bad)


def test_masses_core_json(minres_cores):
    """The issue's example: masses (n = 8, m = 4, T = 10): N = 216, M = 20; P = 4 requested; one iteration of P
    problems in at most P N + P cycles; storage within the bound of 001."""
    out, core = minres_cores[0]["masses_p4"]
    assert (core["N"], core["M"], core["P"]) == (216, 20, 4)
    assert core["cycles_per_iteration"] == 4 * 216 <= core["cycles_bound"] == 4 * 216 + 4
    assert core["storage_words"] <= core["storage_bound_001"] < core["storage_dense_cds"]
    assert core["storage_dense_cds"] == 2 * 4 * 216 * 20
    assert (out / core["sv"]).exists() and (out / core["header"]).exists()
    # the header is PeakRDL's from the core's .rdl: N is the reset value of CONFIG0.N (216 = 0xd8)
    assert re.search(r"MINRESCORE_MASSES_N8_M4_T10_P4__CONFIG0__N_reset\s+0xd8\b", (out / core["header"]).read_text())


def test_format_in_core_json(minres_cores):
    """The e8m17 core: its format in config.json, hw.json and core.json, in the module name, the float library's
    e8m17 operators and latencies, its target (ecp5: the vector memories as DP16KD with their output register);
    binary32 cores keep their names."""
    out, core = minres_cores[0]["n2_m1_t3_e8m17"]
    cfg = json.loads((out / "config.json").read_text())
    assert (cfg["format"], cfg["exp_width"], cfg["man_width"]) == ("e8m17", 8, 17)
    assert (core["format"], core["word_width"], core["stream_width"]) == ("e8m17", 26, 32)
    assert (core["lat_div"], core["lat_sqrt"]) == (13, 13)
    sv = (out / core["sv"]).read_text()
    assert core["module"].endswith("_e8m17_ecp5") and "FMul_e8_m17" in sv and core["target"] == "ecp5"
    # every vector memory copy a mem.Ecp5SdpRam (no memory array of its own in the core)
    assert len(re.findall(r"^module \w+_vmem_\d \(", sv, re.M)) == 3 and 'REGMODE_B("OUTREG")' in sv
    top = re.search(rf"^module {core['module']}\(.*?^endmodule", sv, re.S | re.M).group(0)
    assert "_vmem_0 " in top and not re.search(r"reg +\[\d+:0\] +\w*mem\w* +\[", top)
    out32, core32 = minres_cores[0]["masses_p4"]
    assert (core32["format"], core32["word_width"], core32["module"]) == ("binary32", 32, "MinresCore_masses_n8_m4_t10_p4")


@pytest.mark.parametrize("cid", list(RTL_CASES))
def test_rtl_matches_golden_model(cid, minres_cores):
    out, core = minres_cores[0][cid]
    measure = out / "measured.jsonl"
    measure.unlink(missing_ok=True)
    count = RTL_CASES[cid][2]
    tests, failed = run_cocotb(out / core["sv"], core["module"], "verif.minres.tb", out / "sim",
                               {"CORE_OUT": str(out), "CORE_RANDOM": str(count), "CORE_MEASURE": str(measure)})
    assert tests == SCENARIOS, f"{tests} cocotb tests ran, expected {SCENARIOS}"
    assert failed == 0, f"{failed} of {tests} scenarios failed: see {out / 'sim' / 'sim.log'}"
    rec = [json.loads(ln) for ln in measure.read_text().splitlines()]
    assert next(r for r in rec if r["test"] == "bitexact_random")["cases"] == count
    cyc = next(r for r in rec if r["test"] == "cycles")
    assert cyc["cycles_per_iteration"] == core["cycles_per_iteration"] == core["P"] * core["slot_cycles"]
    if core["P"] >= core["P_eq15"]:
        assert cyc["cycles_per_iteration"] <= core["P"] * core["N"] + core["P"]


@pytest.mark.slow
def test_masses_rtl(minres_cores):
    """The masses core (P = 4) in Verilator: bit-exact, and the measured cycles per iteration (slow: a large
    Verilator build)."""
    out, core = minres_cores[0]["masses_p4"]
    measure = out / "measured.jsonl"
    measure.unlink(missing_ok=True)
    tests, failed = run_cocotb(out / core["sv"], core["module"], "verif.minres.tb", out / "sim",
                               {"CORE_OUT": str(out), "CORE_RANDOM": "8", "CORE_MEASURE": str(measure)})
    assert (tests, failed) == (SCENARIOS, 0), f"see {out / 'sim' / 'sim.log'}"
    cyc = next(json.loads(ln) for ln in measure.read_text().splitlines() if '"cycles"' in ln)
    assert cyc["cycles_per_iteration"] == 864 <= 868
