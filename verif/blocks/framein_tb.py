"""shell.FrameIn against its contract: `words` signed words per frame on s_axis, each saturated to its box
[lo_j, hi_j] (`sat` pulses the cycle after the word's handshake; with several problems the first word's tuser is the
frame's id, saturated to ids - 1, which also sets `sat`); a misplaced tlast sets `tlastErr` in its handshake's
cycle and loses nothing (frames are counted in words); `fills` marks the last word's handshake, `full` rises the
next cycle with the whole frame (and id) on `frame`, and stays until `take`; `hold` refuses a new frame's first
word only; `partial` says a frame is begun. Box rewrites at random cycles: a write on cycle c applies to the words
taken from c + 2 on (the box RAM's read-first synchronous read; the block's doc does not state this, the
bench pins the present timing); writes keep lo <= hi. tready, full, partial, sat and the frame are checked
every cycle; a reset in the middle of a frame (the boxes survive it, as the box RAM does)."""
from __future__ import annotations

import cocotb

from verif.blocks.bench import Block, each, next_cycle, reset_cycles, rng, settle, signed

CYCLES = 2500
SEGMENT = 150


def value(r, lo: int, hi: int, sw: int) -> int:
    """A stream word near the box's edges, at the stream's extremes or anywhere."""
    smin, smax = -(1 << (sw - 1)), (1 << (sw - 1)) - 1
    v = r.choice((lo - 1, lo, lo + 1, hi - 1, hi, hi + 1, smin, smax, 0, r.randint(smin, smax),
                  r.randint(lo, hi), r.randint(lo, hi)))
    return min(max(v, smin), smax)


async def run_frame_in(dut, p: dict):
    b, r = Block(dut, p), rng(p["name"])
    W, ww, sw, ids = p["words"], p["wordW"], p["streamW"], p["ids"]
    idw = (ids - 1).bit_length() if ids > 1 else 0
    wmin, wmax = -(1 << (ww - 1)), (1 << (ww - 1)) - 1
    box = [list(x) for x in p["box"]]
    hist = [[tuple(x) for x in box]] * 3            # boxes after each cycle's writes (the first ones: power-on)
    cnt, full, sat_next = 0, False, False
    cur, frame, fid, pending_id = [0] * W, None, 0, 0
    offer = None
    frames = errs = sats = holds = 0
    resets = reset_cycles(r, CYCLES)
    pv = ph = pt = pw = 0.5
    regs = ("full", "partial", "sat", *(f"frame_{j}" for j in range(W)), *(("id",) if ids > 1 else ()))
    for t in range(CYCLES):
        if t % SEGMENT == 0:
            pv, ph, pt = r.choice((0.2, 0.7, 1.0)), r.choice((0.0, 0.0, 0.3, 0.8)), r.choice((0.1, 0.5, 1.0))
            pw = r.choice((0.0, 0.05, 0.3))
        if t in resets:
            b.reset_h.value = 1
            b.set(s_axis_tvalid=0, take=0, hold=0, boxWen=0)
            cnt, full, sat_next, offer = 0, False, False, None
            hist.append(hist[-1])
            await next_cycle(dut)
            continue
        b.reset_h.value = 0
        before = b.regs(regs)
        # ---- drive
        if offer is None and r.random() < pv:
            last = (cnt == W - 1) ^ (r.random() < 0.08)      # a misplaced tlast now and then
            j = cnt
            offer = (value(r, box[j][0], box[j][1], sw), int(last), r.getrandbits(idw) if idw else 0)
        hold = int(r.random() < ph)
        take = int(full and r.random() < pt)
        b.set(s_axis_tvalid=offer is not None, hold=hold, take=take)
        x, tl, tu = offer if offer is not None else (r.getrandbits(sw), r.getrandbits(1), 0)
        b.set(s_axis_tdata=x & ((1 << sw) - 1), s_axis_tlast=tl)
        if idw:
            b.set(s_axis_tuser=tu)
        wen = r.random() < pw
        if wen:
            j, hi = r.randrange(W), r.getrandbits(1)
            d = r.randint(box[j][0], wmax) if hi else r.randint(wmin, box[j][1])
            b.set(boxWen=1, boxWord=j, boxHi=hi, boxData=d & ((1 << ww) - 1))
            box[j][hi] = d
        else:
            b.set(boxWen=0, boxWord=r.randrange(W), boxHi=r.getrandbits(1), boxData=r.getrandbits(ww))
        hist.append([tuple(x) for x in box])
        await settle()
        # ---- check
        after = b.regs(regs)
        assert after == before, f"{p['name']} t={t}: registered outputs follow the inputs: {before} -> {after}"
        tag = f"{p['name']} t={t}"
        assert after["full"] == full, f"{tag}: full {after['full']}, expected {full}"
        assert after["partial"] == (cnt != 0), f"{tag}: partial {after['partial']} at word {cnt}"
        assert after["sat"] == sat_next, f"{tag}: sat {after['sat']}, expected {sat_next}"
        if full:
            got = [signed(after[f"frame_{j}"], ww) for j in range(W)]
            assert got == frame, f"{tag}: frame {got}, expected {frame}"
            if ids > 1:
                assert after["id"] == fid, f"{tag}: id {after['id']}, expected {fid}"
        ready = b.get("s_axis_tready")
        assert ready == (not full and not (hold and cnt == 0)), f"{tag}: tready {ready}, full {full}, hold {hold}"
        fire = offer is not None and ready
        assert b.get("fills") == (fire and cnt == W - 1), f"{tag}: fills"
        assert b.get("tlastErr") == (fire and tl != (cnt == W - 1)), f"{tag}: tlastErr"
        holds += hold and cnt == 0 and offer is not None and not full
        # ---- update
        sat_next = False
        if fire:
            lo, hi = hist[-3][cnt]            # the boxes after the writes of cycle t - 2
            xs = signed(x, sw)
            v = lo if xs < lo else hi if xs > hi else xs
            sat_next = xs != v
            if cnt == 0 and ids > 1:
                sat_next |= tu >= ids
                nid = min(tu, ids - 1)
            cur[cnt] = v
            errs += tl != (cnt == W - 1)
            if cnt == W - 1:
                frame, full = list(cur), True
                frames += 1
                if ids > 1:
                    fid = nid if W == 1 else pending_id
            elif cnt == 0 and ids > 1:
                pending_id = nid
            cnt = (cnt + 1) % W
            offer = None
        sats += sat_next
        if take:
            full = False
        await next_cycle(dut)
    assert frames > 20 and errs and sats and holds, f"{p['name']}: {frames} frames, {errs} tlast errors, " \
        f"{sats} saturated, {holds} held"
    dut._log.info("%s: %d frames, %d tlast errors, %d saturations", p["name"], frames, errs, sats)


@cocotb.test()
async def frame_in(dut):
    await each(dut, "FrameIn", run_frame_in)
