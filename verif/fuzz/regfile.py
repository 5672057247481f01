"""What a core's register file must answer over AXI4-Lite, from its SystemRDL description (mpc_cores.regmap) and the
write rules of docs/registers.md, for the protocol fuzz.

Every word address of the port is one of: a register; an element of a data memory (an external array of the
RDL); a gap (inside a data memory's power-of-two span, past its elements: the RDL maps nothing there); unmapped.
Reads: a readable register answers OKAY with its fields, 0 between them; every other address DECERR. Writes: a
register with read-write fields OKAY (the fields take the value; a write-1-to-clear bit is cleared by a 1; a
register whose description says "writing 0 or more than N: SLVERR" refuses those values); a read-only register
DECERR, unchanged; write-only data (registers and memory elements) SLVERR while the core is busy or when the value
does not fit the word its field names ("must fit N bits"), setting STATUS.WRITE_REJECTED; an element the core
has no word for DECERR; unmapped DECERR. wstrb is ignored: every write is a whole word.

The model keeps the software-visible state (read-write fields, sticky flags) after each write, in the order the
writes are taken, so that a read overlapping writes may see any state between the writes answered before it was
issued and those issued before its answer.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

from cocotbext.axi import AxiResp

from mpc_cores.regmap import Register

RANGE = re.compile(r"writing 0 or more than (\d+): SLVERR")
FITS = re.compile(r"must fit (\d+) bits")
OKAY, SLVERR, DECERR = AxiResp.OKAY, AxiResp.SLVERR, AxiResp.DECERR


@dataclass(frozen=True)
class Address:
    byte: int
    kind: str                      # "reg", "data" (write-only register or memory element), "gap", "unmapped"
    reg: Register | None = None
    fit: int | None = None         # data: the signed width a value must fit

    @property
    def name(self) -> str:
        return self.reg.name if self.reg else f"{self.byte:#x}"


def _pow2(x: int) -> int:
    return 1 << max(0, (x - 1).bit_length())


class RegFile:
    def __init__(self, rm, addr_bits: int):
        self.rm = rm
        self.addr: dict[int, Address] = {}
        for r in rm.regs.values():
            fit = next((int(m.group(1)) for f in r.fields.values() if (m := FITS.search(f.desc))), None)
            if r.external:
                n = 1
                for d in r.dims:
                    n *= d
                for k in range(_pow2(n)):
                    b = r.offset + r.stride * k
                    self.addr[b] = Address(b, "data" if k < n else "gap", r, fit)
            else:
                self.addr[r.offset] = Address(r.offset, "data" if not r.readable else "reg", r, fit)
        for b in range(0, 1 << addr_bits, 4):
            self.addr.setdefault(b, Address(b, "unmapped"))
        # the state software sees: read-write and write-1-to-clear fields, per register
        self.tracked = {r.name: [f for f in r.fields.values() if f.sw == "rw"]
                        for r in rm.regs.values() if not r.external and any(f.sw == "rw" for f in r.fields.values())}
        state = {f"{r}.{f.name}": f.reset for r, fs in self.tracked.items() for f in fs}
        self.snaps: list[dict[str, int]] = [state]

    @property
    def state(self) -> dict[str, int]:
        return self.snaps[-1]

    def reset(self):
        self.snaps = [self.snaps[0]]

    def groups(self) -> dict[str, list[Address]]:
        """Addresses by kind."""
        out: dict[str, list[Address]] = {}
        for a in self.addr.values():
            out.setdefault(a.kind, []).append(a)
        return out

    # ---- writes
    def expect_write(self, a: Address, value: int, busy: bool) -> set[AxiResp]:
        """The responses allowed for writing `value` to `a` while the core is `busy` (True, False, or None when
        it may be either)."""
        if a.kind == "unmapped":
            return {DECERR}
        if a.kind == "gap":
            return {DECERR} if busy is False else {SLVERR, DECERR}
        if a.kind == "data":
            fits = a.fit is None or -(1 << (a.fit - 1)) <= _signed(value) < (1 << (a.fit - 1))
            if busy is False and fits:
                return {OKAY, DECERR} if a.reg.external else {OKAY}
            return {SLVERR, DECERR} if busy is not True and a.reg.external else {SLVERR}
        if a.name not in self.tracked:
            return {DECERR}                  # read-only register
        m = RANGE.search(a.reg.desc)
        return {SLVERR} if m and not 1 <= value <= int(m.group(1)) else {OKAY}

    def commit_write(self, a: Address, value: int, resp: AxiResp) -> dict[str, int] | None:
        """The write's effect, in the order the writes are taken; returns the register's new fields (by name) when
        a read-write register took the value."""
        s = dict(self.state)
        changed = None
        if a.kind in ("data", "gap") and resp == SLVERR:
            s["STATUS.WRITE_REJECTED"] = 1
        elif a.kind == "reg" and a.name in self.tracked and resp == OKAY:
            for f in self.tracked[a.name]:
                bits = (value & f.mask) >> f.lsb
                key = f"{a.name}.{f.name}"
                if f.w1c:
                    s[key] = s[key] & ~bits & 1
                else:
                    s[key] = bits
            changed = {f.name: s[f"{a.name}.{f.name}"] for f in self.tracked[a.name]}
        self.snaps.append(s)
        return changed

    def hw_sets(self, flags):
        """The core set sticky STATUS flags (outside any write)."""
        s = dict(self.state)
        for f in flags:
            s[f"STATUS.{f}"] = 1
        self.snaps.append(s)

    # ---- reads
    def check_read(self, a: Address, word: int, resp: AxiResp, lo: int, hi: int, dynamic: dict) -> str | None:
        """Problems with a read of `a` answered (word, resp), issued after `lo` writes were answered and answered
        before `hi` writes were issued; `dynamic` gives the allowed values of the fields the core sets ("REG.FIELD"
        -> set, or None: any), and of the flags in-flight solves may set."""
        if a.kind != "reg":
            return None if resp == DECERR else f"read {a.name} ({a.kind}): {resp.name}, expected DECERR"
        if resp != OKAY:
            return f"read {a.name}: {resp.name}"
        r = a.reg
        used = sum(f.mask for f in r.fields.values() if f.readable)
        if word & ~used:
            return f"read {a.name} = {word:#010x}: bits outside its fields"
        for f in r.fields.values():
            if not f.readable:
                continue
            got, key = (word & f.mask) >> f.lsb, f"{r.name}.{f.name}"
            if key in dynamic:
                ok = dynamic[key] is None or got in dynamic[key]
            elif f.hw == "na":
                ok = got == f.reset
            elif key in self.state:
                ok = got in {s[key] for s in self.snaps[lo:hi + 1]}
            else:
                ok = True                     # a value the core sets that the fuzz does not predict
            if not ok:
                return f"read {key} = {got:#x} (word {word:#010x}), expected {self._want(key, lo, hi, dynamic, f)}"
        return None

    def _want(self, key, lo, hi, dynamic, f):
        if key in dynamic:
            return dynamic[key]
        if f.hw == "na":
            return f.reset
        return sorted({s[key] for s in self.snaps[lo:hi + 1]})


def _signed(v: int) -> int:
    v &= 0xFFFFFFFF
    return v - (1 << 32) if v >> 31 else v
