"""A block's assertion firing on a forced violation: each test breaks the block's contract on purpose, at its ports
or (for the checks of a block's own registers) by overwriting a register inside it (cocotb deposit, which lasts to
the next edge); the assertion must stop the simulation (tests/test_blocks.py reads the message from the log). A
test that ends on its own fails ("went on, no assertion stopped it")."""
from __future__ import annotations

import cocotb

from verif.blocks.bench import Block, begin, next_cycle, params

MESSAGES = {"answer_queue_overflow": "AnswerQueue: push into a full queue",
            "frame_in_word_enables": "FrameIn: word enables out of step with the handshake",
            "pass_sequencer_start": "PassSequencer: start registers out of step",
            "turn_sequencer_answer_queue": "answer queue: enqueue while full"}


@cocotb.test()
async def answer_queue_overflow(dut):
    """Five pushes, ignoring `room`, into a queue nobody reads: the fifth finds four words."""
    await begin(dut)
    b = Block(dut, params("AnswerQueue")[0])
    b.set(deq_ready=0)
    for i in range(5):
        b.set(push=1, data=i, last=0)
        await next_cycle(dut)
    b.set(push=0)
    await went_on(dut)


async def went_on(dut):
    for _ in range(5):
        await next_cycle(dut)
    assert False, "went on, no assertion stopped it"


async def force(dut, kind: str, reg: str):
    """the first `kind` block's register `reg` set to 1 a cycle after the start, then wait for the assertion"""
    await begin(dut)
    p = params(kind)[0]
    await next_cycle(dut)
    getattr(getattr(dut, f"u_{p['name']}"), reg).value = 1
    await went_on(dut)


@cocotb.test()
async def frame_in_word_enables(dut):
    """A word's write enable without a handshake the cycle before (no word is offered)."""
    await force(dut, "FrameIn", "pendHot")


@cocotb.test()
async def pass_sequencer_start(dut):
    """A start with no frame waiting."""
    await force(dut, "PassSequencer", "start")


@cocotb.test()
async def turn_sequencer_answer_queue(dut):
    """Answers entering the queue on every cycle while the first is never sent (outFire low): the queue of Kp
    entries fills."""
    await begin(dut)
    p = params("TurnSequencer")[0]
    u = getattr(dut, f"u_{p['name']}")
    for _ in range(p["Kp"] + 3):
        await next_cycle(dut)
        u.ready_valid.value = 1
    await went_on(dut)
