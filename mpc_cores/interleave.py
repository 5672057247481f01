"""The cycle contract of a core that interleaves K_p independent problems on its row units (shell.TurnSequencer):
its rounds, when a problem's passes run, when its answer comes, and the throughput.

Time runs in rounds of R = max(L, K_p K) cycles from reset: problem slot j owns the turn of K cycles at round cycle
j K, in which the row units issue the rows of its next pass (the first pass, then one per iteration); a turn
of a slot with nothing to do issues nothing. Cycle 0 is the first cycle after reset; the token register holds row
0 of slot j's turns at cycles 1 + j K + q R.

A frame whose last word's handshake is at cycle a is taken at a + 1 if its slot is free (else in the cycle after
the slot's answer has left), and its first pass runs in the first turn of its slot that starts at T0 >= take + 2.
Its answer's first word is valid at T0 + Imax R + L + 2, or in the cycle after the previous answer's last word
when that is later. K_p = 1 is the plain sequencer (shell.PassSequencer): its solve starts PASS_START cycles after
the last word's handshake, and its answer passes an output queue of PASS_QUEUE cycles (FGM: 5 + K + Imax L to the
answer's first word).
"""
from __future__ import annotations

from dataclasses import dataclass

# K_p = 1 (shell.PassSequencer): the solve starts PASS_START cycles after the frame's last word's handshake (the
# start is decided in two registers, so that the row memories' addresses are registered beside their blocks)
PASS_START = 2
# K_p = 1: the answer's words pass a queue (shell.AnswerQueue) on their way to m_axis, so that the stream's tready
# does not reach the answer register and the sequencer: one cycle
PASS_QUEUE = 1
# the answer's first word is valid ANSWER_AFTER cycles after the last iteration's results are complete (L cycles
# after its turn began): the answer queue's register and the output register
ANSWER_AFTER = 2
# from the last input word's handshake to the first turn the frame can use: taken a cycle later, the slot loaded a
# cycle after that, and the turn decided in the cycle before it begins
TAKE_TO_TURN = 3
# from the answer's last word's handshake to the first turn the next frame of the slot can use: the slot free a
# cycle later, the waiting frame taken then, loaded a cycle after, the turn decided in the cycle before it begins
FREE_TO_TURN = 3


@dataclass(frozen=True)
class Interleave:
    """K rows per pass and unit, Kp problems, L cycles per pass (the pipeline, eq. (23) of 002)."""
    K: int
    Kp: int
    L: int

    @property
    def R(self) -> int:
        """cycles between two passes of one problem"""
        return max(self.L, self.Kp * self.K) if self.Kp > 1 else self.L

    def turn_start(self, slot: int, earliest: int) -> int:
        """the first cycle >= earliest (cycles from reset) at which slot's turn begins"""
        phase = 1 + slot * self.K
        if earliest <= phase:
            return phase
        return phase + -(-(earliest - phase) // self.R) * self.R

    def answer_from_turn(self, imax: int) -> int:
        """from the first pass's turn to the answer's first word valid (the output port free)"""
        return imax * self.R + self.L + ANSWER_AFTER

    def latency_bounds(self, imax: int) -> tuple[int, int]:
        """from the last input word's handshake to the first output word, a free slot and output port: the least
        and the most (the wait for the slot's turn is between 0 and R - 1 cycles)"""
        lo = TAKE_TO_TURN + self.answer_from_turn(imax)
        return lo, lo + self.R - 1

    def saturated(self, out_words: int, nw: int) -> bool:
        """with frames always waiting, in slot order, every turn carries a pass: a slot's answer leaves and its next
        frame is taken and loaded before its next turn, and the frame buffer refills within a turn"""
        # slack between a slot's answer leaving and its next turn; the next slot's frame streams in (nw words) after
        # this slot's frame is taken and must be taken before that slot's turn, K cycles later
        slack = self.R - (self.L + ANSWER_AFTER + out_words - 1) - FREE_TO_TURN
        return slack >= 0 and nw + 1 <= self.K + slack

    def period(self, imax: int, out_words: int, nw: int) -> int:
        """cycles per solve of each problem when frames always wait (in slot order, no output backpressure)"""
        lost = 0 if self.saturated(out_words, nw) else 1
        return (imax + 1 + lost) * self.R

    def throughput(self, imax: int, out_words: int, nw: int) -> float:
        """solves per cycle, frames always waiting"""
        return self.Kp / self.period(imax, out_words, nw)

    def mac_utilisation(self, imax: int, out_words: int, nw: int) -> float:
        """share of cycles in which the row units take a row, frames always waiting"""
        return self.Kp * (imax + 1) * self.K / self.period(imax, out_words, nw)


def covering_problems(K: int, L: int, out_words: int, nw: int, most: int = 16) -> int:
    """the least K_p at which every turn carries a pass when frames always wait (1 when none up to `most` does)"""
    for kp in range(2, most + 1):
        if Interleave(K, kp, L).saturated(out_words, nw):
            return kp
    return 1


def core_fields(K: int, L: int, kp: int, imax: int, out_words: int, nw: int, one_latency: int) -> dict:
    """core.json's interleaving entries: K_p, the period of a problem's passes, the latency's range and the
    throughput and MAC use with frames always waiting in problem order. `one_latency`: the latency of a core without
    interleaving (its next solve starts as the previous answer's last word enters the output queue: one cycle
    before that latency, less the queue's PASS_QUEUE, after the word before it left)."""
    il = Interleave(K, kp, L)
    if kp > 1:
        lo, hi = il.latency_bounds(imax)
        rate, util = il.throughput(imax, out_words, nw), il.mac_utilisation(imax, out_words, nw)
    else:
        lo = hi = one_latency
        rate = 1 / (one_latency - PASS_QUEUE + out_words - 1)
        util = (imax + 1) * K * rate
    return {"problems": kp, "period_cycles": il.R, "rows_per_turn": K, "latency_cycles": {"min": lo, "max": hi},
            "throughput_solves_per_cycle": rate, "mac_utilisation": util}


def report_lines(K: int, L: int, kp: int, imax: int, out_words: int, nw: int, one_latency: int) -> list[str]:
    """the design report's lines on the cycles per solve and on interleaving"""
    f = core_fields(K, L, kp, imax, out_words, nw, one_latency)
    cover = covering_problems(K, L, out_words, nw)
    lat = f["latency_cycles"]
    cyc = (f"  Latency: {lat['min']} cycles per solve at Imax = {imax}" if kp == 1 else
           f"  Latency: {lat['min']} to {lat['max']} cycles per solve at Imax = {imax} (the wait for the problem's "
           f"turn, then {TAKE_TO_TURN} + Imax R + L + {ANSWER_AFTER})")
    head = f"  Problems: K_p = {kp}" + (f", a round of R = max(L, K_p K) = {f['period_cycles']} cycles per "
                                       f"iteration of each" if kp > 1 else "")
    tail = (f"every turn is busy from K_p = {cover}" if cover > 1 else "no K_p up to 16 keeps every turn busy")
    return [cyc, f"{head}; {f['throughput_solves_per_cycle']:.5f} solves per cycle with frames always waiting, MAC "
                 f"utilisation {100 * f['mac_utilisation']:.1f} %; {tail}"]
