"""cocotb testbench of a generated ADMM core: the shared scenarios of verif/tb.py and the rewrite of its data
memories (M11, G~, bounds, soft sets, parameter box) over AXI4-Lite."""
from __future__ import annotations

import cocotb
from cocotb.triggers import ClockCycles
from cocotbext.axi import AxiResp

from mpc_cores.admm.problem import BOX
from verif.tb import (TB, TIMEOUT_MS, back_to_back, bitexact_random, cycle_contract, interleaving,  # noqa: F401
                      output_all, reset_mid_solve, saturation_flag, tlast_error, write_meets_frame)


@cocotb.test(timeout_time=TIMEOUT_MS, timeout_unit="ms")
async def axil_rewrite(dut):
    """M11, G~, a box bound, a soft set and the parameter box rewritten over AXI4-Lite change the next solves as the
    model predicts (a bound write drops the warm start); writes during a solve, values that do not fit and
    addresses without data are refused; the data memories are write-only."""
    tb = TB(dut, seed=28)
    await tb.reset()
    rm, m, b = tb.rm, tb.model, tb.core["frac_bits"]
    ident, resp = await tb.read(rm["ID"])
    assert ident == 0x41444D31 and resp == AxiResp.OKAY
    c0, _ = await tb.read(rm["CONFIG0"])
    assert c0 & 0xFFFF == tb.n and c0 >> 16 == tb.core["P"]
    await tb.solve_and_check(tb.random_w(), "baseline")
    # one coefficient of each matrix, on a soft slack row (its pair's results leave with it) and a random row
    rng = tb.rng
    rows = [int(m.sd[0])] if m.sd.size else []
    for i in rows + [rng.randrange(tb.n)]:
        j = rng.randrange(tb.n)
        v = int(m.M11[i, j]) - (int(m.M11[i, j]) >> 2)
        assert await tb.write(rm.mat_m(i, j), v) == AxiResp.OKAY
        m.M11[i, j] = v
        jg = rng.randrange(tb.nw + 1)
        v = int(m.G[i, jg]) // 2
        assert await tb.write(rm.mat_g(i, jg), v) == AxiResp.OKAY
        m.G[i, jg] = v
    # bounds of a box component and the radius of a soft set
    box = [i for i in range(tb.n) if m.kind[i] == BOX]
    i = rng.choice(box)
    lo, hi = int(m.lo[i]), int(m.hi[i])
    assert await tb.write(rm.bnd(i, False), (3 * lo + hi) // 4) == AxiResp.OKAY
    assert await tb.write(rm.bnd(i, True), (lo + 3 * hi) // 4) == AxiResp.OKAY
    m.lo[i], m.hi[i] = (3 * lo + hi) // 4, (lo + 3 * hi) // 4
    if m.sd.size:
        k = rng.randrange(m.sd.size)
        r_new = int(m.sr[k]) // 2
        assert await tb.write(rm.bnd(int(m.sd[k]), True), r_new) == AxiResp.OKAY
        m.sr[k] = r_new
        assert await tb.write(rm.bnd(int(m.sx[k]), False), 0) == AxiResp.DECERR, "a soft state row holds no bounds"
    assert not (await tb.status())["WARM_VALID"], "a bounds write must drop the warm start"
    m.reset()
    # a narrower parameter box: the first word saturates sooner
    wl, wh = int(m.wlo[0]) // 2, int(m.whi[0]) // 2
    assert await tb.write(rm.wbox(0, False), wl) == AxiResp.OKAY
    assert await tb.write(rm.wbox(0, True), wh) == AxiResp.OKAY
    m.wlo[0], m.whi[0] = wl, wh
    tb.box = (m.wlo, m.whi)
    await tb.set_ctrl(out_all=True)
    for k in range(3):
        await tb.solve_and_check(tb.random_w(outside=0.1), f"after rewrite {k}")
    # a write during a solve is rejected and does not touch that solve
    w = tb.random_w()
    exp, _ = tb.expect(w)
    await tb.send(w)
    await ClockCycles(dut.clock, tb.nw + 4)
    assert (await tb.status())["BUSY"]
    assert await tb.write(rm.mat_m(0, 0), 0) == AxiResp.SLVERR
    got = await tb.recv()
    assert got == exp, "the rejected write changed the running solve"
    assert (await tb.status())["WRITE_REJECTED"]
    # values that do not fit the word, addresses past the data
    big = 1 << (tb.core["signals"]["coef"]["width"] + 1)
    assert await tb.write(rm.mat_m(0, 0), big) == AxiResp.SLVERR
    if tb.nw + 1 < (1 << rm.cb):     # a column past G~'s (else that address is the next row's column 0)
        assert await tb.write(rm.mat_g(0, tb.nw + 1), 0) == AxiResp.DECERR
    assert await tb.write(rm["CYCLES_PER_ITER"] + 4, 0) == AxiResp.DECERR
    assert (await tb.read(rm.mat_m(0, 0)))[1] != AxiResp.OKAY, "data memories are write-only"
    await tb.solve_and_check(tb.random_w(), "after refused writes")
    # a write of G~ (read from the first cycle of a solve) racing the next frame: seen by that frame's solve
    # whenever it is accepted
    await write_meets_frame(tb, "G", rm.mat_g, tb.nw + 1)
