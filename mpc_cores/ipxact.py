"""IP-XACT component (IEEE 1685-2022) of a generated core, <module>.component.xml beside the SystemVerilog: the
ports of the top module (parsed from the .sv), the bus interfaces with ARM's AMBA 4 bus definitions (AXI4-Lite
target on s_axil_*, AXI4-Stream target on s_axis_* and initiator on m_axis_*, clock and the inverted reset mapped to
ACLK and ARESETn of each), the memory map (from the .rdl, as the RTL register file decodes it), the file sets
(SystemVerilog, C header, SystemRDL), a view with the module name, and a few parameters from core.json.

The same writer serves every kind: the bus interfaces follow from the port-name prefixes, the memory map from the
.rdl. docs/ipxact.md describes the choices; tests/test_ipxact.py validates the file against the standard's schema.
"""
from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path

NS = "http://www.accellera.org/XMLSchema/IPXACT/1685-2022"
XSI = "http://www.w3.org/2001/XMLSchema-instance"
SCHEMA_LOCATION = f"{NS} {NS}/index.xsd"

# ARM's IP-XACT definitions of the AMBA 4 buses (the VLNVs of ARM's published bus and abstraction definitions)
AXI4_LITE = (("amba.com", "AMBA4", "AXI4-Lite", "r0p0_0"), ("amba.com", "AMBA4", "AXI4-Lite_rtl", "r0p0_0"))
AXI4_STREAM = (("amba.com", "AMBA4", "AXI4Stream", "r0p0_1"), ("amba.com", "AMBA4", "AXI4Stream_rtl", "r0p0_1"))

# port-name prefix -> (bus interface name, (bus type, abstraction type), interface mode, memory-mapped)
BUSES = {
    "s_axil_": ("s_axil", AXI4_LITE, "target", True),
    "s_axis_": ("s_axis", AXI4_STREAM, "target", False),
    "m_axis_": ("m_axis", AXI4_STREAM, "initiator", False),
}
CLOCK, RESET = "clock", "reset"    # Chisel's implicit clock and synchronous active-high reset

# file sets: (name, core.json key of the file or the list of files, IP-XACT file type, include file; None: the .h
# files); the driver's files join the C header's set
FILESETS = (("rtl", "sv", "systemVerilogSource", False),
            ("sw", "header", "cSource", True),
            ("sw", "driver", "cSource", None),
            ("regmap", "rdl", "systemRDL-2.0", False))

# component parameters: (core.json key, parameter name, description); absent keys are left out
PARAMETERS = (("stream_width", "STREAM_WIDTH", "bits of tdata on s_axis and m_axis"),
              ("axil_addr_width", "AXIL_ADDR_WIDTH", "bits of the AXI4-Lite byte address"),
              ("problems", "PROBLEMS", "problems interleaved on the datapath (problem id on tuser when more than 1)"),
              ("iterations", "IMAX", "iterations per solve at reset (register IMAX)"))

_ACCESS = {"r": "read-only", "w": "write-only", "rw": "read-write"}


def file_name(module: str) -> str:
    return f"{module}.component.xml"


def sv_ports(sv_text: str, module: str) -> list[tuple[str, str, int]]:
    """(name, direction "in"/"out"/"inout", width) of each port of `module` in SystemVerilog text, in order (an ANSI
    port list; a declaration without a direction takes the previous one's direction and range)."""
    m = re.search(rf"^\s*module\s+{re.escape(module)}\s*\((.*?)\);", sv_text, re.S | re.M)
    if m is None:
        raise ValueError(f"module {module} not found")
    body = re.sub(r"//[^\n]*|/\*.*?\*/", "", m[1], flags=re.S)
    ports, direction, width = [], None, 1
    for item in filter(str.strip, body.split(",")):
        d = re.fullmatch(r"\s*(input|output|inout)?\s*(?:wire\s+|logic\s+)?(?:\[(\d+)\s*:\s*(\d+)\])?\s*(\w+)\s*",
                         item)
        if d is None:
            raise ValueError(f"module {module}: cannot read port declaration {item.strip()!r}")
        if d[1]:
            direction, width = {"input": "in", "output": "out", "inout": "inout"}[d[1]], 1
        if d[2] is not None:
            width = abs(int(d[2]) - int(d[3])) + 1
        if direction is None:
            raise ValueError(f"module {module}: port {d[4]} without a direction")
        ports.append((d[4], direction, width))
    return ports


def _el(parent, tag: str, text=None, **attrib):
    e = ET.SubElement(parent, f"{{{NS}}}{tag}", {k.rstrip("_"): str(v) for k, v in attrib.items()})
    if text is not None:
        e.text = str(text)
    return e


def _named(parent, tag: str, name: str, desc: str = ""):
    e = _el(parent, tag)
    _el(e, "name", name)
    if desc:
        _el(e, "description", desc)
    return e


def _vlnv(parent, tag: str, vlnv):
    return _el(parent, tag, vendor=vlnv[0], library=vlnv[1], name=vlnv[2], version=vlnv[3])


def _port_map(parent, logical: str, physical: str, invert: bool = False):
    pm = _el(parent, "portMap", **({"invert": "true"} if invert else {}))
    _el(_el(pm, "logicalPort"), "name", logical)
    _el(_el(pm, "physicalPort"), "name", physical)


def _bus_interfaces(comp, ports, memory_map: str) -> None:
    names = {p for p, _, _ in ports}
    bis = _el(comp, "busInterfaces")
    for prefix, (name, (bus, abstraction), mode, mapped) in BUSES.items():
        members = [p for p, _, _ in ports if p.startswith(prefix)]
        if not members:
            continue
        bi = _named(bis, "busInterface", name)
        _vlnv(bi, "busType", bus)
        at = _el(_el(bi, "abstractionTypes"), "abstractionType")
        _vlnv(at, "abstractionRef", abstraction)
        pms = _el(at, "portMaps")
        if CLOCK in names:
            _port_map(pms, "ACLK", CLOCK)
        if RESET in names:
            _port_map(pms, "ARESETn", RESET, invert=True)
        for p in members:
            _port_map(pms, p[len(prefix):].upper(), p)
        m = _el(bi, mode)
        if mapped:
            _el(m, "memoryMapRef", memoryMapRef=memory_map)


def _memory_map(comp, name: str, rdl: Path) -> None:
    from mpc_cores.regmap import compile_rdl, read_rdl

    top = compile_rdl(rdl)
    _, regs = read_rdl(rdl)
    mm = _named(_el(comp, "memoryMaps"), "memoryMap", name)
    ab = _named(mm, "addressBlock", name, top.get_property("desc") or "")
    _el(ab, "baseAddress", "'h0")
    _el(ab, "range", f"'h{top.size:x}")
    _el(ab, "width", 32)
    _el(ab, "usage", "register")
    for r in regs.values():
        reg = _named(ab, "register", r.name, r.desc)
        if r.dims:
            arr = _el(reg, "array")
            for d in r.dims:
                _el(arr, "dim", d)
            _el(arr, "stride", r.stride)
        _el(reg, "addressOffset", f"'h{r.offset:x}")
        _el(reg, "size", 32)
        _el(reg, "volatile", str(any(f.hw == "w" for f in r.fields.values())).lower())
        for f in sorted(r.fields.values(), key=lambda f: f.lsb):
            fe = _named(reg, "field", f.name, f.desc)
            _el(fe, "bitOffset", f.lsb)
            _el(fe, "bitWidth", f.width)
            _el(fe, "volatile", str(f.hw == "w").lower())
            if f.reset is not None:
                _el(_el(_el(fe, "resets"), "reset"), "value", f"'h{f.reset:x}")
            pol = _el(_el(fe, "fieldAccessPolicies"), "fieldAccessPolicy")
            _el(pol, "access", _ACCESS[f.sw])
            if f.w1c:
                _el(pol, "modifiedWriteValue", "oneToClear")


def component(out, core: dict) -> ET.Element:
    """The component element of the core generated into `out` (core.json `core`)."""
    from mpc_cores.fusesoc import VENDOR, VERSION

    out = Path(out)
    m = core["module"]
    ports = sv_ports((out / core["sv"]).read_text(), m)
    ET.register_namespace("ipxact", NS)
    ET.register_namespace("xsi", XSI)
    comp = ET.Element(f"{{{NS}}}component", {f"{{{XSI}}}schemaLocation": SCHEMA_LOCATION})
    for tag, v in (("vendor", VENDOR), ("library", core["core"]), ("name", m), ("version", VERSION)):
        _el(comp, tag, v)
    _el(comp, "description", f"{core['core'].upper()} core '{core['name']}' generated by mpc-cores: AXI4-Lite "
                             f"registers and data memories, AXI4-Stream parameters in and solutions out")
    _bus_interfaces(comp, ports, "regs")
    _memory_map(comp, "regs", out / core["rdl"])

    model = _el(comp, "model")
    _el(_named(_el(model, "views"), "view", "rtl"), "componentInstantiationRef", "rtl")
    inst = _named(_el(model, "instantiations"), "componentInstantiation", "rtl")
    _el(inst, "language", "SystemVerilog")
    _el(inst, "moduleName", m)
    _el(_el(inst, "fileSetRef"), "localName", "rtl")
    pe = _el(model, "ports")
    for name, direction, width in ports:
        wire = _el(_named(pe, "port", name), "wire")
        _el(wire, "direction", direction)
        if name == CLOCK:
            _el(_el(wire, "qualifier"), "isClock", "true")
        elif name == RESET:
            _el(_el(wire, "qualifier"), "isReset", "true", level="high")
        if width > 1:
            vec = _el(_el(wire, "vectors"), "vector")
            _el(vec, "left", width - 1)
            _el(vec, "right", 0)

    fss = _el(comp, "fileSets")
    sets: dict[str, list] = {}
    for fs_name, key, ftype, include in FILESETS:
        v = core.get(key)
        for name in [v] if isinstance(v, str) else (v or []):
            sets.setdefault(fs_name, []).append((name, ftype, name.endswith(".h") if include is None else include))
    for fs_name, files in sets.items():
        fs = _named(fss, "fileSet", fs_name)
        for name, ftype, include in files:
            f = _el(fs, "file")
            _el(f, "name", name)
            _el(f, "fileType", ftype)
            if include:
                _el(f, "isIncludeFile", "true")

    params = [(n, core[k], d) for k, n, d in PARAMETERS if isinstance(core.get(k), int)]
    if params:
        pe = _el(comp, "parameters")
        for n, v, d in params:
            p = _el(pe, "parameter", parameterId=n, resolve="immediate", type="longint")
            _el(p, "name", n)
            _el(p, "description", d)
            _el(p, "value", v)
    return comp


def write_component(out, core: dict) -> dict:
    """Write <out>/<module>.component.xml; returns the core.json entry naming it."""
    comp = component(out, core)
    ET.indent(comp, "  ")
    name = file_name(core["module"])
    tmp = Path(out) / (name + ".tmp")
    tmp.write_text('<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(comp, encoding="unicode") + "\n",
                   encoding="utf-8")
    tmp.replace(Path(out) / name)
    return {"ipxact_component": name}
