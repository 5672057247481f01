"""The Fmax harness a core is placed in: the core's ports meet registers, not package pins.

Placed alone as a top level, a core's 150 or more ports are package pins that nextpnr spreads around the die, and
the logic behind them follows: the place-and-route Fmax then measures where the pins happen to be. In a user's
design the ports meet fabric logic. So the bench places each Fmax core inside `fmax_harness` (the usual
out-of-context measurement):

- every input is a bit of one shift register fed from a single pin (each copy its own bits, so no two copies are
  the same logic and Yosys cannot merge them);
- every output is registered and XOR-reduced, four bits per register level, to a single pin;
- the core keeps its hierarchy (Yosys `keep_hierarchy`), so nothing is optimised across its ports, and the cells
  the bench reports are the core's alone (`core_cells`: the design's totals less the harness's own cells).

`copies` > 1 places several independent cores in one netlist: the throughput one device gives.
"""
from __future__ import annotations

import re

from mpc_bench.parsers import lpf_frequency, parse_yosys_stat, yosys_module_cells

TOP = "fmax_harness"
_PORT = re.compile(r"^(input|output)\s*(?:(?:wire|logic)\s+)?(?:signed\s+)?(?:\[(\d+):0\])?\s*(\w+)$")


def core_ports(sv: str, module: str) -> list[tuple[str, int, str]]:
    """(direction, width, name) of the ports of `module` in the generator's SystemVerilog (ANSI port list; a port
    without a direction takes the previous one's)."""
    m = re.search(rf"^module {re.escape(module)}\s*\((.*?)\);", sv, re.S | re.M)
    if not m:
        raise ValueError(f"module {module} not found in the SystemVerilog")
    ports: list[tuple[str, int, str]] = []
    for item in re.sub(r"//[^\n]*", "", m.group(1)).split(","):
        s = " ".join(item.split())
        if not s:
            continue
        pm = _PORT.match(s)
        if pm:
            ports.append((pm.group(1), int(pm.group(2)) + 1 if pm.group(2) else 1, pm.group(3)))
        elif re.fullmatch(r"\w+", s) and ports:
            ports.append((ports[-1][0], ports[-1][1], s))
        else:
            raise ValueError(f"unexpected port declaration in {module}: {s!r}")
    return ports


def harness_verilog(sv: str, module: str, copies: int = 1) -> str:
    """Verilog of `fmax_harness` (ports clock, rst_pin, din, dout) around `copies` instances of `module`."""
    ports = core_ports(sv, module)
    names = {n for _, _, n in ports}
    if not {"clock", "reset"} <= names:
        raise ValueError(f"{module} has no clock and reset ports")
    data = [(d, w, n) for d, w, n in ports if n not in ("clock", "reset")]
    n_in = copies * sum(w for d, w, _ in data if d == "input")
    n_out = copies * sum(w for d, w, _ in data if d == "output")
    if not n_in or not n_out:
        raise ValueError(f"{module} has no data inputs or no outputs")
    L = [f"// Fmax harness of {module} ({copies} instance{'s' if copies > 1 else ''}): mpc_bench.harness",
         f"module {TOP}(input clock, input rst_pin, input din, output dout);",
         "  reg reset;",
         "  always @(posedge clock) reset <= rst_pin;",
         f"  reg [{n_in - 1}:0] sh;",
         f"  always @(posedge clock) sh <= {{sh[{n_in - 2}:0], din}};" if n_in > 1 else
         "  always @(posedge clock) sh <= din;",
         f"  wire [{n_out - 1}:0] o;"]
    i = j = 0
    for k in range(copies):
        conns = [".clock(clock)", ".reset(reset)"]
        for d, w, n in data:
            if d == "input":
                conns.append(f".{n}(sh[{i + w - 1}:{i}])")
                i += w
            else:
                conns.append(f".{n}(o[{j + w - 1}:{j}])")
                j += w
        L.append(f"  {module} u{k} (" + ", ".join(conns) + ");")
    L += [f"  reg [{n_out - 1}:0] x0;", "  always @(posedge clock) x0 <= o;"]
    width, level = n_out, 0
    while width > 1:
        nxt = -(-width // 4)
        L.append(f"  reg [{nxt - 1}:0] x{level + 1};")
        for b in range(nxt):
            hi = min(width, 4 * b + 4) - 1
            L.append(f"  always @(posedge clock) x{level + 1}[{b}] <= ^x{level}[{hi}:{4 * b}];")
        width, level = nxt, level + 1
    L += [f"  assign dout = x{level}[0];", "endmodule", ""]
    return "\n".join(L)


def harness_lpf(core_lpf: str) -> str:
    """The harness's constraints: the core's clock frequency (its pin constraints name ports the harness has not)."""
    f = lpf_frequency(core_lpf)
    if f is None:
        raise ValueError("the core's LPF has no FREQUENCY PORT \"clock\" line")
    return f'FREQUENCY PORT "clock" {f:g} MHZ;\n'


def core_cells(stat: str) -> dict[str, int]:
    """The cells of the core(s) in the harness: the design's totals less the harness's own."""
    total, own = parse_yosys_stat(stat), yosys_module_cells(stat, TOP)
    return {k: v - own.get(k, 0) for k, v in total.items() if v - own.get(k, 0)}
