"""fixed.SerialDivider against its contract: q = floor(x / d) for a signed x of xW bits and a positive d of dW
bits; `start` samples x and d (their values on other cycles do not matter); busy for the xW cycles after the start,
`done` high for one cycle, xW + 1 cycles after it, and q holds the quotient from then until the next start (idle
cycles checked); a start on the done cycle (back to back), a start while busy (the new operands win), resets (busy
and done low after one). Operands: every pair for a small width, else the edges (0, +-1, the extremes; d = 1, 2,
3, the largest) and random ones.

`serial_divider_wide_divisor` runs the pairs of a negative x and a divisor with |x| + d - 1 >= 2^xW (only
possible with dW >= xW) alone: a form of the negative case through |x| + d - 1 would overflow there."""
from __future__ import annotations

import cocotb

from verif.blocks.bench import Block, each, next_cycle, params, reset_cycles, rng, settle, signed

RANDOM = 150


def wide(p: dict, x: int, d: int) -> bool:
    """x / d beyond the block's reach: |x| + d - 1 does not fit xW bits."""
    return x < 0 and -x + d - 1 >= 1 << p["xW"]


def operands(p: dict, r) -> list[tuple[int, int]]:
    xw, dw = p["xW"], p["dW"]
    xmin, xmax, dmax = -(1 << (xw - 1)), (1 << (xw - 1)) - 1, (1 << dw) - 1
    if xw * dw <= 24:
        return [(x, d) for x in range(xmin, xmax + 1) for d in range(1, dmax + 1)]
    xs = (0, 1, -1, 2, -2, xmax, xmin, xmax - 1, xmin + 1)
    ds = (1, 2, 3, dmax, dmax - 1, (dmax + 1) // 2)
    ops = [(x, d) for x in xs for d in ds]
    for _ in range(RANDOM):
        d = r.choice((r.randint(1, dmax), r.randint(1, 16), r.randint(1, dmax)))
        x = r.choice((r.randint(xmin, xmax), r.randint(-4 * d, 4 * d), d * r.randint(-8, 8)))
        ops.append((min(max(x, xmin), xmax), d))
    return ops


async def divide_all(dut, p: dict, ops: list[tuple[int, int]]):
    b, r = Block(dut, p), rng(p["name"])
    xw, dw = p["xW"], p["dW"]
    tag = p["name"]
    pending = list(ops)
    cur = None               # (x, d, start cycle)
    q_hold = None            # the last quotient, held until the next start
    t = 0
    restarts = 0
    resets = reset_cycles(r, 50 * xw + 200)
    while pending or cur is not None:
        if t in resets:                                    # the division cut off runs again later
            b.reset_h.value = 1
            b.set(start=0)
            if cur is not None:
                pending.insert(0, cur[:2])
            cur, q_hold = None, None
            t += 1
            await next_cycle(dut)
            continue
        b.reset_h.value = 0
        t0 = cur[2] if cur is not None else None
        if cur is None:
            start = bool(pending) and r.random() < 0.6
        elif t == t0 + xw + 1:                             # back to back: a start on the done cycle
            start = bool(pending) and r.random() < 0.3
        else:                                              # a start while busy: the new operands win
            start = bool(pending) and r.random() < 0.1 / xw
            if start:                                      # the division it cuts off runs again later
                restarts += 1
                pending.insert(0, cur[:2])
        if start:
            x, d = pending.pop()
            b.set(start=1, x=x & ((1 << xw) - 1), d=d)
        else:
            b.set(start=0, x=r.getrandbits(xw), d=r.getrandbits(dw))
        await settle()
        busy, done, q = b.get("busy"), b.get("done"), signed(b.get("q"), xw)
        if cur is not None:
            x0, d0, _ = cur
            assert busy == (t0 < t <= t0 + xw), f"{tag} t={t}: busy {busy}, started at {t0}"
            assert done == (t == t0 + xw + 1), f"{tag} t={t}: done {done}, started at {t0}"
            if done:
                assert q == x0 // d0, f"{tag}: {x0} / {d0} gave {q}, expected {x0 // d0}"
                q_hold, cur = q, None
        else:
            assert not busy and not done, f"{tag} t={t}: busy {busy}, done {done} with no division"
            if q_hold is not None:
                assert q == q_hold, f"{tag} t={t}: q {q}, the quotient {q_hold} not held"
        if start:
            cur, q_hold = (x, d, t), None
        t += 1
        await next_cycle(dut)
    dut._log.info("%s: %d divisions, %d restarts, %d cycles", tag, len(ops), restarts, t)


async def run_divider(dut, p: dict):
    ops = list(operands(p, rng(p["name"])))
    await divide_all(dut, p, ops)


@cocotb.test()
async def serial_divider(dut):
    await each(dut, "SerialDivider", run_divider)


async def run_wide(dut, p: dict):
    r = rng(p["name"] + "wide")
    xw, dw = p["xW"], p["dW"]
    ops = [(x, d) for x, d in ((r.randint(-(1 << (xw - 1)), -1), r.randint(1 << (xw - 1), (1 << dw) - 1))
                               for _ in range(200)) if wide(p, x, d)]
    await divide_all(dut, p, ops)


@cocotb.test()
async def serial_divider_wide_divisor(dut):
    """Only the dW >= xW parameterisations have such pairs."""
    ps = [p for p in params("SerialDivider") if p["dW"] >= p["xW"]]
    assert ps, "no parameterisation with dW >= xW"

    async def run(dut, p):
        if p in ps:
            await run_wide(dut, p)
    await each(dut, "SerialDivider", run)
