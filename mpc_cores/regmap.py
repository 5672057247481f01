"""The register map of a generated core, from its SystemRDL description <module>.rdl (written by the generator from
the same description as the RTL register file): the PeakRDL exports (C header, register reference, IP-XACT) and
`Regmap`, the byte addresses and bit positions the testbenches use.

Data memories are `external` register arrays: element [i0][i1]..[ik] of an array at byte address B with
dimensions [d0][d1]..[dk] and stride s is at B + s ((i0 d1 + i1) d2 + .. + ik).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path


@dataclass(frozen=True)
class Field:
    name: str
    lsb: int
    width: int
    sw: str              # "r", "rw" or "w"
    w1c: bool            # writing 1 clears it
    reset: int | None
    desc: str
    hw: str = "r"        # hardware access: "r" (the core uses it), "w" (the core sets it) or "na" (a constant)

    @property
    def readable(self) -> bool:
        return self.sw != "w"

    @property
    def writable(self) -> bool:
        return self.sw != "r"

    @property
    def mask(self) -> int:
        return ((1 << self.width) - 1) << self.lsb


@dataclass(frozen=True)
class Register:
    name: str
    offset: int                      # byte address; of the first element for an array
    fields: dict[str, Field]
    desc: str
    dims: tuple[int, ...] = ()       # array dimensions (external data memories); () for a register
    stride: int = 4

    @property
    def readable(self) -> bool:
        return any(f.readable for f in self.fields.values())

    @property
    def writable(self) -> bool:
        return any(f.writable for f in self.fields.values())

    @property
    def external(self) -> bool:
        return bool(self.dims)

    def addr(self, *idx: int) -> int:
        """Byte address of element idx of an array."""
        if len(idx) != len(self.dims):
            raise IndexError(f"{self.name}{''.join(f'[{d}]' for d in self.dims)}: {len(idx)} indices given")
        flat = 0
        for i, d in zip(idx, self.dims):
            if not 0 <= i < d:
                raise IndexError(f"{self.name}: index {tuple(idx)} outside {self.dims}")
            flat = flat * d + i
        return self.offset + self.stride * flat


def _access(f) -> str:
    return "rw" if f.is_sw_readable and f.is_sw_writable else ("r" if f.is_sw_readable else "w")


@lru_cache(maxsize=16)
def _compile(path: str, mtime_ns: int):
    from systemrdl import RDLCompiler

    rdlc = RDLCompiler()
    rdlc.compile_file(path)
    return rdlc.elaborate().top


def compile_rdl(path) -> "systemrdl.node.AddrmapNode":  # noqa: F821
    """The elaborated top addrmap of a .rdl file (cached while the file is unchanged)."""
    p = Path(path).resolve()
    return _compile(str(p), p.stat().st_mtime_ns)


def read_rdl(path) -> tuple[str, dict[str, Register]]:
    """(addrmap name, registers and arrays by name, in address order) of a .rdl file."""
    from systemrdl.rdltypes import OnWriteType

    top = compile_rdl(path)
    regs = {}
    for r in top.registers(unroll=False):
        fields = {f.inst_name: Field(f.inst_name, f.lsb, f.width, _access(f),
                                     f.get_property("onwrite") == OnWriteType.woclr, f.get_property("reset"),
                                     f.get_property("desc") or "", f.get_property("hw").name)
                  for f in r.fields()}
        dims = tuple(r.array_dimensions) if r.is_array else ()
        regs[r.inst_name] = Register(r.inst_name, r.raw_absolute_address, fields, r.get_property("desc") or "", dims,
                                     r.array_stride if r.is_array else 4)
    return top.inst_name, dict(sorted(regs.items(), key=lambda kv: kv[1].offset))


class Regmap:
    """Byte addresses and bit positions of a core's registers and data memories, from its .rdl.

    rm["STATUS"] is a register's byte address (an array's base), rm.addr("MAT_A", k, u, j) an element's;
    rm.STATUS_BITS and rm.CTRL_BITS give bit positions by field name; mat_a, mat_f, ubox, xbox (FGM) and mat_m,
    mat_g, bnd, wbox (ADMM) address the data memories by matrix row and column."""

    def __init__(self, rdl):
        self.name, self.regs = read_rdl(rdl)
        self.STATUS_BITS = self.bits("STATUS")
        self.CTRL_BITS = self.bits("CTRL")
        # row units of the FGM and ADMM maps (the DGP core has one)
        self.P = self.reset("CONFIG0", "P") if "P" in self.regs["CONFIG0"].fields else 1
        mat = next((self.regs[k] for k in ("MAT_A", "MAT_M") if k in self.regs), None)
        self.cb = int(math.log2(mat.dims[-1])) if mat else 0   # column bits of the matrix memories

    @classmethod
    def for_core(cls, out, core: dict) -> "Regmap":
        """The register map of the core generated into `out` (core.json's "rdl")."""
        return cls(Path(out) / core.get("rdl", f"{core['module']}.rdl"))

    def __getitem__(self, name: str) -> int:
        return self.regs[name].offset

    def __contains__(self, name: str) -> bool:
        return name in self.regs

    def addr(self, name: str, *idx: int) -> int:
        return self.regs[name].addr(*idx)

    def bits(self, reg: str) -> dict[str, int]:
        """Bit position of each one-bit field of `reg`."""
        return {f.name: f.lsb for f in self.regs[reg].fields.values() if f.width == 1}

    def reset(self, reg: str, field: str) -> int | None:
        return self.regs[reg].fields[field].reset

    def status(self, word: int) -> dict:
        return {k: bool(word >> b & 1) for k, b in self.STATUS_BITS.items()}

    # ---- FGM: row i of a matrix lives in row unit i % P at slot i / P
    def mat_a(self, i: int, j: int) -> int:
        """(I - H_n)[i][j]"""
        return self.addr("MAT_A", i // self.P, i % self.P, j)

    def mat_f(self, i: int, j: int) -> int:
        """Phi_n[i][j]"""
        return self.addr("MAT_F", i // self.P, i % self.P, j)

    def ubox(self, i: int, hi: bool) -> int:
        return self.addr("UBOX", i // self.P, i % self.P, int(hi))

    def xbox(self, j: int, hi: bool) -> int:
        return self.addr("XBOX", j, int(hi))

    # ---- ADMM: rows addressed by component index
    def mat_m(self, i: int, j: int) -> int:
        """M11[i][j]"""
        return self.addr("MAT_M", i, j)

    def mat_g(self, i: int, j: int) -> int:
        """G~[i][j], j over (x, u_prev, r, 1)"""
        return self.addr("MAT_G", i, j)

    def bnd(self, i: int, hi: bool) -> int:
        """(lo, hi) of a box component, (centre, radius) at a soft pair's slack"""
        return self.addr("BND", i, int(hi))

    def wbox(self, j: int, hi: bool) -> int:
        return self.addr("WBOX", j, int(hi))


def _markdown_exporter():
    """PeakRDL-markdown, with each register array described once (its dimensions and stride) instead of once per
    element: a data memory has up to tens of thousands of elements."""
    from peakrdl_markdown import MarkdownExporter

    class Exporter(MarkdownExporter):
        def _add_addrmap_regfile_mem(self, node, msg, depth):
            children = node.children

            def folded(unroll=False, skip_not_present=True):
                for c in children(unroll=False, skip_not_present=skip_not_present):
                    if getattr(c, "is_array", False):
                        c.current_idx = [0] * len(c.array_dimensions)
                    yield c

            node.children = folded
            try:
                return super()._add_addrmap_regfile_mem(node, msg, depth)
            finally:
                del node.children

        def _addrnode_table_row(self, node):
            row = super()._addrnode_table_row(node)
            if node.is_array:
                row["Identifier"] = node.inst_name + "".join(f"[{d}]" for d in node.array_dimensions)
            return row

    return Exporter()


def export(out, core: dict) -> dict:
    """Compile <out>/<module>.rdl and write what PeakRDL makes of it: the C header <module>.h, the register
    reference <module>_regs.md and the IP-XACT memory map <module>.xml (IEEE 1685-2014, a component with the
    memory map only; the core's full component is mpc_cores.ipxact's). Returns the core.json entries naming the
    four files."""
    from peakrdl_cheader.exporter import CHeaderExporter
    from peakrdl_ipxact import IPXACTExporter

    from mpc_cores.fusesoc import VENDOR, VERSION

    out = Path(out)
    m = core["module"]
    files = {"rdl": f"{m}.rdl", "header": f"{m}.h", "regmap_doc": f"{m}_regs.md", "ipxact": f"{m}.xml"}
    top = compile_rdl(out / files["rdl"])
    CHeaderExporter().export(top, str(out / files["header"]))
    _markdown_exporter().export(top, str(out / files["regmap_doc"]), input_files=[files["rdl"]])
    # library <kind>-regmap: the VLNV of the core's own IP-XACT component (mpc_cores.ipxact) is not repeated
    IPXACTExporter(vendor=VENDOR, library=f"{core['core']}-regmap", version=VERSION).export(
        top, str(out / files["ipxact"]))
    return files


def markdown_table(core: dict) -> str:
    """The registers of a core as a table for its docs page (offset, name, access, description, fields by bits) and
    the names of its data regions, generated from core.json (the generator's register map, as in the .rdl); the
    size-dependent values (resets, region bases) are left to the core's own core.json and .rdl"""
    lines = ["| offset | register | access | description | fields |", "|---|---|---|---|---|"]
    for r in core["registers"]:
        fields = ", ".join(f"{f['name']} [{f['lsb'] + f['width'] - 1}:{f['lsb']}]" if f["width"] > 1
                           else f"{f['name']} [{f['lsb']}]" for f in r["fields"])
        lines.append(f"| 0x{r['offset']:02X} | {r['name']} | {r['access']} | {r['desc']} | {fields} |")
    regions = list(core.get("regions", {}))
    lines += ["", "Data regions (write-only; bases in core.json and the .rdl): " + (", ".join(regions) or "none") + "."]
    return "\n".join(lines) + "\n"
