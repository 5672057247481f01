"""cocotb test of a generated core's AXI4-Lite register file against its SystemRDL description (any core kind):
reset values, access rules (read-only, read-write, write-1-to-clear, write-only) and the error responses of reads
from write-only registers, data memories and unmapped words.

Environment: CORE_OUT = the generator's output folder (core.json and the <module>.rdl it names).
"""
from __future__ import annotations

import cocotb
from cocotb.triggers import ReadOnly, RisingEdge
from cocotbext.axi import AxiResp

from mpc_cores.driver import AxiDriver

TIMEOUT_MS = 50
PATTERNS = (0xFFFFFFFF, 0x55555555, 0xAAAAAAAA)


class RegsTB(AxiDriver):
    """The register file alone: the streams stay idle (no input frame, output always ready)."""

    def registers(self, pred):
        return [r for r in self.rm.regs.values() if not r.external and pred(r)]


def _fields(word: int, reg) -> dict[str, int]:
    return {f.name: (word & f.mask) >> f.lsb for f in reg.fields.values() if f.readable}


@cocotb.test(timeout_time=TIMEOUT_MS, timeout_unit="ms")
async def reset_values(dut):
    """After reset every readable register reads OKAY, every field with a reset value reads it (ID, CONFIG0/1,
    CTRL, IMAX, STATUS, SOLVES, LAST_CYCLES, CYCLES_PER_ITER) and bits outside the fields read 0."""
    tb = RegsTB(dut)
    await tb.reset()
    regs = tb.registers(lambda r: r.readable)
    assert {"ID", "CONFIG0", "CONFIG1", "CTRL", "IMAX", "STATUS", "SOLVES", "LAST_CYCLES",
            "CYCLES_PER_ITER"} <= {r.name for r in regs}
    for r in regs:
        word, resp = await tb.read(r.offset)
        assert resp == AxiResp.OKAY, f"{r.name}: read response {resp}"
        for f in r.fields.values():
            if f.readable and f.reset is not None:
                got = (word & f.mask) >> f.lsb
                assert got == f.reset, f"{r.name}.{f.name} = {got:#x} after reset, the RDL says {f.reset:#x}"
        used = sum(f.mask for f in r.fields.values() if f.readable)
        assert word & ~used == 0, f"{r.name} = {word:#010x}: bits outside its fields are set"


@cocotb.test(timeout_time=TIMEOUT_MS, timeout_unit="ms")
async def access_rules(dut):
    """Writes to read-only registers change nothing; read-write fields read back what was written (restored
    after); write-1-to-clear bits stay 0 after writing 1 when clear, and a STATUS write leaves its read-only bits."""
    tb = RegsTB(dut)
    await tb.reset()
    for r in tb.registers(lambda r: r.readable and not r.writable):
        before, _ = await tb.read(r.offset)
        for v in (0xFFFFFFFF, 0):
            await tb.write(r.offset, v)
            after, resp = await tb.read(r.offset)
            assert resp == AxiResp.OKAY and after == before, \
                f"read-only {r.name}: {before:#010x} became {after:#010x} after writing {v:#010x}"
    for r in tb.registers(lambda r: any(f.sw == "rw" and not f.w1c for f in r.fields.values())):
        rw = [f for f in r.fields.values() if f.sw == "rw" and not f.w1c]
        before, _ = await tb.read(r.offset)
        for p in PATTERNS:
            v = sum(p & f.mask for f in rw)
            assert await tb.write(r.offset, v) == AxiResp.OKAY, f"{r.name}: writing {v:#x} refused"
            got, resp = await tb.read(r.offset)
            assert resp == AxiResp.OKAY
            for f in rw:
                assert got & f.mask == v & f.mask, f"{r.name}.{f.name}: wrote {v:#x}, read {got:#x}"
            others = [f for f in r.fields.values() if f.readable and f not in rw]
            assert all(got & f.mask == before & f.mask for f in others), f"{r.name}: a read-only field changed"
        restore = sum(f.reset << f.lsb for f in rw)
        assert await tb.write(r.offset, restore) == AxiResp.OKAY
        got, _ = await tb.read(r.offset)
        assert got == before, f"{r.name}: {got:#x} after restoring {before:#x}"
    for r in tb.registers(lambda r: any(f.w1c for f in r.fields.values())):
        before, _ = await tb.read(r.offset)
        for f in (f for f in r.fields.values() if f.w1c):
            assert before & f.mask == 0, f"{r.name}.{f.name} set after reset"
            assert await tb.write(r.offset, f.mask) == AxiResp.OKAY
            got, resp = await tb.read(r.offset)
            assert resp == AxiResp.OKAY
            assert got & f.mask == 0, f"{r.name}.{f.name}: writing 1 to a clear write-1-to-clear bit set it"
            assert got == before, f"{r.name}: {before:#x} became {got:#x} after writing 1 to {f.name}"


@cocotb.test(timeout_time=TIMEOUT_MS, timeout_unit="ms")
async def read_errors(dut):
    """Reads from write-only registers, from the data memories (first, middle and last element of each array)
    and from unmapped words below the data memories return DECERR."""
    tb = RegsTB(dut)
    await tb.reset()
    for r in tb.registers(lambda r: not r.readable):
        _, resp = await tb.read(r.offset)
        assert resp == AxiResp.DECERR, f"write-only {r.name}: read response {resp}"
    arrays = [r for r in tb.rm.regs.values() if r.external]
    for a in arrays:
        n = 1
        for d in a.dims:
            n *= d
        for flat in sorted({0, n // 2, n - 1}):
            addr = a.offset + a.stride * flat
            _, resp = await tb.read(addr)
            assert resp == AxiResp.DECERR, f"{a.name} element {flat} at {addr:#x}: read response {resp}"
    top = min([a.offset for a in arrays] + [16 * 4])
    mapped = {r.offset for r in tb.rm.regs.values() if not r.external}
    for addr in range(0, top, 4):
        if addr not in mapped:
            _, resp = await tb.read(addr)
            assert resp == AxiResp.DECERR, f"unmapped {addr:#x}: read response {resp}"


class _Pins:
    """No bus master: the scenario drives the AXI4-Lite pins itself."""

    def __init__(self, dut, rng):
        self.dut = dut


async def _handshake_to_response(dut, valid: list[str], ready: str, resp_valid: str) -> tuple[int, int]:
    """Raise `valid` (all of them), drop them after the handshake; return (the cycles from the cycle of the
    handshake to the first with `resp_valid` high, the cycles `resp_valid` stays high with its ready held high)."""
    for v in valid:
        getattr(dut, v).value = 1
    cycle, shook, first = 0, None, None
    while True:
        await RisingEdge(dut.clock)
        if shook is not None and shook == cycle:
            for v in valid:
                getattr(dut, v).value = 0
        await ReadOnly()
        cycle += 1
        if shook is None and int(getattr(dut, ready).value) == 1:
            shook = cycle
        if shook is not None and first is None and int(getattr(dut, resp_valid).value) == 1:
            first = cycle
        if first is not None and int(getattr(dut, resp_valid).value) == 0:
            return first - shook, cycle - first
        assert cycle < 50, f"no {resp_valid} within 50 cycles"


@cocotb.test(timeout_time=TIMEOUT_MS, timeout_unit="ms")
async def response_cycles(dut):
    """B valid comes exactly core.json's axil_response_cycles["write"] after the cycle of the AW/W handshake, R
    valid exactly ["read"] after the AR handshake, each for one cycle with its ready held high, and the read
    returns the word just written (CTRL.OUT_ALL flipped)."""
    tb = RegsTB(dut, axil=_Pins)
    want = tb.core["axil_response_cycles"]
    for nm in ("awvalid", "wvalid", "arvalid", "awprot", "arprot"):
        getattr(dut, f"s_axil_{nm}").value = 0
    dut.s_axil_bready.value = 1
    dut.s_axil_rready.value = 1
    await tb.reset()
    ctrl = tb.rm.regs["CTRL"]
    out_all = ctrl.fields["OUT_ALL"]
    value = sum(f.reset << f.lsb for f in ctrl.fields.values()) ^ out_all.mask
    dut.s_axil_awaddr.value = ctrl.offset
    dut.s_axil_wdata.value = value
    dut.s_axil_wstrb.value = 0xF
    cycles, held = await _handshake_to_response(dut, ["s_axil_awvalid", "s_axil_wvalid"], "s_axil_awready",
                                                "s_axil_bvalid")
    assert (cycles, held) == (want["write"], 1), f"write: B after {cycles} cycles for {held}, want {want['write']}"
    assert int(dut.s_axil_bresp.value) == AxiResp.OKAY
    await RisingEdge(dut.clock)
    dut.s_axil_araddr.value = ctrl.offset
    cycles, held = await _handshake_to_response(dut, ["s_axil_arvalid"], "s_axil_arready", "s_axil_rvalid")
    assert (cycles, held) == (want["read"], 1), f"read: R after {cycles} cycles for {held}, want {want['read']}"
    assert int(dut.s_axil_rresp.value) == AxiResp.OKAY
    got = int(dut.s_axil_rdata.value)
    assert got & out_all.mask == value & out_all.mask, f"CTRL read {got:#x} after writing {value:#x}"
