"""Protocol violations forced into generated cores, to show that their assertions (bus.Protocol) are compiled into
the Verilator models of the suite and stop the simulation. Each test overwrites one register inside the core
(cocotb deposit) so that an output breaks its protocol on the next clock edge; the assertion must end the
simulation there: a test that gets past the edge fails. Run one test per simulation (tests/test_assertions.py).
Where a register is overwritten is the kind's (verif/fuzz/kinds.py: Kind.force_*); the scenarios each kind takes
are its Family's `violations`.

Environment: CORE_OUT = the generator's output folder.
"""
from __future__ import annotations

import cocotb
from cocotb.triggers import ClockCycles, RisingEdge
from cocotbext.axi import AxiStreamFrame

from verif.fuzz import kinds
from verif.fuzz.axil import AxiLiteFuzzMaster
from verif.fuzz.tb import _kind_name

MESSAGES = {
    "stream_valid_dropped": "m_axis: valid dropped before ready",
    "stream_data_changed": "m_axis: payload changed while valid and not ready",
    "axil_response_dropped": "s_axil B: valid dropped before ready",
    "queue_overflow": "output queue: enqueue while full",
}


async def _held_answer(dut, out_all: bool = False):
    """A frame in, its answer waiting on m_axis (tready low) for two cycles."""
    k = kinds.make(dut, _kind_name(), 5)
    await k.tb.reset()
    if out_all:
        await k.set_reg("CTRL", 1 << k.tb.rm.CTRL_BITS["OUT_ALL"])
    k.tb.sink.pause = True
    k.tb.src.send_nowait(AxiStreamFrame(tdata=k.job().words))
    while not dut.m_axis_tvalid.value:
        await RisingEdge(dut.clock)
    await ClockCycles(dut.clock, 2)
    return k


async def _survived(dut, what: str):
    await ClockCycles(dut.clock, 3)
    raise AssertionError(f"{what}: the simulation went on, no assertion stopped it")


@cocotb.test()
async def stream_valid_dropped(dut):
    """The answer's valid falls while it waits, without tready (FGM, ADMM, accelerated DGP: the output queue
    emptied or the sequencer sent back to idle; plain DGP: its state sent back to idle)."""
    k = await _held_answer(dut)
    k.force_valid_drop(dut)
    await _survived(dut, "tvalid dropped")


@cocotb.test()
async def stream_data_changed(dut):
    """The answer's word changes while the first waits and tlast rises without tready (FGM, ADMM, accelerated
    DGP: the head of the output queue, or the output index moved to the last word; plain DGP: its output index
    moved to the status word)."""
    k = await _held_answer(dut, out_all=True)
    k.force_payload_change(dut)
    await _survived(dut, "tdata changed")


@cocotb.test()
async def axil_response_dropped(dut):
    """Any core: a write response withdrawn while bready is low."""
    k = kinds.make(dut, _kind_name(), 5, axil=lambda d, rng: AxiLiteFuzzMaster(d, rng, stall=1.0))
    await k.tb.reset()
    cocotb.start_soon(k.tb.axil.write(k.tb.rm["CTRL"], 0))
    while not dut.s_axil_bvalid.value:
        await RisingEdge(dut.clock)
    await ClockCycles(dut.clock, 2)
    dut.axil.bValid.value = 0
    await _survived(dut, "bvalid dropped")


@cocotb.test()
async def queue_overflow(dut):
    """MINRES core: a word issued into its full output queue."""
    await _held_answer(dut)
    await ClockCycles(dut.clock, 8)     # the queue fills up behind the held word
    assert not dut.outQ.io_enq_ready.value, "the output queue is not full"
    dut.pending.value = 1
    await _survived(dut, "enqueue while full")
