"""The MINRES core's schedule as the generator computes it (minres.MinresParams), so that a design flow can plan
with it before generation; mpc_cores.minres.report checks it against the generator's hw.json."""
from __future__ import annotations

import math

# The scalar part of an iteration in program order (name, kind, operands), as minres.MinresParams.scalarOps;
# sources: nrm = ||u||^2, delta, c, cp, s, sp, gamma, eta.
SCALAR_OPS = (
    ("g1", "sqrt", ("nrm",)), ("m1", "mul", ("c", "delta")), ("m2", "mul", ("cp", "s")),
    ("m3", "mul", ("m2", "gamma")), ("a0", "sub", ("m1", "m3")), ("m4", "mul", ("a0", "a0")),
    ("s4", "add", ("m4", "nrm")), ("a1", "sqrt", ("s4",)), ("m5", "mul", ("s", "delta")),
    ("m6", "mul", ("cp", "c")), ("m7", "mul", ("m6", "gamma")), ("a2", "add", ("m5", "m7")),
    ("a3", "mul", ("sp", "gamma")), ("c1", "div", ("a0", "a1")), ("s1", "div", ("g1", "a1")),
    ("ceta", "mul", ("c1", "eta")), ("seta", "mul", ("s1", "eta")))
SCALAR_SOURCES = ("nrm", "delta", "c", "cp", "s", "sp", "gamma", "eta")
# cycles from a vector memory's read address to its word (minres.VecRam.ReadLatency)
READ_LATENCY = 2
# registers carrying each matvec product to the adder tree (minres.MinresParams.dotMove)
DOT_MOVE = 1
# the register between a shared operator's operand select and the operator (minres.StaticSchedule.OperandReg), and
# between an operation's operands and its own operator in the passes (minres.TimedOps.OperandReg)
OPERAND_REG = 1
# the batch's start decision registered before the passes' counters (MinresParams.StartReg): a cycle per batch
START_REG = 1


def _log2ceil(x: int) -> int:
    """chisel3.util.log2Ceil: bits of x - 1 (0 for x = 1)."""
    return (x - 1).bit_length()


def _asap(ops, unit_lat: dict, sources) -> int:
    """minres.StaticSchedule: ASAP in program order, an operation issuing when its operands are ready and its
    operator (one per kind, sub on the adder) is free, its result OPERAND_REG + the operator's latency later; the
    cycle of the last result."""
    ready = dict.fromkeys(sources, 0)
    busy = set()
    for name, kind, args in ops:
        unit = "add" if kind == "sub" else kind
        t = max(ready[a] for a in args)
        while (unit, t) in busy:
            t += 1
        busy.add((unit, t))
        ready[name] = t + OPERAND_REG + unit_lat[unit]
    return max(ready[o[0]] for o in ops)


def shared_latency(lat: dict) -> int:
    """Cycles of the scalar part on one operator per kind (minres.SharedScalar)."""
    return _asap(SCALAR_OPS, {"mul": lat["lat_mul"], "add": lat["lat_add"], "div": lat["lat_div"],
                              "sqrt": lat["lat_sqrt"]}, SCALAR_SOURCES)


def tree_latency(la: int) -> int:
    """Cycles of the pairwise reduction of la partial sums on one adder (minres.FStreamAcc.treeSchedule)."""
    level, ops = [f"p{i}" for i in range(la)], []
    while len(level) > 1:
        nxt = []
        for k in range(0, len(level), 2):
            if k + 1 < len(level):
                ops.append((f"t{len(ops)}", "add", (level[k], level[k + 1])))
                nxt.append(ops[-1][0])
            else:
                nxt.append(level[k])
        level = nxt
    return _asap(ops, {"add": la}, [f"p{i}" for i in range(la)])


def acc_latency(N: int, la: int) -> int:
    """minres.FStreamAcc.latency for a stream of N terms (the shared reduction when the stream is long enough)."""
    shared = la > 1 and N > tree_latency(la) + 1
    return la + 1 + (tree_latency(la) if shared else la * _log2ceil(la))


def schedule(N: int, M: int, K: int, lat: dict, P: int, warm: bool) -> dict:
    """P (0: eq. (15) of the core), the slot S, cycles per iteration P S and the batch's cycles at Imax = 0
    (a batch of Imax iterations takes batch_cycles_imax0 + Imax P S; back to back, batches start (Imax + 1) P S
    apart)."""
    la, lm, ld, ls = lat["lat_add"], lat["lat_mul"], lat["lat_div"], lat["lat_sqrt"]
    lat_matvec = 1 + DOT_MOVE + lm + la * _log2ceil(K)
    acc_tail = acc_latency(N, la) + 1
    # the passes' operations: operand register and operator (minres.MinresParams.opMul etc.)
    om, oa, od, osq = (OPERAND_REG + v for v in (lm, la, ld, ls))
    lat_b = om + 2 * oa
    lat_cx = 2 * om + 3 * oa + od
    t_row = M - 1 + READ_LATENCY + (om if warm else 0)
    t_b = t_row + N - 1 + lat_matvec + om + acc_tail
    t_s = t_b + N - 1 + lat_b + om + acc_tail

    def plan(lat_scalar: int) -> tuple[int, int, int]:
        need = t_s + lat_scalar + 1 + od + 1
        p = P or math.ceil(need / N)
        return need, p, max(N, math.ceil(need / p))

    shared = shared_latency(lat)
    lat_scalar = shared if plan(shared)[2] > shared else 4 * om + 2 * oa + osq + od
    need, P_, S = plan(lat_scalar)
    t_c = t_s + lat_scalar + 1
    return {"P": P_, "P_eq15": math.ceil(need / N), "slot_cycles": S, "cycles_per_iteration": P_ * S,
            "batch_cycles_imax0": P_ * S - S + t_c + N + lat_cx + START_REG}
