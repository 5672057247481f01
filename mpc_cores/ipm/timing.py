"""Cycle model of the interior-point core: the sequencer of ipm.IpmCore step by step, with the Stage 1 programs'
cycles (mpc_cores.ipm.isa.cycles) and the MINRES batch's ((I_MR + 1) P S + c, the MINRES core's contract), for
frames waiting at the input in a given channel order. It gives each answer's latency as the core counts it
(LAST_CYCLES: from the id word's handshake to the status word's), which the testbench compares cycle for cycle.

The hand-offs, in cycles (IpmCore, MinresCore):
  a program started on the cycle its predecessor is done runs back to back (sample, cold/warm, linearise;
  receive, receive, ..., update, linearise or output);
  the last word of a MINRES frame is taken (by the register slice in front of MINRES) one cycle after linearise is
  done; the sequencer sees the frame sent one cycle later, and acts on the next (another frame of the forming
  group: its id word on the cycle after; the next problem's update likewise); else it closes the batch and
  decides in its idle state a cycle later;
  MINRES takes each word TO_MINRES cycles after the slice, and starts a full batch the cycle after its last word
  (a closed partial batch one cycle later), but no
  earlier than (I_MR + 1) P S cycles after it started the previous batch (when that batch's feed has taken its
  last element: batches overlap), and streams its answers (batch cycles) + READ_LATENCY cycles later (a word is
  issued that far ahead of its read), or the cycle after the previous batch's last answer word was taken if that
  is later;
  a receive waiting for MINRES is done N + 2 + ISSUE_GAP + FROM_MINRES cycles after MINRES starts streaming (its k-th problem
  N + 2 cycles later each), ISSUE_GAP after it takes the last word, else after its own cycles, from the second
  problem on ID_STALL more (the norm and id words between two problems' solutions, which arrive 3 cycles after
  the previous problem's last word while the next receive takes its first word ISSUE_GAP + PROGRAM_START + 1
  cycles after it);
  an answer's status word leaves 3 cycles after output is done; the sequencer acts 2 cycles later (the next
  problem's update) or decides in its idle state 2 cycles later.
The model assumes Stage 1 is in its receive when MINRES starts streaming (Stage 1 hidden, see `hidden`) or late
enough that MINRES waits; the testbench checks both regimes against the RTL.
"""
from __future__ import annotations

from mpc_cores.ipm.isa import ISSUE_GAP, PROGRAM_START
from mpc_cores.minres.schedule import READ_LATENCY

ID_STALL = max(0, 2 - ISSUE_GAP - PROGRAM_START)
# the register slice between the core's sequencer and MINRES's input (ipm.IpmCore, bus.RegSlice)
TO_MINRES = 1
# the register slice between MINRES's output and Stage 1's input (ipm.IpmCore): a word MINRES streams reaches
# Stage 1 one cycle later
FROM_MINRES = 1


def simulate(core: dict, order: list[int], warm: set | None = None, i_nw: int | None = None,
             i_mr: int | None = None, out_all: bool = False) -> dict:
    """Frames for the channels in `order` (distinct, 2P at most) wait at the input from cycle 0 (`out_all`: the
    answers carry z and the steady state, CTRL.OUT_ALL). Returns
    {"take": id word handshake cycle, "answer": status word cycle, "latency": their difference} per channel."""
    P, N = core["P"], core["N"]
    C = core["stage1_cycles"]
    i_nw = i_nw or core["i_nw"]
    i_mr = i_mr or core["iterations"]
    batch = core["minres_batch_cycles_imax0"] + i_mr * core["cycles_per_iteration"]
    warm = warm or set()
    queue = list(order)
    chans: list[list[int]] = [[], []]    # per group its channels in batch order (empty: idle)
    solves = [0, 0]
    fifo: list[tuple[int, int]] = []     # (group, cycle its batch is complete in MINRES), oldest first
    mr_next = 0                          # first cycle MINRES may start its next batch (the previous one's feed)
    out_free = 0                         # first cycle MINRES may stream a batch's answers (the previous ones taken)
    span = (i_mr + 1) * core["cycles_per_iteration"]
    take, answer = {}, {}

    def close(g: int, f: int) -> int:
        """the batch's last word taken on cycle f: queued in MINRES; the sequencer decides 2 cycles later"""
        fifo.append((g, f + TO_MINRES + (1 if len(chans[g]) == P else 2)))
        return f + 2

    t = 0                                # the cycle of the sequencer's next decision (idle state)
    while queue or fifo:
        head_g = queue[0] // P if queue else None
        form = head_g is not None and not chans[head_g] and (not fifo or (len(fifo) == 1 and head_g != fifo[0][0]))
        if form:
            g, s = head_g, t + 1
            while True:
                c = queue.pop(0)
                take[c] = s
                chans[g].append(c)
                f = s + C["sample"] + C["warm" if c in warm else "cold"] + C["linearise"] + 1
                if queue and queue[0] // P == g and len(chans[g]) < P:
                    s = f + 2            # the next frame's id word
                    continue
                t = close(g, f)
                break
            continue
        assert fifo, "the cycle model has nothing to do"
        g, full = fifo.pop(0)
        solves[g] += 1
        start = max(full, mr_next)
        mr_next = start + span
        o = max(start + READ_LATENCY + batch, out_free)   # MINRES streams the answers
        done = t + 1
        for k in range(len(chans[g])):
            done = max(done + C["receive"] + (k > 0) * ID_STALL, o + N + 2 + ISSUE_GAP + FROM_MINRES + k * (N + 2))
        out_free = done + 1
        for k, c in enumerate(chans[g]):
            last = k == len(chans[g]) - 1
            end = done + C["update"]
            if solves[g] < i_nw:
                f = end + C["linearise"] + 1
                if last:
                    t = close(g, f)
                else:
                    done = f + 2         # the next problem's update
            else:
                answer[c] = end + C["output_all" if out_all else "output"] + 3
                if last:
                    t = answer[c] + 2
                else:
                    done = answer[c] + 2
        if solves[g] == i_nw:
            chans[g], solves[g] = [], 0
    return {c: {"take": take[c], "answer": answer[c], "latency": answer[c] - take[c]} for c in order}


def newton_cycles(c: dict) -> int:
    """Cycles one more Newton iteration adds to the last of 2P problems sent back to back (warm)."""
    order = list(range(2 * c["P"]))
    warm = simulate(c, order, warm=set(order))
    more = simulate(c, order, warm=set(order), i_nw=c["i_nw"] + 1)
    return max(v["latency"] for v in more.values()) - max(v["latency"] for v in warm.values())


def stage1_hidden(c: dict) -> bool:
    """Stage 1 hides behind MINRES: a Newton iteration of 2P problems takes two MINRES batches back to back,
    2 (I_MR + 1) P S cycles."""
    return newton_cycles(c) == 2 * (c["iterations"] + 1) * c["cycles_per_iteration"]


def timing(c: dict) -> dict:
    """core.json's cycle facts: whether Stage 1 hides behind MINRES, the latency of 2P problems sent back to back
    (cold and warm), and eq. (18) of 001."""
    P, N, imr, inw = c["P"], c["N"], c["iterations"], c["i_nw"]
    order = list(range(2 * P))
    cold = simulate(c, order)
    warm = simulate(c, order, warm=set(order))
    eq18 = 2 * inw * (P * N + P) * imr
    per_newton = newton_cycles(c)
    bound = 2 * (imr + 1) * c["cycles_per_iteration"]
    hidden = per_newton == bound
    return {
        "stage1_hidden": hidden,
        "stage1_note": "" if hidden else (f"a Newton iteration takes {per_newton} cycles > 2 (I_MR + 1) P S = {bound}: "
                                          "Stage 1 sets the pace"),
        "latency_cycles_cold": max(v["latency"] for v in cold.values()),
        "latency_cycles": max(v["latency"] for v in warm.values()),
        "latency_per_channel": [warm[ch]["latency"] for ch in order],
        "cycles_per_solve": simulate(c, [0], warm={0})[0]["latency"],
        "cycles_per_newton_iteration": per_newton,
        "eq18_cycles": eq18,
        "latency_formula": (f"2P problems back to back, warm: {max(v['latency'] for v in warm.values())} cycles "
                            f"(mpc_cores.ipm.timing.simulate); eq. (18) of 001, 2 I_NW (P N + P) I_MR = {eq18}"),
    }
