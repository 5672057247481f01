"""mem.InitRam against its contract: the power-on contents (init rows, signed lanes, rows beyond init zero) read
back; one synchronous read port, read-first (a read and a write of one row on one cycle read the old row), its
data a cycle after the address, two with outReg, and the address a cycle ahead with raddrAhead; lane-masked
writes (with broadcast, wdata is lane 0's word repeated); on the ECP5 primitive's simulation model (ecp5, outReg)
a write lands two cycles after it is presented. Every row first, then random reads and writes (the write address
often the read address), then a reset of the enclosing module: the contents survive it."""
from __future__ import annotations

import cocotb

from verif.blocks.bench import Block, each, next_cycle, rng, settle

RANDOM = 600


def row_bits(row: list[int], lw: int) -> int:
    return sum((v & ((1 << lw) - 1)) << (i * lw) for i, v in enumerate(row))


async def run_init_ram(dut, p: dict):
    b, r = Block(dut, p), rng(p["name"])
    depth, lanes, lw, tag = p["depth"], p["lanes"], p["laneW"], p["name"]
    reg, ahead = int(p.get("outReg", False)), int(p.get("raddrAhead", False))
    wl = 2 if p.get("ecp5") and p.get("outReg") and depth <= 1024 else 0   # the primitive's write registers
    mem = [row_bits(p["init"][a], lw) if a < len(p["init"]) else 0 for a in range(depth)]
    raddr, writes, samples = {}, {}, {}
    lag = 1 + reg
    plan = [("init", a) for a in range(depth)] + [("random", None)] * RANDOM + [("reset", None)] * 2 + \
        [("after reset", a) for a in range(depth)] + [("drain", 0)] * 4
    checked, last_wa = 0, None
    for t, (phase, a) in enumerate(plan):
        b.reset_h.value = int(phase == "reset")
        if a is not None:
            ra = a
        else:   # now and then the row written last: a read in each cycle after the write
            ra = last_wa if last_wa is not None and r.random() < 0.3 else r.randrange(depth)
        b.set(raddr=ra)
        raddr[t] = ra
        w = None
        if phase == "random" and r.random() < 0.5:
            wa = ra if r.random() < 0.3 else r.randrange(depth)
            mask = r.getrandbits(lanes) or 1
            if p.get("broadcast"):
                data = row_bits([r.getrandbits(lw)] * lanes, lw)
            else:
                data = r.getrandbits(lanes * lw)
            w, last_wa = (wa, mask, data), wa
            b.set(wen=1, waddr=wa, wmask=mask, wdata=data)
        else:
            b.set(wen=0, waddr=r.randrange(depth), wmask=r.getrandbits(lanes), wdata=r.getrandbits(lanes * lw))
        writes[t] = w
        await settle()
        if t - lag in samples:
            got = b.get("rdata")
            want, addr, phase0 = samples[t - lag]
            assert got == want, f"{tag} t={t}: row {addr} ({phase0}) read {got:#x}, expected {want:#x}"
            checked += 1
        # the rising edge ending cycle t: the read samples the row, then the writes that land there
        if t - ahead in raddr:
            addr = raddr[t - ahead]
            samples[t] = (mem[addr], addr, plan[t - ahead][0])
        if writes.get(t - wl):
            wa, mask, data = writes[t - wl]
            for i in range(lanes):
                if mask >> i & 1:
                    f = ((1 << lw) - 1) << (i * lw)
                    mem[wa] = (mem[wa] & ~f) | (data & f)
        await next_cycle(dut)
    assert checked >= len(plan) - lag - ahead - 1, f"{tag}: {checked} reads checked"
    dut._log.info("%s: %d reads checked", tag, checked)


@cocotb.test()
async def init_ram(dut):
    await each(dut, "InitRam", run_init_ram)
