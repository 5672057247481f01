"""shell.AnswerQueue against its contract: a producer that decides its push a cycle ahead from `room` (as
shell.PassSequencer does) never overflows it; room = count + push <= 2; deq valid and bits are registers; a word
pushed on cycle t is offered from t + 1, words and their last flags leave in order; with the producer always
pushing and tready high a word leaves every cycle. Random pushes and tready in segments, a reset in the middle.
(answer_queue_overflow, verif/blocks/violations.py: a push into a full queue stops the simulation.)"""
from __future__ import annotations

import cocotb

from verif.blocks.bench import Block, densities, each, next_cycle, reset_cycle, reset_cycles, rng, settle

CYCLES = 1500
SEGMENT = 100
DENSITIES = (0.0, 0.3, 0.7, 1.0)


async def run_answer_queue(dut, p: dict):
    b, r = Block(dut, p), rng(p["name"])
    w = p["width"]
    q: list[tuple[int, int]] = []
    push_next = False
    steady, top = [], 0
    resets = reset_cycles(r, CYCLES)
    pw = pr = 1.0
    for t in range(CYCLES + 10):
        pw, pr = densities(r, t, (pw, pr), CYCLES, SEGMENT, DENSITIES, DENSITIES[1:])
        if t in resets:
            await reset_cycle(b, dut, q, push=0, deq_ready=0)
            push_next = False
            continue
        b.reset_h.value = 0
        before = b.regs(("deq_valid", "deq_bits_data", "deq_bits_last"))
        push = push_next
        word = (r.getrandbits(w), int(r.random() < 0.3))
        ready = int(r.random() < pr)
        b.set(push=push, data=word[0], last=word[1], deq_ready=ready)
        await settle()
        after = b.regs(("deq_valid", "deq_bits_data", "deq_bits_last"))
        assert after == before, f"{p['name']} t={t}: deq follows the inputs: {before} -> {after}"
        room = b.get("room")
        assert room == (len(q) + push <= 2), f"{p['name']} t={t}: room {room} with {len(q)} held, push {push}"
        assert after["deq_valid"] == (len(q) > 0), f"{p['name']} t={t}: deq valid {after}, {len(q)} held"
        if q:
            assert (after["deq_bits_data"], after["deq_bits_last"]) == q[0], \
                f"{p['name']} t={t}: word {after}, expected {q[0]}"
        pop = ready and q
        if pw == 1.0 and pr == 1.0 and t < CYCLES and t % SEGMENT > 3 and not resets & set(range(t - 4, t)):
            steady.append(bool(pop))
        if pop:
            q.pop(0)
        if push:
            q.append(word)
        top = max(top, len(q))
        assert len(q) <= 4
        push_next = r.random() < pw and bool(room)
        await next_cycle(dut)
    assert not q
    assert steady and all(steady), f"{p['name']}: not a word per cycle with pushes and tready always high"
    assert top >= 3, f"{p['name']}: the queue never held more than {top} words"


@cocotb.test()
async def answer_queue(dut):
    await each(dut, "AnswerQueue", run_answer_queue)
