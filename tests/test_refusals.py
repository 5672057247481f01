"""Front-end refusals: every bad spec, option or size is refused by the command line before any numerics run, with
one line `error: <rule>: <values>` on stderr, exit status 2 and no traceback (mpc_cores.schema, mpc_cores.cli).
Python only: no refusal reaches the generator."""
from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from mpc_cores import registry, schema
from mpc_cores.errors import SpecError
from mpc_cores.problem import load_spec, problem_from_dict

REPO = Path(__file__).resolve().parent.parent
EXAMPLES = sorted((REPO / "examples").glob("*.yaml"))
MASSES = REPO / "examples/masses.yaml"


def refusal(*args) -> str:
    """Run `python -m mpc_cores <args>`; check the refusal's form and return its line."""
    p = subprocess.run([sys.executable, "-m", "mpc_cores", *map(str, args)], capture_output=True, text=True,
                       cwd=REPO, timeout=300)
    lines = p.stderr.splitlines()
    assert p.returncode == 2, (p.returncode, p.stderr[-2000:])
    assert "Traceback" not in p.stderr and len(lines) == 1 and lines[0].startswith("error: "), p.stderr[-2000:]
    assert p.stdout == ""
    return lines[0]


def spec_file(tmp_path, changes: dict, base=MASSES) -> Path:
    """The base spec with `changes` ({"a.b": value}; value None deletes the key) written to tmp_path."""
    d = yaml.safe_load(base.read_text())
    for path, value in changes.items():
        *head, last = path.split(".")
        node = d
        for k in head:
            node = node.setdefault(k, {})
        if value is None:
            node.pop(last, None)
        else:
            node[last] = value
    f = tmp_path / "spec.yaml"
    f.write_text(yaml.safe_dump(d))
    return f


# --------------------------------------------------------------------------
# the spec: keys, types, ranges


@pytest.mark.parametrize("changes,expected", [
    ({"solverr": {"P": 1}}, "error: spec: unknown key 'solverr', did you mean 'solver'?"),
    ({"cost.q": 1.0}, "error: cost: unknown key 'q', did you mean 'Q'?"),
    ({"solver.frac_bitz": 12}, "error: solver: unknown key 'frac_bitz', did you mean 'frac_bits'?"),
    ({"solver.ipm_newtn": 4}, "error: solver: unknown key 'ipm_newtn', did you mean 'ipm_newton'?"),
    ({"solver.zzz": 1}, "error: solver: unknown key 'zzz' (valid keys: frac_bits, iterations, P,"),
    ({"inputs.max": None}, "error: inputs: missing key(s) ['max']"),
], ids=["top", "case", "frac_bitz", "ipm_newtn", "no_near", "missing"])
def test_keys(tmp_path, changes, expected):
    assert refusal("design", "--problem", spec_file(tmp_path, changes)).startswith(expected)


@pytest.mark.parametrize("changes,expected", [
    ({"horizon": "ten"}, "horizon: expected an integer >= 1, got 'ten'"),
    ({"horizon": 2.5}, "horizon: expected an integer >= 1, got 2.5"),
    ({"name": 3}, "name: expected a non-empty string, got 3"),
    ({"model.Ts": "fast"}, "model.Ts: expected a positive number (seconds), got 'fast'"),
    ({"solver": [1, 2]}, "solver: expected a mapping, got list"),
    ({"solver.frac_bits": "16"}, "solver.frac_bits: expected an integer in [1, 30]"),
    ({"solver.warm_start": 1}, "solver.warm_start: expected true or false, got 1"),
    ({"solver.rounding": "up"}, "solver.rounding: expected one of truncate, nearest, got 'up'"),
    ({"solver.ipm_format": 32}, "solver.ipm_format: expected a format name"),
    ({"solver.int_bits": {"y": "x"}}, "solver.int_bits.y: expected an integer in [0, 32]"),
], ids=["horizon_text", "horizon_frac", "name", "Ts", "solver_list", "frac_bits_text", "warm_start", "rounding",
        "ipm_format", "int_bits"])
def test_types(tmp_path, changes, expected):
    assert refusal("design", "--problem", spec_file(tmp_path, changes)).startswith("error: " + expected)


@pytest.mark.parametrize("changes,expected", [
    ({"solver.frac_bits": 0}, "solver.frac_bits: expected an integer in [1, 30] (the word of 1.0 takes frac_bits "
                              "+ 2 bits, within the 32-bit AXI4-Lite word), got 0"),
    ({"solver.frac_bits": 31}, "solver.frac_bits: expected an integer in [1, 30]"),
    ({"solver.P": 0}, "solver.P: expected an integer >= 1 (row units), got 0"),
    ({"solver.lat_add": -1}, "solver.lat_add: expected an integer in [0, 64] (pipeline registers), got -1"),
    ({"solver.lat_mul": 65}, "solver.lat_mul: expected an integer in [0, 64]"),
    ({"solver.iterations": 0}, "solver.iterations: expected an integer in [1, 65535] (a 16-bit register), got 0"),
    ({"solver.iterations": 65536}, "solver.iterations: expected an integer in [1, 65535]"),
    ({"solver.c": 0.5}, "solver.c: expected a number >= 1 (Assumption 1 of 002), got 0.5"),
    ({"solver.stream_width": 12}, "solver.stream_width: expected a multiple of 8 in [8, 64], got 12"),
    ({"solver.minres_P": 65}, "solver.minres_P: expected an integer in [0, 64] (0: eq. (15) of 001), got 65"),
    ({"solver.ipm_newton": 0}, "solver.ipm_newton: expected an integer in [1, 65535] (I_NW), got 0"),
    ({"solver.ipm_mu_tol": -1e-3}, "solver.ipm_mu_tol: expected a positive number, got -0.001"),
    ({"solver.minres_format": "e9m23"}, "solver.minres_format: format must fit the 32-bit stream word"),
    ({"soft_states": {"indices": [0], "min": -1, "max": 1, "sigma1": 1, "sigma2": 0}},
     "soft_states.sigma2: expected a positive number (Remark 1 of 002), got 0"),
], ids=["frac_bits_0", "frac_bits_31", "P_0", "lat_add", "lat_mul", "imax_0", "imax_big", "c", "stream_width",
        "minres_P", "ipm_newton", "ipm_mu_tol", "minres_format", "sigma2"])
def test_ranges(tmp_path, changes, expected):
    assert refusal("design", "--problem", spec_file(tmp_path, changes)).startswith("error: " + expected)


# --------------------------------------------------------------------------
# sizes


def test_huge_horizon_refused_quickly(tmp_path):
    f = spec_file(tmp_path, {"horizon": 100000})
    for core in registry.names():
        t0 = time.monotonic()
        line = refusal("design", "--core", core, "--problem", f)
        assert time.monotonic() - t0 < 60
        assert line == ("error: problem size: the condensed QP's data n (n + nw) must be at most 3407872 words "
                        "(16 x the LFE5U-85F's 208 DP16KD of 1024 x 18 bits): got n = N nu = 100000 x 4 = 400000, "
                        "nw = 12, 1.6e+11 words")


def test_sparse_order_limit(tmp_path):
    nx = 20
    f = spec_file(tmp_path, {"model": {"A": [[0.5 * (i == j) for j in range(nx)] for i in range(nx)],
                                       "B": [[1.0]] * nx},
                             "horizon": 200, "tracking": None, "solver.P": 1})
    assert refusal("design", "--problem", f) == (
        "error: problem size: the sparse KKT matrix, of order (N + 1)(2 nx + nu + ns), must be at most 8192 "
        "(float64, 512 MiB): got N = 200, nx = 20, nu = 1, ns = 0, order 8241")


def test_multipliers(tmp_path):
    expected = ("error: multipliers: P max(n, nw) must be at most 2496 (16 x the LFE5U-85F's 156 MULT18X18D): "
                "got P = 63, n = 40, nw = 12, 2520 multipliers")
    assert refusal("design", "--problem", spec_file(tmp_path, {"solver.P": 63})) == expected
    assert refusal("design", "--P", 63) == expected
    assert refusal("design", "--core", "admm", "--problem", REPO / "examples/masses_rate_soft.yaml",
                   "--P", 200).startswith("error: multipliers: P max(n, nw) must be at most 2496")


def test_check_size_limits():
    """Each limit at its boundary."""
    schema.check_size(10, 8, 4, 4, P=40)              # the masses core at P = n (tests/test_cycles_sweep.py)
    schema.check_size(10, 8, 4, 4, P=62)              # 62 x 40 = 2480 multipliers
    schema.check_size(461, 1, 4)                      # n = 1844: 1844 x 1845 = 3402180 words
    with pytest.raises(SpecError, match=r"condensed QP's data .* got n = N nu = 462 x 4 = 1848, nw = 1"):
        schema.check_size(462, 1, 4)                  # 1848 x 1849 = 3416952 words
    schema.check_size(198, 20, 1)                     # order 199 x 41 = 8159
    with pytest.raises(SpecError, match=r"sparse KKT matrix.* order 8200"):
        schema.check_size(199, 20, 1)
    schema.check_size(909, 2, 1, ns=2, rate=True)     # u_prev joins the state under input_rate: 910 x 9 = 8190
    with pytest.raises(SpecError, match=r"sparse KKT matrix.* nx = 3, nu = 1, ns = 2, order 8199"):
        schema.check_size(910, 2, 1, ns=2, rate=True)


# --------------------------------------------------------------------------
# files and options


def test_missing_spec_file(tmp_path):
    assert refusal("design", "--problem", tmp_path / "nope.yaml") == f"error: spec file not found: {tmp_path}/nope.yaml"
    assert refusal("verilog", "--problem", tmp_path / "nope.yaml").startswith("error: spec file not found: ")
    (tmp_path / "dir.yaml").mkdir()
    assert refusal("design", "--problem", tmp_path / "dir.yaml").startswith(
        f"error: spec file not readable: {tmp_path}/dir.yaml: ")
    assert refusal("design", "--problem", tmp_path / "spec.txt") == (
        f"error: {tmp_path}/spec.txt: unknown spec extension '.txt' (expected .yaml, .yml or .json)")
    bad = tmp_path / "bad.yaml"
    bad.write_text("horizon: [1\n")
    assert refusal("design", "--problem", bad) == (
        f"error: {bad}: invalid YAML at line 2, column 1: expected ',' or ']', but got '<stream end>'")
    assert refusal("design", "--problem", spec_file(tmp_path, {"states.min": [float("nan")] * 40})).startswith(
        "error: states.min: entries must be finite, got [nan, nan,")     # an array message joined into one line


@pytest.mark.parametrize("args,expected", [
    (("--frac-bits", "64"), "--frac-bits: expected an integer in [1, 30] (the word of 1.0 takes frac_bits + 2 bits, "
                            "within the 32-bit AXI4-Lite word), got 64"),
    (("--frac-bits", "abc"), "--frac-bits: expected an integer in [1, 30] (the word of 1.0 takes frac_bits + 2 "
                             "bits, within the 32-bit AXI4-Lite word), got 'abc'"),
    (("--P", "x"), "--P: expected an integer >= 1 (row units), got 'x'"),
    (("--P", "0"), "--P: expected an integer >= 1 (row units), got 0"),
    (("--P", "2.5"), "--P: expected an integer >= 1 (row units), got 2.5"),
    (("--lat-mul", "65"), "--lat-mul: expected an integer in [0, 64] (pipeline registers), got 65"),
    (("--iterations", "0"), "--iterations: expected an integer in [1, 65535] (a 16-bit register), got 0"),
    (("--rounding", "up"), "--rounding: expected one of truncate, nearest, got 'up'"),
    (("--tol", "-1"), "--tol: expected a positive number, got -1"),
    (("--tol", "nan"), "--tol: expected a positive number, got nan"),
    (("--format", "e8m17"), "CORE=fgm takes the overrides P, frac_bits, lat_add, lat_mul, rounding, iterations, "
                            "target, problems, early_exit, exit_tol: got format"),
    (("--target", "stratix"), "--target: expected one of generic, ecp5, xilinx7, got 'stratix'"),
    (("--target", "ecp5"), "target ecp5 needs lat_mul >= 4 (the DSP's registers, and a stage summing partial "
                           "products; widest product 17 x 19 bits): got lat_mul=1 (set lat_mul: 4 in the spec's "
                           "solver section, LAT_MUL=4, or leave it out)"),
    (("--core", "admm", "--problem", "examples/masses_rate_soft.yaml", "--target", "xilinx7", "--lat-mul", "2"),
     "target xilinx7 needs lat_mul >= 4 (the DSP's registers, and a stage summing partial products; widest product "
     "20 x 29 bits): got lat_mul=2 (set lat_mul: 4 in the spec's solver section, LAT_MUL=4, or leave it out)"),
    (("--core", "ipm", "--problems", "2"), "CORE=ipm takes the overrides P, iterations, newton, lat_add, lat_mul, "
                                           "format, latency, target, multiplexed: got problems"),
    (("--core", "minres", "--P", "65"), "--P: expected an integer in [0, 64] (0: eq. (15) of 001), got 65"),
    (("--core", "minres", "--format", "e9m23"), "--format: format must fit the 32-bit stream word (1 + E + M <= 32): "
                                                "got e9m23, 33 bits"),
    (("--core", "ipm", "--P", "-1"), "--P: expected an integer in [0, 64] (0: eq. (15) of 001), got -1"),
    (("--core", "ipm", "--iterations", "70000"), "--iterations: expected an integer in [1, 65535] (a 16-bit "
                                                 "register), got 70000"),
    (("--problems", "17"), "--problems: expected an integer in [1, 16] (problems interleaved on the row units), got 17"),
    (("--core", "minres", "--problems", "2"),
     "CORE=minres takes the overrides P, iterations, lat_add, lat_mul, format, latency, target: got problems"),
    (("--core", "ipm", "--latency", "fastest"), "--latency: expected one of compact, fast, got 'fastest'"),
    (("--core", "ipm", "--format", "e8m17", "--target", "ecp5", "--lat-mul", "3"),
     "target ecp5 in e8m17 needs lat_mul >= 4 (the MULT18X18D's input, pipeline and output registers and the "
     "output's): got lat_mul=3"),
    (("--bogus", "1"), "unrecognized arguments: --bogus 1"),
], ids=["B64", "B_text", "P_text", "P0", "P_frac", "lat_mul", "imax", "rounding", "tol", "tol_nan", "format_fgm",
        "target_name", "target_lat_mul", "target_x7_lat_mul", "problems_ipm",
        "minres_P", "minres_format", "ipm_P", "ipm_imr", "problems_range", "problems_minres", "ipm_latency", "ipm_ecp5_lat_mul",
        "unknown_option"])
def test_overrides(args, expected):
    assert refusal("design", *args) == "error: " + expected


def test_overrides_before_numerics():
    """verilog and demo check their options before the design (and the generator) runs."""
    assert refusal("verilog", "--frac-bits", "64").startswith("error: --frac-bits: expected an integer in [1, 30]")
    assert refusal("demo", "--frac-bits", "64").startswith("error: --frac-bits: expected an integer in [1, 30]")
    assert refusal("demo", "--steps", "x") == "error: argument --steps: invalid int value: 'x'"


# --------------------------------------------------------------------------
# the schema against the kinds, the examples, the docs and the benchmark's part


def test_solver_keys_are_the_kinds():
    """solver_rules() has a rule for every key a kind reads (CoreKind.spec_section) and no other; a kind's own
    rules are keys it reads that no other kind reads, and every shared key is read by two kinds at least."""
    kinds = registry.kinds().values()
    read = {k for kind in kinds for k in kind.spec_section}
    assert set(schema.solver_rules()) == read
    for kind in kinds:
        assert set(kind.spec_rules) <= set(kind.spec_section), kind.name
    for key in schema.SHARED_SOLVER:
        readers = {id(k.spec_rules) for k in kinds if key in k.spec_section}
        assert len(readers) >= 2, f"shared key {key} is read by one kind only: it belongs in its spec_rules"
    for kind in kinds:
        for key in set(kind.spec_section) - set(schema.SHARED_SOLVER):
            assert key in kind.spec_rules, f"CORE={kind.name} reads {key}, a key of another kind"


def test_override_rules():
    kinds = registry.kinds()
    assert schema.override_rule(kinds["fgm"], "P") is schema.SHARED_SOLVER["P"]
    assert schema.override_rule(kinds["minres"], "P") is kinds["minres"].spec_rules["minres_P"]
    assert schema.override_rule(kinds["ipm"], "format") is kinds["ipm"].spec_rules["ipm_format"]
    for kind in kinds.values():
        for name in kind.overrides:
            schema.override_rule(kind, name)


@pytest.mark.parametrize("path", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_examples_validate(path):
    d = yaml.safe_load(path.read_text())
    assert schema.check_spec(d) == d
    p = load_spec(path)
    assert p.solver == d.get("solver", {})
    assert problem_from_dict(d, path.stem).N == d["horizon"]


def test_docs_list_the_rules():
    text = (REPO / "docs/spec.md").read_text()
    for key in schema.solver_rules():
        assert f"`{key}`" in text, key
    for number in (schema.WORDS_MAX, schema.MULTS_MAX, schema.ORDER_MAX):
        assert f"{number:,}" in text or str(number) in text, number


def test_part_agrees_with_the_benchmark():
    from mpc_bench.parsers import ECP5_85F

    assert (ECP5_85F["MULT18X18D"], ECP5_85F["DP16KD"]) == (schema.PART_MULTS, schema.PART_BLOCKS)
