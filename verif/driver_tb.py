"""cocotb bench of a core's generated C driver (<module>_driver.c, mpc_cores.cdriver) on the Verilator model.

The driver, built as a shared library (CORE_DRIVER_LIB), runs in a thread of cocotb's bridge (cocotb.task.bridge);
its four hooks are Python functions that hand each access to the simulation (cocotb.task.resume): a register write
or read becomes an AXI4-Lite transaction of cocotbext-axi's master, a frame a transfer on s_axis, an answer a frame
from m_axis. So every call of the driver drives the RTL cycle by cycle, and its results are compared with the
core's bit-exact golden model beside it (mpc_cores.driver.TB, or the kind testbench's subclass): the identity
check, random solves warm and cold with and without OUT_ALL (every word, STATUS's flags, LAST_CYCLES against
core.json's cycle contract, the iterations), HOLD, a rewrite of data-region elements between solves (a matrix
coefficient and the parameter box, the model rewritten alike), and the driver's refusals (an index outside a
region, an IMAX outside its register, a value that does not fit its word).

Environment: CORE_OUT, CORE_DRIVER_LIB, CORE_RANDOM (solves, default 12), CORE_MEASURE."""
from __future__ import annotations

import ctypes
import importlib
import os

import cocotb
from cocotb.task import bridge, resume

from mpc_cores import registry
from mpc_cores.cdriver import names
from mpc_cores.driver import TB, measure

c_int, c_u32, c_i64, c_uint, c_vp = ctypes.c_int, ctypes.c_uint32, ctypes.c_int64, ctypes.c_uint, ctypes.c_void_p
WRITE = ctypes.CFUNCTYPE(c_int, c_vp, c_u32, c_u32)
READ = ctypes.CFUNCTYPE(c_int, c_vp, c_u32, ctypes.POINTER(c_u32))
SEND = ctypes.CFUNCTYPE(c_int, c_vp, ctypes.POINTER(c_i64), c_uint)
RECV = ctypes.CFUNCTYPE(c_int, c_vp, ctypes.POINTER(c_i64), c_uint)


class Io(ctypes.Structure):
    _fields_ = [("user", c_vp), ("reg_write", WRITE), ("reg_read", READ), ("send", SEND), ("recv", RECV)]


class Handle(ctypes.Structure):
    _fields_ = [("io", c_vp), ("ctrl", c_u32)]


def result_type(core: dict):
    """The ctypes twin of <p>_result_t: STATUS's one-bit fields, in the header's order"""
    flags = [f["name"].lower() for r in core["registers"] if r["name"] == "STATUS" for f in r["fields"]
             if f["width"] == 1]
    status = type("Status", (ctypes.Structure,), {"_fields_": [(f, ctypes.c_uint8) for f in flags] + [("raw", c_u32)]})
    return type("Result", (ctypes.Structure,), {"_fields_": [
        ("words", c_uint), ("cycles", c_u32), ("iterations", c_u32), ("met", ctypes.c_uint8), ("status", status),
        ("status_word", c_i64)]})


def _tb_class(kind):
    """the kind testbench's TB subclass (its expected answer: the DGP's ends with the status word), else TB"""
    mod = importlib.import_module(kind.testbench)
    return next((v for v in vars(mod).values() if isinstance(v, type) and issubclass(v, TB) and v is not TB), TB)


def _iterations(r, imax: int) -> tuple[int, bool]:
    """the model's iterations and whether its stopping test ended the solve"""
    it, met = getattr(r, "iterations", None), getattr(r, "met", False)
    if it is None:
        return imax, False
    return (int(it[0]), bool(met[0])) if hasattr(it, "__len__") else (int(it), bool(met))


def rewrites(tb, core: dict) -> list[tuple[str, tuple, int, object]]:
    """(region, indices, value, apply to the model) of a data rewrite: one coefficient of the parameter matrix
    (FGM Phi_n, the ADMM family's G~) and a narrower box of parameter word 0"""
    m, rng, P = tb.model, tb.rng, core.get("P", 1)
    regions = core.get("regions", {})
    out = []
    if "MAT_F" in regions:
        i, j = rng.randrange(tb.n), rng.randrange(tb.nw)
        v = -int(m.F[i, j]) // 2 + (1 << max(0, core["frac_bits"] - 4))
        out.append(("MAT_F", (i // P, i % P, j), v, lambda v=v, i=i, j=j: m.F.__setitem__((i, j), v)))
    if "MAT_G" in regions:
        i, j = rng.randrange(tb.n), rng.randrange(tb.nw + 1)
        v = int(m.G[i, j]) // 2
        out.append(("MAT_G", (i, j), v, lambda v=v, i=i, j=j: m.G.__setitem__((i, j), v)))
    box = next((g for g in ("XBOX", "WBOX") if g in regions), None)
    if box:
        lo, hi = tb.box
        for h, v in ((0, int(lo[0]) // 2), (1, int(hi[0]) // 2)):
            out.append((box, (0, h), v, lambda v=v, h=h: tb.box[h].__setitem__(0, v)))
    return out


@cocotb.test(timeout_time=2000, timeout_unit="ms")
async def c_driver(dut):
    core_out = os.environ["CORE_OUT"]
    cls = _tb_class(registry.get(__import__("json").load(open(os.path.join(core_out, "core.json")))["core"]))
    tb = cls(dut, seed=31)
    await tb.reset()
    core, rm = tb.core, tb.rm
    p, _ = names(core["module"])
    lib = ctypes.CDLL(os.environ["CORE_DRIVER_LIB"])
    Result = result_type(core)
    status_word = registry.get(core["core"]).answer_status_word
    sw = core["stream_width"]

    @resume
    async def axil_write(off, val):
        return int(await tb.write(off, val))

    @resume
    async def axil_read(off):
        v, resp = await tb.read(off)
        return v, int(resp)

    @resume
    async def frame_out(words):
        await tb.send(words)

    @resume
    async def frame_in():
        return await tb.recv()

    def reg_write(_u, off, val):
        return axil_write(off, val)

    def reg_read(_u, off, ptr):
        v, resp = axil_read(off)
        ptr[0] = v
        return resp

    def send(_u, words, count):
        w = [words[i] for i in range(count)]
        assert all(-(1 << (sw - 1)) <= x < (1 << (sw - 1)) for x in w), w
        frame_out(w)
        return 0

    def recv(_u, words, room):
        got = frame_in()
        if len(got) > room:
            return -1
        for i, x in enumerate(got):
            words[i] = x
        return len(got)

    hooks = (WRITE(reg_write), READ(reg_read), SEND(send), RECV(recv))   # kept alive for the C side
    io = Io(None, *hooks)
    h = Handle()
    fn = {k: getattr(lib, f"{p}_{k}") for k in ("init", "set_ctrl", "set_imax", "hold", "status", "clear", "solve")}
    for f in fn.values():
        f.restype = c_int
    solves = int(os.environ.get("CORE_RANDOM") or 12)
    E_RANGE, E_BUS = -5, -1
    log = {"solves": 0, "rewrites": 0, "warm": 0, "out_all": 0}

    def solve(tag: str, outside: float = 0.0):
        w = tb.random_w(outside)
        exp, r = tb.expect(w)
        out = (c_i64 * (tb.n + 1))()
        res = Result()
        wa = (c_i64 * tb.nw)(*[int(x) for x in w])
        assert fn["solve"](ctypes.byref(h), wa, out, ctypes.byref(res)) == 0, f"{tag}: solve failed"
        got = [out[i] for i in range(res.words)] + ([res.status_word] if status_word else [])
        assert got == exp, f"{tag}: driver {got} != model {exp}"
        it, met = _iterations(r, tb.imax)
        assert (res.iterations, bool(res.met)) == (it, met), f"{tag}: iterations {res.iterations} {res.met}"
        # the sticky flags since the last clear, as the model's solves set them
        for flag in ("sat", "overflow"):
            v = getattr(r, flag)
            sticky[flag] |= bool(v[0]) if hasattr(v, "__len__") else bool(v)
            assert bool(getattr(res.status, flag)) == sticky[flag], f"{tag}: STATUS.{flag.upper()}"
        assert not res.status.busy and res.status.raw >> rm.STATUS_BITS["WARM_VALID"] & 1
        # the latency the monitor saw, against core.json's contract, and LAST_CYCLES as the register reads
        lat = tb.out_start[-1] - tb.in_done[-1]
        if core.get("problems", 1) > 1:     # interleaved problems: the wait for the problem's turn varies
            lo, hi = core["latency_cycles"]["min"], core["latency_cycles"]["max"]
            assert lo <= lat <= hi, f"{tag}: {lat} cycles, core.json: {lo} to {hi}"
        else:
            # a zero start (the model's zero_start: its first pass skipped) takes core.json's saving fewer cycles
            zs = getattr(r, "zero_start", None)
            saved = int(zs[0]) * core["zero_start_saving_cycles"] if zs is not None else 0
            assert lat == core["solve_overhead_cycles"] + it * core["cycles_per_iteration"] - saved, \
                f"{tag}: {lat} cycles"
        assert (res.cycles, 0) == axil_read(rm["LAST_CYCLES"]), f"{tag}: LAST_CYCLES {res.cycles}"
        log["solves"] += 1

    sticky = {"sat": False, "overflow": False}

    def run():
        assert fn["init"](ctypes.byref(h), ctypes.byref(io)) == 0, "identity check failed"
        for k in range(solves):
            warm, out_all = k % 3 != 0, k % 4 == 3
            assert fn["set_ctrl"](ctypes.byref(h), int(warm), int(out_all)) == 0
            tb.warm, tb.out_all = warm, out_all
            log["warm"] += warm
            log["out_all"] += out_all
            if k == solves // 2:     # the data rewrite between solves, with the core held at rest
                assert fn["hold"](ctypes.byref(h), 1, 100) == 0
                for region, idx, v, apply in rewrites(tb, core):
                    f = getattr(lib, f"{p}_write_{region.lower()}")
                    f.restype = c_int
                    assert f(ctypes.byref(h), *idx, c_int(v)) == 0, (region, idx, v)
                    apply()
                    log["rewrites"] += 1
                    dims = core["regions"][region]["dims"]
                    assert f(ctypes.byref(h), *dims, c_int(0)) == E_RANGE
                    big = 1 << min(31, core["stream_width"] + 4)
                    assert f(ctypes.byref(h), *idx, c_int(big)) == E_BUS, f"{region}: a value too wide"
                assert fn["hold"](ctypes.byref(h), 0, 0) == 0
            solve(f"solve {k}", outside=0.1 if k % 5 == 4 else 0.0)
        assert fn["set_imax"](ctypes.byref(h), 0) == E_RANGE
        assert fn["clear"](ctypes.byref(h)) == 0
        st = Result().status
        assert fn["status"](ctypes.byref(h), ctypes.byref(st)) == 0 and not (st.sat or st.overflow), "clear"

    await bridge(run)()
    st, _ = await tb.read(rm["SOLVES"])
    assert st == log["solves"] == solves and log["rewrites"] >= (2 if core.get("regions") else 0), log
    measure({"test": "c_driver", "module": core["module"], **log})
