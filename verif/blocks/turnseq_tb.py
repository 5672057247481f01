"""shell.TurnSequencer against its documented contract, on every cycle:
- rounds of R = max(L, Kp K) cycles from reset (tokN of the first cycle out of reset shows the round's last
  position); slot j's turn is round cycles j K .. j K + K - 1 (tokN rows 0..K-1, slot j), the rest pad;
- a complete frame for a free slot is taken at once (take, combinationally from frameReady and the slot's phase;
  imax, outLast and warm(slot) latched then, warmOf the latched warm); a frame for a busy slot waits;
- a turn runs what its slot's phase was the cycle before the turn: a loaded slot the first pass (pass0), a running
  one an iteration (first for the first of its imax), a free or waiting one nothing (tokN invalid);
- the last iteration's results are complete L cycles after its turn began (tokN's row 0): the slot then enters
  the answer queue, and its answer (outIndex 0..outLast, outIsLast on the last) is offered from the second cycle
  after, or from the cycle after the answer before it left; outFire steps it; done on the last word's fire, with
  runCycles = the cycles since its first pass's turn began; the slot is free again the cycle after;
- running while any slot is not free.
Random frames (slots, iteration counts, answer lengths, warm flags), answer backpressure, a reset in the middle."""
from __future__ import annotations

import cocotb

from verif.blocks.bench import Block, each, next_cycle, reset_cycles, rng, settle

CYCLES = 2500
DRAIN = 300
SEGMENT = 250


class Model:
    def __init__(self, p: dict):
        self.K, self.Kp, self.L = p["K"], p["Kp"], p["L"]
        self.R = max(self.L, self.Kp * self.K)
        self.phase = ["free"] * self.Kp
        self.slot = [dict() for _ in range(self.Kp)]
        self.warm_known = [False] * self.Kp
        self.turns: dict[int, dict] = {}     # turn start cycle (tokN's row 0) -> what it issues
        self.entering: dict[int, int] = {}   # cycle -> slot entering the answer queue
        self.queue: list[tuple[int, int]] = []   # (slot, cycle it entered)
        self.busy, self.oslot, self.idx = False, 0, 0

    def pos(self, c: int) -> int:
        return (c - 1) % self.R

    def tok(self, c: int) -> dict:
        pos = self.pos(c)
        if pos >= self.Kp * self.K:
            return {"valid": 0}
        j, k = divmod(pos, self.K)
        t = self.turns.get(c - k)
        if not t or not t["live"]:
            return {"valid": 0}
        return {"valid": 1, "pass0": t["p0"], "first": t["first"], "k": k, "slot": j}


async def run_turn_sequencer(dut, p: dict):
    b, r = Block(dut, p), rng(p["name"])
    tag, Kp, K, max_out = p["name"], p["Kp"], p["K"], p["maxOut"]
    m = Model(p)
    frame = None                 # (slot) of the waiting frame
    next_frame = 0               # the cycle from which a new frame may be ready
    imax, out_last = 1, 0
    takes = dones = firsts = 0
    c = 0                        # cycles since reset
    resets = reset_cycles(r, CYCLES)
    pf = pr = 0.5
    toks = ("tokN_valid", "tokN_pass0", "tokN_first", "tokN_k", "tokN_slot")
    regs = (*toks, "running", "outValid", "outSlot", "outIndex", "outIsLast", "runCycles",
            *(f"warmOf_{j}" for j in range(Kp)))
    for t in range(CYCLES + DRAIN):
        if t % SEGMENT == 0:
            pf, pr = r.choice((0.1, 0.5, 1.0)), r.choice((0.2, 0.7, 1.0))
        if t >= CYCLES:
            pf, pr = 0.0, 1.0
        if t in resets:
            b.reset_h.value = 1
            b.set(frameReady=0, outFire=0)
            m, frame, next_frame, c = Model(p), None, 0, 0
            await next_cycle(dut)
            continue
        b.reset_h.value = 0
        before = b.regs(regs)
        # ---- drive
        if frame is None and c >= next_frame and r.random() < pf:
            frame = r.randrange(Kp)
        if r.random() < 0.3:
            imax, out_last = r.randint(1, 3), r.randrange(max_out)
        warm = [r.getrandbits(1) for _ in range(Kp)]
        fire = int(before["outValid"] and r.random() < pr)
        b.set(frameReady=frame is not None, frameSlot=frame if frame is not None else r.randrange(Kp), imax=imax,
              outLast=out_last, outFire=fire, **{f"warm_{j}": warm[j] for j in range(Kp)})
        await settle()
        got = b.regs(regs)
        assert got == before, f"{tag} t={t}: registered outputs follow the inputs: {before} -> {got}"
        got["take"], got["done"] = b.get("take"), b.get("done")
        # ---- expected
        exp = dict(got)
        tok = m.tok(c)
        exp["tokN_valid"] = tok["valid"]
        if tok["valid"]:
            exp.update({f"tokN_{f}": tok[f] for f in ("pass0", "first", "k", "slot")})
        exp["take"] = int(frame is not None and m.phase[frame] == "free")
        exp["running"] = int(any(ph != "free" for ph in m.phase))
        exp["outValid"] = int(m.busy)
        last_fire = False
        exp["done"] = 0
        if m.busy:
            s = m.slot[m.oslot]
            last = m.idx == s["outLast"]
            exp.update(outSlot=m.oslot, outIndex=m.idx, outIsLast=int(last))
            if fire and last:
                last_fire = True
                exp["done"], exp["runCycles"] = 1, c - s["u0"]
        for j in range(Kp):
            if m.warm_known[j]:
                exp[f"warmOf_{j}"] = m.slot[j]["warm"]
        diff = {k: (got[k], exp[k]) for k in exp if got[k] != exp[k]}
        assert not diff, f"{tag} t={t} c={c}: (got, expected) {diff}; phases {m.phase}, queue {m.queue}"
        # ---- next state
        phase = list(m.phase)
        if exp["take"]:
            phase[frame] = "loaded"
            m.slot[frame] = {"imax": imax, "outLast": out_last, "warm": warm[frame]}
            m.warm_known[frame] = True
            frame, next_frame = None, c + 2 + (r.randrange(4) if r.random() < 0.5 else 0)
            takes += 1
        pn = c % m.R                          # tokN's position next cycle
        if pn < Kp * K and pn % K == 0:       # a turn starts next cycle: its slot's phase now decides it
            j = pn // K
            s = m.slot[j]
            if m.phase[j] == "loaded":
                m.turns[c + 1] = {"live": 1, "p0": 1, "first": 0}
                phase[j] = "run"
                s.update(left=s["imax"], iter0=True, u0=c + 1)
            elif m.phase[j] == "run":
                m.turns[c + 1] = {"live": 1, "p0": 0, "first": int(s["iter0"])}
                firsts += s["iter0"]
                s["iter0"] = False
                s["left"] -= 1
                if s["left"] == 0:
                    phase[j] = "wait"
                    m.entering[c + 1 + m.L] = j
            else:
                m.turns[c + 1] = {"live": 0}
        if m.busy and fire:
            m.idx += 1
        if last_fire:
            m.busy = False
            phase[m.oslot] = "free"
            dones += 1
        if m.queue and m.queue[0][1] < c and not m.busy:   # the queue hands out its head
            j, _ = m.queue.pop(0)
            m.busy, m.oslot, m.idx = True, j, 0
        if c in m.entering:
            m.queue.append((m.entering.pop(c), c))
        m.phase = phase
        m.turns.pop(c - m.K - 1, None)
        c += 1
        await next_cycle(dut)
    assert not any(ph != "free" for ph in m.phase) and frame is None, f"{tag}: not drained: {m.phase}"
    assert takes > 20 and firsts, f"{tag}: {takes} frames taken"
    dut._log.info("%s: %d frames taken, %d answers", tag, takes, dones)


@cocotb.test()
async def turn_sequencer(dut):
    await each(dut, "TurnSequencer", run_turn_sequencer)
