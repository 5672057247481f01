"""bus.FlowQueue against its contract: a FIFO of `depth` words that an empty queue passes straight through (the
same words on the same cycles as chisel3.util.Queue(flow = true)): deq valid is the registered non-empty flag or
enq valid, deq bits the head or (empty) enq bits, enq ready the registered not-full flag (no combinational path
from either side's inputs). Random valid and ready in segments (idle, backpressure, always high), full and empty
edges, simultaneous push and pop, a reset in the middle of the stream."""
from __future__ import annotations

import cocotb

from verif.blocks.bench import Block, densities, each, next_cycle, reset_cycle, reset_cycles, rng, settle

CYCLES = 1500
SEGMENT = 100
DENSITIES = (0.0, 0.2, 0.5, 0.9, 1.0)


async def run_queue(dut, p: dict):
    b, r = Block(dut, p), rng(p["name"])
    w, depth = p["width"], p["depth"]
    q: list[int] = []
    offer = None
    seen_full = seen_through = 0
    resets = reset_cycles(r, CYCLES)
    pv = pr = 1.0
    for t in range(CYCLES + depth + 5):
        pv, pr = densities(r, t, (pv, pr), CYCLES, SEGMENT, DENSITIES, bursts=False)
        if t in resets:
            await reset_cycle(b, dut, q, enq_valid=0, deq_ready=0)
            offer = None
            continue
        b.reset_h.value = 0
        ready_before = b.get("enq_ready")
        assert ready_before == (len(q) < depth), f"{p['name']} t={t}: enq ready {ready_before}, {len(q)} held"
        seen_full += len(q) == depth
        if offer is None and r.random() < pv:
            offer = r.getrandbits(w)
        ready = int(r.random() < pr)
        b.set(enq_valid=offer is not None, enq_bits=offer if offer is not None else r.getrandbits(w),
              deq_ready=ready)
        await settle()
        assert b.get("enq_ready") == ready_before, f"{p['name']} t={t}: enq ready follows the inputs"
        ahead = q + ([offer] if offer is not None else [])
        valid = b.get("deq_valid")
        assert valid == (len(ahead) > 0), f"{p['name']} t={t}: deq valid {valid}, held {len(q)}, offer {offer}"
        if ahead:
            data = b.get("deq_bits")
            assert data == ahead[0], f"{p['name']} t={t}: word {data:#x}, expected {ahead[0]:#x}"
        if offer is not None and len(q) < depth:
            seen_through += not q and ready
            q.append(offer)
            offer = None
        if ready and valid:
            q.pop(0)
        await next_cycle(dut)
    assert not q, f"{p['name']}: {len(q)} words never left"
    assert seen_full and seen_through, f"{p['name']}: full {seen_full} cycles, passed through {seen_through} words"


@cocotb.test()
async def flow_queue(dut):
    await each(dut, "FlowQueue", run_queue)
