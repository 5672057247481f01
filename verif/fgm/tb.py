"""cocotb testbench of a generated FGM core: the shared scenarios of verif/tb.py and the rewrite of its data
memories (matrices, bounds, beta) over AXI4-Lite."""
from __future__ import annotations

import cocotb
from cocotb.triggers import ClockCycles
from cocotbext.axi import AxiResp

from verif.tb import (TB, TIMEOUT_MS, back_to_back, bitexact_random, cycle_contract, interleaving,  # noqa: F401
                      output_all, reset_mid_solve, saturation_flag, tlast_error, write_meets_frame)


@cocotb.test(timeout_time=TIMEOUT_MS, timeout_unit="ms")
async def axil_rewrite(dut):
    """Matrices, bounds and beta rewritten over AXI4-Lite change the next solve as the model predicts; a write
    during a solve is rejected (SLVERR, WRITE_REJECTED) and that solve is unchanged; bad addresses and values
    are refused."""
    tb = TB(dut, seed=18)
    await tb.reset()
    rm, m = tb.rm, tb.model
    ident, resp = await tb.read(rm["ID"])
    assert ident == 0x46474D31 and resp == AxiResp.OKAY
    c0, _ = await tb.read(rm["CONFIG0"])
    assert c0 & 0xFFFF == tb.n and c0 >> 16 == tb.core["P"]
    assert await tb.write(rm["IMAX"], 0) == AxiResp.SLVERR
    w = tb.random_w()
    await tb.solve_and_check(w, "baseline")
    # rewrite: one coefficient of each matrix, the bounds of the last row, beta
    i, j = tb.rng.randrange(tb.n), tb.rng.randrange(tb.n)
    new_a = int(m.A[i, j]) + (1 << (tb.core["frac_bits"] - 3))
    assert await tb.write(rm.mat_a(i, j), new_a) == AxiResp.OKAY
    m.A[i, j] = new_a
    jf = tb.rng.randrange(tb.nw)
    new_f = -int(m.F[i, jf]) // 2
    assert await tb.write(rm.mat_f(i, jf), new_f) == AxiResp.OKAY
    m.F[i, jf] = new_f
    r = tb.n - 1
    lo, hi = int(m.lo[r]), int(m.hi[r])
    new_lo, new_hi = (3 * lo + hi) // 4, (lo + 3 * hi) // 4
    assert await tb.write(rm.ubox(r, False), new_lo) == AxiResp.OKAY
    assert await tb.write(rm.ubox(r, True), new_hi) == AxiResp.OKAY
    assert not (await tb.status())["WARM_VALID"], "a bounds write must drop the warm start"
    lo_v, hi_v = m.lo.copy(), m.hi.copy()
    lo_v[r], hi_v[r] = new_lo, new_hi
    m.write_bounds(lo_v, hi_v)
    new_beta = m.beta - (m.beta >> 3)
    assert await tb.write(rm["BETA"], new_beta) == AxiResp.OKAY
    assert await tb.write(rm["ONE_PLUS_BETA"], (1 << tb.core["frac_bits"]) + new_beta) == AxiResp.OKAY
    m.beta, m.opb = new_beta, (1 << tb.core["frac_bits"]) + new_beta
    await tb.set_ctrl(out_all=True)
    for k in range(3):
        await tb.solve_and_check(tb.random_w(), f"after rewrite {k}")
    # a write during a solve is rejected and does not touch that solve
    w = tb.random_w()
    exp, _ = tb.expect(w)
    await tb.send(w)
    await ClockCycles(dut.clock, tb.nw + 4)
    assert (await tb.status())["BUSY"]
    assert await tb.write(rm.mat_a(0, 0), 0) == AxiResp.SLVERR
    got = await tb.recv()
    assert got == exp, "the rejected write changed the running solve"
    assert (await tb.status())["WRITE_REJECTED"]
    # values that do not fit the word, addresses past the data
    big = 1 << (tb.core["signals"]["coef"]["width"] + 1)
    assert await tb.write(rm.mat_a(0, 0), big) == AxiResp.SLVERR
    assert await tb.write(rm["ONE_PLUS_BETA"] + 4, 0) == AxiResp.DECERR
    if tb.n < (1 << rm.cb):          # a column past the row (else that address is the next row's column 0)
        assert await tb.write(rm.mat_a(0, tb.n), 0) == AxiResp.DECERR
    assert not (await tb.read(rm.mat_a(0, 0)))[1] == AxiResp.OKAY, "data memories are write-only"
    await tb.solve_and_check(tb.random_w(), "after refused writes")
    # a write of Phi_n (read from the first cycle of a solve) racing the next frame: seen by that frame's solve
    # whenever it is accepted
    await write_meets_frame(tb, "F", rm.mat_f, tb.nw)
