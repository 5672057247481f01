"""A small AXI4-Lite manager for protocol fuzzing, driving a core's s_axil_* ports directly (cocotbext-axi's master
always presents AW and W together).

Each channel runs on its own: a write's AW and W beats wait independent random delays, so either may come first
(or both on one cycle), with a random wstrb; transactions queue back to back (a channel presents its next beat on
the cycle after a handshake when its delay is 0); bready and rready drop at random. Responses are matched to
requests in order, as AXI4-Lite has no ids: a response without an accepted request is recorded as an error, and
`idle()` says whether every request has had its one response.

`write` and `read` have the signatures of cocotbext-axi's AxiLiteMaster (mpc_cores.driver.AxiDriver takes either).
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import cocotb
from cocotb.queue import Queue
from cocotb.triggers import Event, RisingEdge
from cocotbext.axi import AxiResp


@dataclass
class Result:
    """What AxiLiteMaster.write/read return: the response and, for a read, the data bytes."""
    resp: AxiResp
    data: bytes = b""


class _Pending:
    def __init__(self):
        self.event = Event()
        self.result: Result | None = None
        self.shown: dict[str, int] = {}   # cycle on which each beat was first presented


class AxiLiteFuzzMaster:
    """Manager of the AXI4-Lite port `prefix` of `dut`. Knobs (change them at any time): `delay`, the probability
    of one more idle cycle before a beat is presented (AW, W, AR independently); `stall`, the probability that
    bready or rready is low on a cycle; `strb`, None for a random wstrb per write, else the wstrb to use."""

    def __init__(self, dut, rng, prefix: str = "s_axil", delay: float = 0.0, stall: float = 0.0):
        self.clock = dut.clock
        self.rng = rng
        self.delay, self.stall, self.strb = delay, stall, None
        self.s = {n: getattr(dut, f"{prefix}_{n}") for n in (
            "awaddr", "awprot", "awvalid", "awready", "wdata", "wstrb", "wvalid", "wready", "bresp", "bvalid",
            "bready", "araddr", "arprot", "arvalid", "arready", "rdata", "rresp", "rvalid", "rready")}
        for n in ("awvalid", "wvalid", "arvalid", "awaddr", "awprot", "wdata", "wstrb", "araddr", "arprot"):
            self.s[n].value = 0
        self.s["bready"].value = 1
        self.s["rready"].value = 1
        self.aw, self.w, self.ar = Queue(), Queue(), Queue()
        self.accepted_w: deque[_Pending] = deque()   # writes with both beats taken, awaiting their B
        self.accepted_r: deque[_Pending] = deque()   # reads with AR taken, awaiting their R
        self.half: dict[str, deque] = {"aw": deque(), "w": deque()}  # beats taken whose partner is not yet
        self.errors: list[str] = []
        self.counts = {"aw": 0, "w": 0, "b": 0, "ar": 0, "r": 0}
        self.issued = 0   # writes issued (their effects happen in this order)
        # which beat of a write was presented first: "aw", "w" or "both" (the same cycle)
        self.order = {"aw": 0, "w": 0, "both": 0}
        self.cycle = 0
        for ch in ("aw", "w", "ar"):
            cocotb.start_soon(self._source(ch))
        cocotb.start_soon(self._sink("b"))
        cocotb.start_soon(self._sink("r"))

    # ---- requests
    async def write(self, addr: int, data, strb: int | None = None) -> Result:
        """Write one word (bytes, little-endian, or an int); returns the response."""
        value = int.from_bytes(data, "little") if isinstance(data, (bytes, bytearray)) else int(data)
        if strb is None:
            strb = self.rng.randrange(16) if self.strb is None else self.strb
        p = _Pending()
        self.issued += 1
        self.aw.put_nowait((p, {"awaddr": addr, "awprot": self.rng.randrange(8)}))
        self.w.put_nowait((p, {"wdata": value & 0xFFFFFFFF, "wstrb": strb}))
        await p.event.wait()
        return p.result

    async def read(self, addr: int, length: int = 4) -> Result:
        p = _Pending()
        self.ar.put_nowait((p, {"araddr": addr, "arprot": self.rng.randrange(8)}))
        await p.event.wait()
        return p.result

    def idle(self) -> bool:
        """Every request has been answered once, and nothing is queued or half taken."""
        return (not self.accepted_w and not self.accepted_r and not any(self.half.values())
                and self.aw.empty() and self.w.empty() and self.ar.empty()
                and self.counts["aw"] == self.counts["w"] == self.counts["b"]
                and self.counts["ar"] == self.counts["r"])

    # ---- channels
    async def _source(self, ch: str):
        valid, ready = self.s[f"{ch}valid"], self.s[f"{ch}ready"]
        queue = {"aw": self.aw, "w": self.w, "ar": self.ar}[ch]
        edge = RisingEdge(self.clock)
        while True:
            p, beat = await queue.get()
            while self.rng.random() < self.delay:
                valid.value = 0
                await edge
            for k, v in beat.items():
                self.s[k].value = v
            valid.value = 1
            p.shown[ch] = self.cycle
            while True:
                await edge
                if ready.value:
                    break
            valid.value = 0
            self.counts[ch] += 1
            if ch == "ar":
                self.accepted_r.append(p)
            else:
                other = "w" if ch == "aw" else "aw"
                if self.half[other] and self.half[other][0] is p:
                    self.half[other].popleft()
                    self.accepted_w.append(p)
                    t = p.shown
                    self.order["both" if t["aw"] == t["w"] else min(t, key=t.get)] += 1
                elif self.half[other]:
                    self.errors.append(f"{ch.upper()} of one write taken with the other beat of another")
                else:
                    self.half[ch].append(p)

    async def _sink(self, ch: str):
        valid, ready = self.s[f"{ch}valid"], self.s[f"{ch}ready"]
        edge = RisingEdge(self.clock)
        while True:
            await edge
            if ch == "b":
                self.cycle += 1
            if valid.value and ready.value:
                self.counts[ch] += 1
                pending = self.accepted_w if ch == "b" else self.accepted_r
                if not pending:
                    self.errors.append(f"{ch.upper()} response without an accepted request")
                else:
                    p = pending.popleft()
                    if ch == "b":
                        p.result = Result(AxiResp(int(self.s["bresp"].value)))
                    else:
                        p.result = Result(AxiResp(int(self.s["rresp"].value)),
                                          int(self.s["rdata"].value).to_bytes(4, "little"))
                    p.event.set()
            ready.value = int(self.rng.random() >= self.stall)
