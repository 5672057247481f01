"""shell.PassSequencer against its documented contract, on every cycle:
- start: a frame's last word taken at f (frameFills) starts the solve at max(f, d) + 2, d the previous solve's done
  (the frame waits meanwhile; frameReady drops after the start, as FrameIn's full does);
- the solve's positions p = 0 .. P - 1, P = firstLen + Imax L: the first pass issues rows 0..K-1 at p = 0..K-1 of
  its firstLen, each iteration rows 0..K-1 at its first K of L; tokN at cycle s + p is position p's token (pass0
  in the first pass, first in the first iteration), tokNN the one after it; invalid in the gaps and in idle;
- imax latched a cycle before the start, outLast at the start (the inputs change at random cycles);
- running from s + 1 to s + P; copyNow the cycle after each pass's last position: after every iteration but the
  last, after the first pass when copyAfterFirst; copyNext a cycle ahead of it;
- outLoad at s + P (outLoadAhead a cycle earlier); from then the answer's words 0..outLast move out one per cycle
  the queue's room allows: outShiftAhead = a word still to decide and outRoom, outShift the cycle after, with
  outIndex and outIsLast; outValid from s + P + 1 to the last word's shift, done there with runCycles = P and
  iters = Imax;
- stop (the early exit), high in the cycle the generator holds iteration i's last position (s + firstLen + (i + 1) L
  - 2), makes iteration i the solve's last: Imax becomes i + 1 from then on; high in any other cycle it does nothing.
Random frames, iteration counts, answer lengths, stops and outRoom; a reset in the middle of a solve."""
from __future__ import annotations

import cocotb

from verif.blocks.bench import Block, each, next_cycle, reset_cycles, rng, settle

CYCLES = 2500
SEGMENT = 200
NEVER = -10


def token(p: dict, solve: dict, pos: int) -> dict | None:
    """Position pos's token (valid, pass0, first, k), or None outside the solve."""
    K, first_len, L = p["K"], p["firstLen"], p["L"]
    if not 0 <= pos < solve["P"]:
        return None
    if pos < first_len:
        return {"valid": int(pos < K), "pass0": 1, "first": 0, "k": pos}
    i, r = divmod(pos - first_len, L)
    return {"valid": int(r < K), "pass0": 0, "first": int(i == 0), "k": r}


def copies(p: dict, s: int, imax: int) -> set[int]:
    first_len, L = p["firstLen"], p["L"]
    ends = ([first_len - 1] if p["copyAfterFirst"] else []) + [first_len + (i + 1) * L - 1 for i in range(imax - 1)]
    return {s + 2 + e for e in ends}


async def run_pass_sequencer(dut, p: dict):
    b, r = Block(dut, p), rng(p["name"])
    tag = p["name"]
    max_out = p["maxOut"]
    fill = None            # the waiting frame's fill cycle
    last_done = NEVER
    solve = None
    solves = 0
    imax, out_last = 1, 0
    resets = reset_cycles(r, CYCLES)
    pf = proom = 0.5
    pstop = 0.0
    stops = 0
    regs = ("start", "tokN_valid", "tokN_pass0", "tokN_first", "tokN_k", "tokNN_valid", "tokNN_pass0",
            "tokNN_first", "tokNN_k", "running", "copyNow", "copyNext", "outValid", "outIndex", "outShift",
            "outLoad", "outLoadAhead", "outIsLast", "runCycles")
    for t in range(CYCLES):
        if t % SEGMENT == 0:
            pf, proom = r.choice((0.05, 0.3, 1.0)), r.choice((0.2, 0.6, 1.0, 1.0))
            pstop = r.choice((0.0, 0.1, 0.5))
        if t in resets:
            b.reset_h.value = 1
            b.set(frameFills=0, frameReady=0, outRoom=0, stop=0)
            fill, last_done, solve = None, NEVER, None
            await next_cycle(dut)
            continue
        b.reset_h.value = 0
        before = b.regs(regs)
        # ---- the frame: filled when none waits; ready from the cycle after its fill to its start
        ready = fill is not None and fill < t
        fills = int(fill is None and r.random() < pf)
        if r.random() < 0.2:
            imax, out_last = r.randint(1, 3), r.randrange(max_out)
        room = int(r.random() < proom)
        stop = int(r.random() < pstop)
        b.set(frameFills=fills, frameReady=ready, imax=imax, imaxOne=imax == 1, outLast=out_last, outRoom=room,
              stop=stop)
        if fills:
            fill = t
        await settle()
        got = b.regs(regs)
        assert got == before, f"{tag} t={t}: registered outputs follow the inputs: {before} -> {got}"
        got["shiftAhead"], got["done"] = b.get("outShiftAhead"), b.get("done")
        # ---- the start: the frame's fill and the previous solve's done, plus two
        s_next = None
        if fill is not None and fill < t + 2 and (solve is None or solve.get("done") is not None):
            s_next = max(fill, last_done if solve is None else solve["done"]) + 2
        if s_next == t + 1:   # the start is decided: imax is latched now, outLast at the start
            if solve is not None:
                last_done = solve["done"]
            solve = {"s": t + 1, "I": imax, "P": p["firstLen"] + imax * p["L"], "decided": 0, "shifts": {},
                     "done": None}
            solve["copy"] = copies(p, solve["s"], imax)
        if stop and solve is not None and solve["done"] is None:   # the early exit at an iteration's end
            i, rest = divmod(t - solve["s"] + 2 - p["firstLen"], p["L"])
            if rest == 0 and 1 <= i < solve["I"]:
                solve["I"], solve["P"] = i, p["firstLen"] + i * p["L"]
                solve["copy"] = copies(p, solve["s"], i)
                stops += 1
        got["iters"] = b.get("iters")
        exp = {k: 0 for k in (*regs, "shiftAhead", "done", "iters")}
        if solve is not None:
            s, P = solve["s"], solve["P"]
            if t == s:
                solve["O"] = out_last
                fill = None   # taken: frameReady drops next cycle
                solves += 1
            exp["start"] = int(t == s)
            for port, pos in (("tokN", t - s), ("tokNN", t - s + 1)):
                for f, v in (token(p, solve, pos) or {}).items():
                    exp[f"{port}_{f}"] = v
            exp["running"] = int(s + 1 <= t <= s + P)
            exp["copyNow"], exp["copyNext"] = int(t in solve["copy"]), int(t + 1 in solve["copy"])
            e = s + P
            exp["outLoad"], exp["outLoadAhead"] = int(t == e), int(t == e - 1)
            if t >= e and solve["done"] is None:   # the answer's words
                n = solve["O"] + 1
                exp["outValid"] = int(t > e)
                idx = solve["shifts"].get(t - 1)
                if idx is not None:
                    exp["outShift"], exp["outIndex"], exp["outIsLast"] = 1, idx, int(idx == n - 1)
                    if idx == n - 1:
                        exp["done"], exp["runCycles"], exp["iters"] = 1, P, solve["I"]
                        solve["done"] = t
                if solve["decided"] < n and room:
                    exp["shiftAhead"] = 1
                    solve["shifts"][t] = solve["decided"]
                    solve["decided"] += 1
        if not exp["outShift"]:   # the word's index and last flag: at a shift; the cycle count: at done
            exp["outIndex"], exp["outIsLast"] = got["outIndex"], got["outIsLast"]
        if not exp["done"]:
            exp["runCycles"], exp["iters"] = got["runCycles"], got["iters"]
        for port in ("tokN", "tokNN"):   # row, pass and iteration of a token that issues nothing: no contract
            if not exp[f"{port}_valid"]:
                for f in ("pass0", "first", "k"):
                    exp[f"{port}_{f}"] = got[f"{port}_{f}"]
        diff = {k: (got[k], exp[k]) for k in exp if got[k] != exp[k]}
        assert not diff, f"{tag} t={t}: (got, expected) {diff}; solve {solve}, frame filled at {fill}"
        await next_cycle(dut)
    assert solves > 15 and stops > 3, f"{tag}: {solves} solves, {stops} early exits"
    dut._log.info("%s: %d solves, %d early exits", tag, solves, stops)


@cocotb.test()
async def pass_sequencer(dut):
    await each(dut, "PassSequencer", run_pass_sequencer)
