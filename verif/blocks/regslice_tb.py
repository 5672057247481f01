"""bus.RegSlice against its contract: a two-word FIFO of a ready/valid stream whose enq ready, deq valid and deq
bits are registers (no combinational path crosses it), full throughput, a word taken on cycle t offered from
t + 1. Random valid and ready in segments of different densities (idle, backpressure, both always high), a
reset in the middle of the stream; a StreamWord slice carries tlast with its word."""
from __future__ import annotations

import cocotb

from verif.blocks.bench import Block, densities, each, next_cycle, reset_cycle, reset_cycles, rng, settle

CYCLES = 1500
SEGMENT = 100
DENSITIES = (0.0, 0.2, 0.5, 0.9, 1.0)


async def run_slice(dut, p: dict):
    b, r = Block(dut, p), rng(p["name"])
    w, stream = p["width"], p.get("stream", False)
    q: list[tuple[int, int]] = []
    offer = None          # the word the producer offers (held until taken)
    sent = got = 0
    pv = pr = 1.0
    steady = []           # pops per cycle in the segments with valid and ready always high
    resets = reset_cycles(r, CYCLES)
    for t in range(CYCLES + 20):
        pv, pr = densities(r, t, (pv, pr), CYCLES, SEGMENT, DENSITIES, DENSITIES[1:])
        if t in resets:
            await reset_cycle(b, dut, q, enq_valid=0, deq_ready=0)
            offer = None
            continue
        b.reset_h.value = 0
        before = b.regs(("enq_ready", "deq_valid"))
        before_bits = b.get("deq_bits_data" if stream else "deq_bits")
        assert before["enq_ready"] == (len(q) < 2), f"{p['name']} t={t}: enq ready {before}, {len(q)} words held"
        assert before["deq_valid"] == (len(q) > 0), f"{p['name']} t={t}: deq valid {before}, {len(q)} words held"
        if offer is None and r.random() < pv:
            offer = (r.getrandbits(w), r.getrandbits(1))
        ready = int(r.random() < pr)
        if offer is not None:
            if stream:
                b.set(enq_valid=1, enq_bits_data=offer[0], enq_bits_last=offer[1])
            else:
                b.set(enq_valid=1, enq_bits=offer[0])
        else:
            b.set(enq_valid=0)
            b.set(**({"enq_bits_data": r.getrandbits(w)} if stream else {"enq_bits": r.getrandbits(w)}))
        b.set(deq_ready=ready)
        await settle()
        after = b.regs(("enq_ready", "deq_valid"))
        assert after == before, f"{p['name']} t={t}: a combinational path into {before} -> {after}"
        if q:
            data = b.get("deq_bits_data" if stream else "deq_bits")
            assert data == before_bits, f"{p['name']} t={t}: deq bits follow the inputs"
            want = q[0]
            assert data == want[0], f"{p['name']} t={t}: word {data:#x}, expected {want[0]:#x}"
            if stream:
                assert b.get("deq_bits_last") == want[1], f"{p['name']} t={t}: tlast of word {want}"
        pop = ready and q
        push = offer is not None and len(q) < 2
        if pv == 1.0 and pr == 1.0 and t < CYCLES and t % SEGMENT > 2 and not resets & set(range(t - 3, t)):
            steady.append((t, bool(pop)))
        if pop:
            q.pop(0)
            got += 1
        if push:
            q.append(offer if stream else (offer[0], 0))
            offer = None
            sent += 1
        await next_cycle(dut)
    assert not q, f"{p['name']}: {len(q)} words never left"
    assert steady and all(s for _, s in steady), \
        f"{p['name']}: no word left on cycles {[t for t, s in steady if not s]} with valid and ready always high"
    dut._log.info("%s: %d words in, %d out", p["name"], sent, got)


@cocotb.test()
async def reg_slice(dut):
    await each(dut, "RegSlice", run_slice)
