"""The IP-XACT component of a generated core (<module>.component.xml, mpc_cores.ipxact): for a small core of each kind
of the registry (conftest's `small_cores`), the file that the generation flow writes validates against the IEEE
1685-2022 schema (Accellera's XSD files in verif/schema/ipxact-1685-2022, or IPXACT_SCHEMA_DIR; lxml, offline), and it
describes the core: every port of the SystemVerilog module with its direction and width, the AXI4-Lite and AXI4-Stream
bus interfaces mapping every AXI port onto a logical port of ARM's definitions in the right direction, the memory map
with every register and data memory of core.json at its offset, the file sets naming the generated files."""
from __future__ import annotations

import math
import os
import re
from pathlib import Path

import pytest

from mpc_cores import registry
from mpc_cores.flow import REPO
from mpc_cores.ipxact import NS

from lxml import etree  # noqa: E402  (requirements.txt)

# Accellera's IEEE 1685-2022 XSD files (Apache-2.0, LICENSE and NOTICE beside them), kept in the repository so that
# the validation runs offline on any machine; IPXACT_SCHEMA_DIR points elsewhere
SCHEMA_DIR = Path(os.environ.get("IPXACT_SCHEMA_DIR", REPO / "verif" / "schema" / "ipxact-1685-2022"))
N = {"ipxact": NS}

# ARM's AMBA 4 definitions: logical ports of the abstraction -> driven by the initiator (True) or the target
AXIL = {"ACLK": None, "ARESETn": None,
        **{p: True for p in ("AWADDR", "AWPROT", "AWVALID", "WDATA", "WSTRB", "WVALID", "BREADY", "ARADDR", "ARPROT",
                             "ARVALID", "RREADY")},
        **{p: False for p in ("AWREADY", "WREADY", "BRESP", "BVALID", "ARREADY", "RDATA", "RRESP", "RVALID")}}
AXIS = {"ACLK": None, "ARESETn": None, "TREADY": False,
        **{p: True for p in ("TVALID", "TDATA", "TSTRB", "TKEEP", "TLAST", "TID", "TDEST", "TUSER")}}
BUSES = {"s_axil": ("target", ("amba.com", "AMBA4", "AXI4-Lite", "r0p0_0"),
                    ("amba.com", "AMBA4", "AXI4-Lite_rtl", "r0p0_0"), AXIL),
         "s_axis": ("target", ("amba.com", "AMBA4", "AXI4Stream", "r0p0_1"),
                    ("amba.com", "AMBA4", "AXI4Stream_rtl", "r0p0_1"), AXIS),
         "m_axis": ("initiator", ("amba.com", "AMBA4", "AXI4Stream", "r0p0_1"),
                    ("amba.com", "AMBA4", "AXI4Stream_rtl", "r0p0_1"), AXIS)}


@pytest.fixture(scope="module")
def schema():
    index = SCHEMA_DIR / "index.xsd"
    assert index.is_file(), f"IEEE 1685-2022 schema not found at {index}"
    return etree.XMLSchema(etree.parse(str(index)))


@pytest.fixture(params=registry.names())
def generated(request, small_cores):
    """(out_dir, core.json, the component's root element) of the kind's small core"""
    out, core = small_cores[request.param]
    return out, core, etree.parse(str(out / core["ipxact_component"])).getroot()


def _text(e, path: str) -> str:
    return e.findtext(path, namespaces=N)


def _int(s: str) -> int:
    return int(s[2:], 16) if s.startswith("'h") else int(s)


def test_component_validates_against_the_schema(generated, schema):
    out, core, root = generated
    assert core["ipxact_component"] == f"{core['module']}.component.xml"
    assert root.tag == f"{{{NS}}}component"
    schema.assertValid(root.getroottree())
    assert [_text(root, f"ipxact:{k}") for k in ("vendor", "library", "name", "version")] == \
        core["fusesoc_vlnv"].split(":")
    # PeakRDL's memory-map document (IEEE 1685-2014) has another VLNV
    other = etree.parse(str(out / core["ipxact"])).getroot()
    ns = {"ipxact": other.tag.split("}")[0][1:]}
    assert other.findtext("ipxact:library", namespaces=ns) != _text(root, "ipxact:library")


def test_schema_rejects_a_wrong_component(small_cores, schema):
    """The validation is not vacuous: the interface mode of 1685-2014 (master), an unknown access or a register
    without its address offset fails it."""
    out, core = small_cores["fgm"]
    text = (out / core["ipxact_component"]).read_text()
    assert schema.validate(etree.fromstring(text.encode()))
    for old, new in (("<ipxact:initiator />", "<ipxact:master />"), (">read-only<", ">ro<"),
                     ("<ipxact:addressOffset>'h0</ipxact:addressOffset>", "")):
        assert old in text
        assert not schema.validate(etree.fromstring(text.replace(old, new, 1).encode())), old


def test_ports_and_bus_interfaces(generated):
    out, core, root = generated
    m = core["module"]
    header = re.search(rf"^module {m}\s*\((.*?)\);", (out / core["sv"]).read_text(), re.S | re.M)[1]
    sv_names = set(re.findall(r"\b([A-Za-z_]\w*)\b", re.sub(r"\[\d+:\d+\]", "", header))) - {"input", "output"}
    ports = {}
    for p in root.iterfind("ipxact:model/ipxact:ports/ipxact:port", N):
        left = _text(p, "ipxact:wire/ipxact:vectors/ipxact:vector/ipxact:left")
        ports[_text(p, "ipxact:name")] = (_text(p, "ipxact:wire/ipxact:direction"), int(left) + 1 if left else 1)
    assert set(ports) == sv_names
    assert ports["clock"] == ports["reset"] == ("in", 1)
    for p in ("s_axil_awaddr", "s_axil_araddr"):
        assert ports[p] == ("in", core["axil_addr_width"])
    assert ports["s_axil_wdata"] == ("in", 32) and ports["s_axil_rdata"] == ("out", 32)
    assert ports["s_axis_tdata"] == ("in", core["stream_width"]) and ports["m_axis_tdata"] == ("out",
                                                                                             core["stream_width"])
    assert ("s_axis_tuser" in ports) == ("m_axis_tuser" in ports) == (core.get("problems", 1) > 1)
    inst = root.find("ipxact:model/ipxact:instantiations/ipxact:componentInstantiation", N)
    assert _text(inst, "ipxact:moduleName") == m

    maps = root.find("ipxact:memoryMaps", N)
    mapped = []
    bis = root.findall("ipxact:busInterfaces/ipxact:busInterface", N)
    assert {_text(b, "ipxact:name") for b in bis} == set(BUSES)
    for b in bis:
        mode, bus, abstraction, logical = BUSES[_text(b, "ipxact:name")]
        vlnv = lambda e: tuple(e.get(k) for k in ("vendor", "library", "name", "version"))  # noqa: E731
        assert vlnv(b.find("ipxact:busType", N)) == bus
        at = b.find("ipxact:abstractionTypes/ipxact:abstractionType", N)
        assert vlnv(at.find("ipxact:abstractionRef", N)) == abstraction
        mode_el = b.find(f"ipxact:{mode}", N)
        assert mode_el is not None, (b, mode)
        ref = mode_el.find("ipxact:memoryMapRef", N)
        if _text(b, "ipxact:name") == "s_axil":
            assert ref is not None and ref.get("memoryMapRef") in [_text(mm, "ipxact:name") for mm in maps]
        else:
            assert ref is None
        pm = {_text(p, "ipxact:logicalPort/ipxact:name"): (_text(p, "ipxact:physicalPort/ipxact:name"),
                                                           p.get("invert", "false"))
              for p in at.iterfind("ipxact:portMaps/ipxact:portMap", N)}
        assert pm.pop("ACLK") == ("clock", "false") and pm.pop("ARESETn") == ("reset", "true")
        for lg, (phys, _) in pm.items():
            assert lg in logical, (b, lg)
            want = "out" if logical[lg] == (mode == "initiator") else "in"
            assert ports[phys][0] == want, (phys, lg, mode)
            mapped.append(phys)
    assert len(mapped) == len(set(mapped))
    assert set(mapped) == set(ports) - {"clock", "reset"}


def test_memory_map_and_file_sets(generated):
    out, core, root = generated
    block = root.find("ipxact:memoryMaps/ipxact:memoryMap/ipxact:addressBlock", N)
    assert _int(_text(block, "ipxact:baseAddress")) == 0 and _text(block, "ipxact:width") == "32"
    regs = {}
    for r in block.iterfind("ipxact:register", N):
        dims = tuple(int(d.text) for d in r.iterfind("ipxact:array/ipxact:dim", N))
        stride = _int(_text(r, "ipxact:array/ipxact:stride") or "4")
        fields = {_text(f, "ipxact:name"): (int(_text(f, "ipxact:bitOffset")), int(_text(f, "ipxact:bitWidth")),
                                            _int(_text(f, "ipxact:resets/ipxact:reset/ipxact:value"))
                                            if f.find("ipxact:resets", N) is not None else None)
                  for f in r.iterfind("ipxact:field", N)}
        regs[_text(r, "ipxact:name")] = (_int(_text(r, "ipxact:addressOffset")), dims, stride, fields)
    assert set(regs) == {r["name"] for r in core["registers"]} | set(core["regions"])
    for r in core["registers"]:
        offset, dims, _, fields = regs[r["name"]]
        assert (offset, dims) == (r["offset"], ()), r["name"]
        assert fields == {f["name"]: (f["lsb"], f["width"], f.get("reset")) for f in r["fields"]}, r["name"]
    for nm, g in core["regions"].items():
        offset, dims, stride, _ = regs[nm]
        assert (offset, list(dims)) == (g["offset"], g["dims"]), nm
    extent = max(o + 4 + s * (math.prod(d) - 1) for o, d, s, _ in regs.values())
    assert extent <= _int(_text(block, "ipxact:range")) <= 2 ** core["axil_addr_width"]

    files = {_text(fs, "ipxact:name"): [_text(f, "ipxact:name") for f in fs.iterfind("ipxact:file", N)]
             for fs in root.iterfind("ipxact:fileSets/ipxact:fileSet", N)}
    assert files == {"rtl": [core["sv"]], "sw": [core["header"]] + core.get("driver", []), "regmap": [core["rdl"]]}
    for f in sum(files.values(), []):
        assert (out / f).is_file(), f
