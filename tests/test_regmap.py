"""The register map from one description: for a small generated core of each kind, the SystemRDL file the generator
writes agrees with the RTL (verif/regs_tb.py over AXI4-Lite in Verilator), with hw.json/core.json and with the
documented address arithmetic of the data memories; its PeakRDL exports are usable (the C header compiles with
gcc and places every register at its offset, the IP-XACT parses and names the registers).

The cores are conftest's `small_cores`: one small core of every kind of the registry (conftest.suite_kinds;
tests/test_suites.py checks that none is left out).
"""
from __future__ import annotations

import itertools
import shutil
import subprocess
import xml.etree.ElementTree as ET

import pytest

from conftest import suite_kinds
from mpc_cores import registry
from mpc_cores.flow import REPO
from mpc_cores.regmap import Regmap
from mpc_cores.sim import run_cocotb

KINDS = suite_kinds("regmap")
SCENARIOS = 4  # cocotb tests in verif/regs_tb.py
SHARED = ("ID", "CONFIG0", "CONFIG1", "CTRL", "IMAX", "STATUS", "SOLVES", "LAST_CYCLES", "CYCLES_PER_ITER")
# the data-memory layouts (README): the regions that name one -> its address formula in
# test_region_addresses_follow_the_documented_layout; a core without data memories has none
LAYOUTS = {"fgm": {"MAT_A", "MAT_F", "UBOX", "XBOX"}, "admm": {"MAT_M", "MAT_G", "BND", "WBOX"}}


@pytest.fixture(params=KINDS)
def generated(request, small_cores):
    return small_cores[request.param]


def test_outputs_named_in_core_json(generated):
    out, core = generated
    m = core["module"]
    assert (core["rdl"], core["header"], core["regmap_doc"], core["ipxact"]) == (
        f"{m}.rdl", f"{m}.h", f"{m}_regs.md", f"{m}.xml")
    for k in ("sv", "rdl", "header", "regmap_doc", "ipxact"):
        assert (out / core[k]).is_file(), k


def test_rdl_agrees_with_core_json(generated):
    """Registers and regions of core.json (from hw.json) are those of the RDL, with the same offsets, and the
    CONFIG fields hold the core's sizes."""
    out, core = generated
    rm = Regmap.for_core(out, core)
    assert rm.name == core["module"]
    regs = {r["name"]: r for r in core["registers"]}
    assert list(regs)[:len(SHARED)] == list(SHARED)
    assert set(regs) | set(core["regions"]) == set(rm.regs)
    for nm, r in regs.items():
        assert rm[nm] == r["offset"], nm
        assert not rm.regs[nm].external
        assert {f["name"]: (f["lsb"], f["width"], f.get("reset")) for f in r["fields"]} == \
            {f.name: (f.lsb, f.width, f.reset) for f in rm.regs[nm].fields.values()}, nm
    for nm, g in core["regions"].items():
        a = rm.regs[nm]
        assert a.external and a.offset == g["offset"] and list(a.dims) == g["dims"], nm
        assert a.addr(*(d - 1 for d in a.dims)) < g["offset"] + g["bytes"], nm
    # the CONFIG fields named after core.json entries hold them (P, n, nw, frac_bits, nu, N, T, m; ADMM: n_A = n)
    config = {f.name: f.reset for r in ("CONFIG0", "CONFIG1") for f in rm.regs[r].fields.values()}
    named = {k: v for k, v in config.items() if k in core}
    assert named == {k: core[k] for k in named} and len(named) >= 3, (config, named)
    if "n_A" in config:
        assert config["n_A"] == core["n"]
    if core["core"] == "minres":
        assert (rm.reset("CONFIG0", "N"), rm.reset("CONFIG1", "T")) == (core["N"], core["T"])
        assert rm.STATUS_BITS["NONFINITE"] == 6 and "WARM_VALID" not in rm.STATUS_BITS
    elif core["core"] == "ipm":
        assert (rm.reset("CONFIG0", "N"), rm.reset("CONFIG1", "T")) == (core["N"], core["T"])
        assert (rm.reset("IMAX", "IMAX"), rm.reset("INW", "INW")) == (core["iterations"], core["i_nw"])
        assert [rm.STATUS_BITS[k] for k in ("NONFINITE", "NOT_CONVERGED", "CHANNEL")] == [6, 7, 8]
    else:
        assert rm.reset("CONFIG1", "nw") == core["nw"] and rm.reset("CONFIG1", "frac_bits") == core["frac_bits"]
        assert rm.reset("IMAX", "IMAX") == core["iterations"]
        assert rm.reset("CTRL", "WARM_START") == int(core["warm_start"])
        assert rm.reset("CYCLES_PER_ITER", "CYCLES") == core["cycles_per_iteration"]


def test_region_addresses_follow_the_documented_layout(generated):
    """Every element address from the array dimensions equals the README's formula on core.json's bases:
    FGM base + ((slot(i) << COL_BITS | j) << 2), slot(i) = (i / P) << P_BITS | i % P; ADMM base + ((i << COL_BITS
    | j) << 2); the bound and box regions base + ((row << 1 | hi) << 2)."""
    out, core = generated
    rm = Regmap.for_core(out, core)
    base = {k: v["offset"] for k, v in core["regions"].items()}
    P, cb = core.get("P", 1), core.get("col_bits", 0)
    slot = lambda i: ((i // P) << core.get("p_bits", 0)) | (i % P)  # noqa: E731
    layout = [name for name, regions in LAYOUTS.items() if regions == set(base)]
    assert layout or not base, f"regions {sorted(base)}: no documented layout"
    if layout == ["fgm"]:
        n, nw = core["n"], core["nw"]
        for i, j in itertools.product(range(n), range(max(n, nw))):
            assert rm.mat_a(i, j) == base["MAT_A"] + (((slot(i) << cb) | j) << 2)
            assert rm.mat_f(i, j) == base["MAT_F"] + (((slot(i) << cb) | j) << 2)
        for i, hi in itertools.product(range(n), (0, 1)):
            assert rm.ubox(i, hi) == base["UBOX"] + (((slot(i) << 1) | hi) << 2)
        for j, hi in itertools.product(range(nw), (0, 1)):
            assert rm.xbox(j, hi) == base["XBOX"] + (((j << 1) | hi) << 2)
    elif layout == ["admm"]:
        n, nw = core["n"], core["nw"]
        for i, j in itertools.product(range(n), range(max(n, nw + 1))):
            assert rm.mat_m(i, j) == base["MAT_M"] + (((i << cb) | j) << 2)
            assert rm.mat_g(i, j) == base["MAT_G"] + (((i << cb) | j) << 2)
        for i, hi in itertools.product(range(n), (0, 1)):
            assert rm.bnd(i, hi) == base["BND"] + (((i << 1) | hi) << 2)
        for j, hi in itertools.product(range(nw), (0, 1)):
            assert rm.wbox(j, hi) == base["WBOX"] + (((j << 1) | hi) << 2)
    else:
        assert not core["regions"]


def test_c_header_compiles_with_the_offsets(generated, tmp_path):
    """The PeakRDL header compiles, and its register struct puts every register and data memory at the offset of
    core.json (checked by gcc: offsetof in static assertions); it defines the STATUS and CTRL bit positions."""
    if shutil.which("gcc") is None:
        pytest.skip("gcc not found")
    out, core = generated
    hdr = out / core["header"]
    subprocess.run(["gcc", "-fsyntax-only", "-x", "c", str(hdr)], check=True, capture_output=True, text=True)
    m = core["module"]
    checks = [f'_Static_assert(offsetof({m}_t, {r["name"]}) == {r["offset"]}, "{r["name"]}");'
              for r in core["registers"]]
    checks += [f'_Static_assert(offsetof({m}_t, {k}) == {g["offset"]}, "{k}");' for k, g in core["regions"].items()]
    src = tmp_path / "offsets.c"
    src.write_text(f'#include <stddef.h>\n#include "{hdr.name}"\n' + "\n".join(checks) + "\n")
    p = subprocess.run(["gcc", "-fsyntax-only", "-I", str(out), str(src)], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    text = hdr.read_text()
    pfx = m.upper()
    rm = Regmap.for_core(out, core)
    for reg in ("STATUS", "CTRL"):
        for f, b in rm.bits(reg).items():
            assert f"#define {pfx}__{reg}__{f}_bp {b}\n" in text, (reg, f)


def test_ipxact_names_the_registers(generated):
    out, core = generated
    root = ET.parse(out / core["ipxact"]).getroot()
    ns = {"ipxact": root.tag.split("}")[0].strip("{")}
    regs = {r.findtext("ipxact:name", namespaces=ns): r.findtext("ipxact:addressOffset", namespaces=ns)
            for r in root.iterfind(".//ipxact:register", ns)}
    assert root.findtext("ipxact:name", namespaces=ns) == core["module"]
    want = {r["name"]: r["offset"] for r in core["registers"]}
    want.update({k: g["offset"] for k, g in core["regions"].items()})
    assert {k: int(v.replace("'h", ""), 16) for k, v in regs.items()} == want


def test_regmap_doc(generated):
    """The register reference lists each register once and each data memory once with its dimensions."""
    out, core = generated
    text = (out / core["regmap_doc"]).read_text()
    for r in core["registers"]:
        assert f"### {r['name']} register" in text
    for k, g in core["regions"].items():
        assert text.count(f"### {k} register") == 1
        assert f"Array Dimensions: {g['dims']}" in text


def test_readback_over_axi(generated):
    """verif/regs_tb.py on the core in Verilator: reset values, access rules and error responses as the RDL says."""
    out, core = generated
    tests, failed = run_cocotb(out / core["sv"], core["module"], "verif.regs_tb", out / "sim",
                               {"CORE_OUT": str(out)})
    assert tests == SCENARIOS, f"{tests} cocotb tests ran, expected {SCENARIOS}"
    assert failed == 0, f"{failed} of {tests} scenarios failed: see {out / 'sim' / 'sim.log'}"


# the docs page of each kind with a page of its own (CoreKind.docs_page; ama and vucondat share admm's)
PAGES = {n: k.docs_page.removeprefix("docs/") for n, k in registry.kinds().items() if k.docs_page == f"docs/{n}.md"}
TEMPLATE = ["What it solves", "Theory of operation", "Ports", "Registers", "Programmer's guide", "Latency and resources",
            "Verification"]


def test_docs_page_follows_the_template_with_the_generated_registers(generated):
    """The kind's page has the template's sections in order (docs/verification.md, Docs pages) and its Registers section
    holds the register table generated from the kind's register map (mpc_cores.regmap.markdown_table)"""
    from mpc_cores.regmap import markdown_table

    out, core = generated[0], generated[1]
    if core["core"] not in PAGES:
        pytest.skip(f"{core['core']} shares {PAGES['admm']}")
    text = (REPO / "docs" / PAGES[core["core"]]).read_text()
    assert [ln[3:].strip() for ln in text.splitlines() if ln.startswith("## ")] == TEMPLATE
    begin = f"<!-- registers: rendered from the {core['core']} core's register map -->\n"
    assert begin in text, "no generated register table"
    got = text.split(begin, 1)[1].split("<!-- /registers -->", 1)[0]
    assert got == markdown_table(core), f"docs/{PAGES[core['core']]}: the register table is stale"
