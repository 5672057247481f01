"""cocotb tests of the ECP5 block RAM texts as synthesis sees them: the `ifdef SYNTHESIS` branch (DP16KD primitives
with the output register) built in Verilator with -DSYNTHESIS against `dp16kd_model`, a model of the primitive
written from the Lattice pin and INITVAL conventions (the ones Yosys's own mapping uses). BRAM_SPEC (JSON): depth,
lanes, lane width, the initial rows, and "broadcast" when every write carries one word for all its lanes.

bram_rows (toplevel: an InitRam, mem/Ecp5BlockRam.scala):
- every row reads back its initial contents, two cycles after its address (three with the address registered
  ahead, spec "ahead");
- random lane-masked writes, then every row again against a model of the behavioural InitRam.

sdp_rows (toplevel: an Ecp5SdpRam, mem/Ecp5SdpRam.scala; lanes 1, no initial rows):
- every word written, then read back two cycles after its address;
- a read and a write of different words on every cycle, each read checked two cycles later."""
from __future__ import annotations

import json
import os
import random
from pathlib import Path

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import FallingEdge, ReadOnly, RisingEdge


def dp16kd_model() -> str:
    """A DP16KD model: port A writes, port B reads, REGMODE_B "OUTREG" adds the output register. Data width modes
    x18 (1024 words, address AD13..AD4, both byte enables AD1, AD0 on for a write; INITVAL_k holds words
    16 k .. 16 k + 15 at bits 20 j .. 20 j + 17), x9 (2048, AD13..AD3), x4 (4096, AD13..AD2), x2 (8192, AD13..AD1)
    and x1 (16384, AD13..AD0), the narrow modes without initial contents."""
    params = "\n".join(f"  parameter [319:0] INITVAL_{k:02X} = 320'h0;" for k in range(64))
    case = "\n".join(f"      {k}: v = INITVAL_{k:02X};" for k in range(64))
    pins = lambda p, n, d: ", ".join(f"{d} {p}{i}" for i in range(n))  # noqa: E731
    bus = lambda p, n: "{" + ", ".join(f"{p}{i}" for i in reversed(range(n))) + "}"  # noqa: E731
    dob = "\n".join(f"  assign DOB{i} = q[{i}];" for i in range(18))
    return f"""\
module DP16KD ({pins("DIA", 18, "input")}, {pins("ADA", 14, "input")}, input CEA, input OCEA, input CLKA,
  input WEA, input RSTA, input CSA0, input CSA1, input CSA2, {pins("DIB", 18, "input")}, {pins("ADB", 14, "input")},
  input CEB, input OCEB, input CLKB, input WEB, input RSTB, input CSB0, input CSB1, input CSB2,
  {pins("DOB", 18, "output")});
  parameter DATA_WIDTH_A = 18;
  parameter DATA_WIDTH_B = 18;
  parameter REGMODE_A = "NOREG";
  parameter REGMODE_B = "NOREG";
  parameter RESETMODE = "SYNC";
  parameter ASYNC_RESET_RELEASE = "SYNC";
  parameter CSDECODE_A = "0b000";
  parameter CSDECODE_B = "0b000";
  parameter WRITEMODE_A = "NORMAL";
  parameter WRITEMODE_B = "NORMAL";
  parameter GSR = "ENABLED";
{params}
  localparam W = DATA_WIDTH_A;
  localparam AW = W == 18 ? 10 : W == 9 ? 11 : W == 4 ? 12 : W == 2 ? 13 : 14;
  localparam [17:0] MASK = (18'h1 << W) - 18'h1;
  reg [17:0] mem [0:(1 << AW) - 1];
  reg [319:0] v;
  integer k, j;
  initial begin
    if (DATA_WIDTH_B != W || !(W == 18 || W == 9 || W == 4 || W == 2 || W == 1))
      $fatal(1, "dp16kd_model: ports of one width in 1, 2, 4, 9 or 18");
    for (k = 0; k < (1 << AW); k = k + 1) mem[k] = 18'h0;
    for (k = 0; k < 64; k = k + 1) begin
      case (k)
{case}
        default: v = 320'h0;
      endcase
      if (v != 320'h0 && W != 18) $fatal(1, "dp16kd_model: initial contents in the x18 mode only");
      if (W == 18) for (j = 0; j < 16; j = j + 1) mem[16 * k + j] = v[20 * j +: 18];
    end
  end
  wire [13:0] ada = {bus("ADA", 14)};
  wire [13:0] adb = {bus("ADB", 14)};
  wire [17:0] dia = {bus("DIA", 18)};
  reg [17:0] lat, outr;
  always @(posedge CLKA) if (CEA && WEA) begin
    if (W == 18 && ada[1:0] != 2'b11) $fatal(1, "dp16kd_model: a write without both byte enables");
    if (W != 18 && W != 1 && ada[13 - AW:0] != 0) $fatal(1, "dp16kd_model: address pins below the word set");
    mem[ada[13 -: AW]] <= dia & MASK;
  end
  always @(posedge CLKB) begin
    if (CEB) lat <= mem[adb[13 -: AW]];
    if (OCEB) outr <= lat;
  end
  wire [17:0] q = REGMODE_B == "OUTREG" ? outr : lat;
{dob}
endmodule
"""


@cocotb.test()
async def bram_rows(dut):
    spec = json.loads(Path(os.environ["BRAM_SPEC"]).read_text())
    depth, lanes, lw = spec["depth"], spec["lanes"], spec["lane_width"]
    rows = [int(r) for r in spec["rows"]] + [0] * (depth - len(spec["rows"]))
    rng = random.Random(3)
    cocotb.start_soon(Clock(dut.clock, 10, unit="ns").start())
    dut.wen.value = 0
    dut.wmask.value = 0
    dut.waddr.value = 0
    dut.wdata.value = 0

    lag = 2 if spec.get("ahead") else 1

    async def read_all(tag):
        """one address a cycle: after the edge that takes address a, rdata holds the word of a - lag"""
        got = []
        for a in range(depth + lag):
            dut.raddr.value = min(a, depth - 1)
            await RisingEdge(dut.clock)
            await ReadOnly()
            if a >= lag:
                got.append(int(dut.rdata.value))
            await FallingEdge(dut.clock)
        bad = [a for a in range(depth) if got[a] != rows[a]]
        assert not bad, f"{tag}: rows {bad[:8]} differ, e.g. {got[bad[0]]:x} != {rows[bad[0]]:x}"

    await FallingEdge(dut.clock)
    await read_all("initial contents")
    lane = (1 << lw) - 1
    for _ in range(3 * depth):
        await RisingEdge(dut.clock)
        a, m, d = rng.randrange(depth), rng.randrange(1, 1 << lanes), rng.getrandbits(lanes * lw)
        if spec.get("broadcast"):  # one word for every lane (the memory takes lane 0's)
            d = sum((d & lane) << (i * lw) for i in range(lanes))
        dut.wen.value, dut.waddr.value, dut.wmask.value, dut.wdata.value = 1, a, m, d
        rows[a] = sum(((d if m >> i & 1 else rows[a]) >> (i * lw) & lane) << (i * lw) for i in range(lanes))
    await RisingEdge(dut.clock)
    dut.wen.value = 0
    # the write port has two registers: the last write lands at the second of these edges
    await RisingEdge(dut.clock)
    await RisingEdge(dut.clock)
    await FallingEdge(dut.clock)
    await read_all("after lane-masked writes")


@cocotb.test()
async def sdp_rows(dut):
    spec = json.loads(Path(os.environ["BRAM_SPEC"]).read_text())
    depth, width = spec["depth"], spec["lane_width"]
    rng = random.Random(5)
    words = [rng.getrandbits(width) for _ in range(depth)]
    cocotb.start_soon(Clock(dut.clock, 10, unit="ns").start())
    dut.wen.value = 0
    dut.raddr.value = 0
    await FallingEdge(dut.clock)
    for a, w in enumerate(words):            # every word written, one a cycle
        dut.wen.value, dut.waddr.value, dut.wdata.value = 1, a, w
        await FallingEdge(dut.clock)
    dut.wen.value = 0
    pipe = []    # expected words of the reads: after the edge that takes an address, rdata holds the previous one's
    for t in range(depth + 2 * 64 + 2):
        if t < depth:
            a = t
        elif t < depth + 2 * 64:                     # a read and a write of another word on the same cycle
            a = rng.randrange(depth)
            b = (a + 1 + rng.randrange(depth - 1)) % depth if depth > 1 else None
            if b is not None:
                nw = rng.getrandbits(width)
                dut.wen.value, dut.waddr.value, dut.wdata.value = 1, b, nw
        else:
            a = None
        if a is not None:
            dut.raddr.value = a
        pipe.append(None if a is None else words[a])
        await RisingEdge(dut.clock)
        if t >= depth and t < depth + 2 * 64 and b is not None:
            words[b] = nw
        await ReadOnly()
        if len(pipe) >= 2 and pipe[-2] is not None:
            got = int(dut.rdata.value)
            assert got == pipe[-2], f"cycle {t}: read {got:x}, expected {pipe[-2]:x}"
        await FallingEdge(dut.clock)
        dut.wen.value = 0
