"""The Stage 1 programs of the interior-point core for one MPC problem, in the instruction set of mpc_cores.ipm.isa.

Per problem slot (slot space), vectors of the boxed variables (nb of them) are laid out so that one instruction
covers the upper and the lower inequalities together: V = (lu, ll, su, sl), DV = (dlu, dll, dsu, dsl),
RG = (rGu, rGl), WT = (wu, wl). Programs:
  sample     IN x^ (n), r (ny); the steady state ss = (x_s, u_s) = Mxu r; x0 = x^ - x_s; lo, hi shifted by ss
  cold       the cold start: z = 0, (lambda, s) = start value
  warm       the warm start: the previous iterate unshifted (001), (lambda, s) raised to a floor
  linearise  (6a-d), (7), W_k, the variable column, bt, the preconditioner d and bh = d bt; OUT the MINRES frame
             (variable column, d, bh, z)
  update     IN the MINRES solution x; dz = d x; lines 4-7 of Algorithm 1 (direction, line search, step)
  output     u0 = clamp(z_u0, lo, hi) + u_s, mu; OUT
A sample runs: sample, [cold], then I_NW times (linearise, MINRES, update), then output.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mpc_cores.ipm.isa import Instr, Operand, cycles
from mpc_cores.ipm.sparse import SparseMpc

# index tables
T_BROW, T_BPRIM, T_PRIM, T_EQ, T_SHIFT, T_U0 = range(6)


def S(addr, mode="vec", table=0) -> Operand:
    return Operand("slot", addr, mode, table)


def C(addr, mode="vec", table=0) -> Operand:
    return Operand("const", addr, mode, table)


@dataclass
class Alloc:
    size: int = 0
    names: dict = field(default_factory=dict)

    def __call__(self, name: str, n: int) -> int:
        self.names[name] = (self.size, n)
        self.size += n
        return self.names[name][0]


@dataclass
class Stage1:
    slot: dict                 # name -> slot address
    const: dict                # name -> const address
    const_words: np.ndarray    # float64 values of the constant region
    tables: list
    slot_words: int
    programs: dict             # name -> list[Instr]

    def cycles(self, lat: dict) -> dict:
        return {k: cycles(v, lat) for k, v in self.programs.items()}


def build(s: SparseMpc, sigma: float, tau: float, precondition: bool, start_value: float = 1.0,
          warm_floor: float = 1e-2) -> Stage1:
    p = s.problem
    n, m, ny, N = p.nx, p.nu, p.ny, s.N
    L = s.L
    nb = len(s.bounded)
    npr = len(s.primal)
    eq = np.setdiff1d(np.arange(N), s.primal)
    if nb == 0:
        raise ValueError("the interior-point core needs at least one boxed variable")
    K0 = s.K0
    off = np.abs(K0 - np.diag(np.diag(K0))).max(axis=1)

    # ---- constant region
    ca = Alloc()
    consts = {}

    def const(name, v):
        v = np.atleast_1d(np.asarray(v, dtype=float))
        consts[ca(name, len(v))] = v

    const("zero", 0.0)
    const("one", 1.0)
    const("sigma", sigma)
    const("tau", tau)
    const("inv_ineq", 1.0 / s.n_ineq)
    const("start", start_value)
    const("floor", warm_floor)
    const("Hd", np.diag(K0)[s.primal])
    const("offp", off[s.primal])
    const("deq", 1.0 / np.sqrt(off[eq]))
    const("lo", s.lo)
    const("hi", s.hi)
    Mxu = np.vstack([s.Mx, s.Mu]) if ny else np.zeros((n + m, 0))
    for j in range(ny):
        const(f"Mxu{j}", Mxu[:, j])
    cw = np.zeros(ca.size)
    for a, v in consts.items():
        cw[a: a + len(v)] = v
    c = {k: a for k, (a, _) in ca.names.items()}

    # ---- slot region
    sa = Alloc()
    for name, size in (("z", N), ("V", 4 * nb), ("DV", 4 * nb), ("RG", 2 * nb), ("WT", 2 * nb), ("TT", 2 * nb),
                       ("LS", 2 * nb), ("RS", 2 * nb), ("w", nb), ("th", nb), ("dth", nb), ("t1", 4 * nb),
                       ("t2", nb), ("lo", nb), ("hi", nb), ("diag", npr), ("t3", npr), ("d", N), ("bt", N),
                       ("x", N), ("dz", N), ("t4", N), ("xin", n), ("r", max(ny, 1)), ("ss", n + m),
                       ("ts", n + m), ("u", m), ("mu", 1), ("smu", 1), ("acc", 1), ("amin", 1), ("amax", 1),
                       ("alpha", 1)):
        sa(name, size)
    a = {k: v for k, (v, _) in sa.names.items()}
    nb2, nb4 = 2 * nb, 4 * nb
    V, DV = a["V"], a["DV"]
    lu, ll, su, sl = V, V + nb, V + 2 * nb, V + 3 * nb

    tables = [np.asarray(s.primal[s.bounded]), np.asarray(s.bounded), np.asarray(s.primal), eq,
              np.asarray(s.shift_of), np.arange(L.u(0), L.u(0) + m)]

    I = Instr
    sample = [I("IN", n, d=S(a["xin"]))]
    if ny:
        sample += [I("IN", ny, d=S(a["r"])),
                   I("MUL", n + m, d=S(a["ss"]), a=C(c["Mxu0"]), b=S(a["r"], "scalar"))]
        for j in range(1, ny):
            sample += [I("MUL", n + m, d=S(a["ts"]), a=C(c[f"Mxu{j}"]), b=S(a["r"] + j, "scalar")),
                       I("ADD", n + m, d=S(a["ss"]), a=S(a["ss"]), b=S(a["ts"]))]
    else:
        sample += [I("MOV", n + m, d=S(a["ss"]), a=C(c["zero"], "scalar"))]
    sample += [I("SUB", n, d=S(a["xin"]), a=S(a["xin"]), b=S(a["ss"]), note="x0 = x^ - x_s"),
               I("SUB", nb, d=S(a["lo"]), a=C(c["lo"]), b=S(a["ss"], "gather", T_SHIFT)),
               I("SUB", nb, d=S(a["hi"]), a=C(c["hi"]), b=S(a["ss"], "gather", T_SHIFT))]

    cold = [I("MOV", N, d=S(a["z"]), a=C(c["zero"], "scalar")),
            I("MOV", nb4, d=S(V), a=C(c["start"], "scalar"))]
    warm = [I("MAX", nb4, d=S(V), a=S(V), b=C(c["floor"], "scalar"), note="warm start: (lambda, s) >= floor")]

    lin = [I("MOV", nb, d=S(a["th"]), a=S(a["z"], "gather", T_BROW), note="theta on the boxed variables"),
           I("MUL", nb2, d=S(a["LS"]), a=S(lu), b=S(su), note="(lu su, ll sl)"),
           I("ACC", nb2, d=S(a["acc"]), a=S(a["LS"])),
           I("MUL", 1, d=S(a["mu"]), a=S(a["acc"]), b=C(c["inv_ineq"]), note="mu (7)"),
           I("MUL", 1, d=S(a["smu"]), a=C(c["sigma"]), b=S(a["mu"])),
           I("SUB", nb, d=S(a["RG"]), a=S(a["hi"]), b=S(a["th"])),
           I("SUB", nb, d=S(a["RG"]), a=S(a["RG"]), b=S(su), note="rGu (6c)"),
           I("SUB", nb, d=S(a["RG"] + nb), a=S(a["th"]), b=S(a["lo"])),
           I("SUB", nb, d=S(a["RG"] + nb), a=S(a["RG"] + nb), b=S(sl), note="rGl (6c)"),
           I("SUB", nb2, d=S(a["RS"]), a=S(a["smu"], "scalar"), b=S(a["LS"]), note="rS (6d)"),
           I("DIV", nb2, d=S(a["WT"]), a=S(lu), b=S(su), note="(wu, wl)"),
           I("MUL", nb2, d=S(a["TT"]), a=S(lu), b=S(a["RG"])),
           I("SUB", nb2, d=S(a["TT"]), a=S(a["RS"]), b=S(a["TT"])),
           I("DIV", nb2, d=S(a["TT"]), a=S(a["TT"]), b=S(su), note="(tu, tl)"),
           I("ADD", nb, d=S(a["w"]), a=S(a["WT"]), b=S(a["WT"] + nb), note="W_k"),
           I("MOV", npr, d=S(a["diag"]), a=C(c["Hd"])),
           I("ADD", nb, d=S(a["diag"], "gather", T_BPRIM), a=C(c["Hd"], "gather", T_BPRIM), b=S(a["w"]),
             note="variable column H_ii + w_i"),
           I("MOV", N, d=S(a["bt"]), a=C(c["zero"], "scalar")),
           I("SUB", n, d=S(a["bt"] + L.lam(0)), a=C(c["zero"], "scalar"), b=S(a["xin"]), note="f: -x0"),
           I("SUB", nb, d=S(a["t2"]), a=S(ll), b=S(lu)),
           I("SUB", nb, d=S(a["t1"]), a=S(a["TT"]), b=S(a["TT"] + nb)),
           I("SUB", nb, d=S(a["t2"]), a=S(a["t2"]), b=S(a["t1"])),
           I("MUL", nb, d=S(a["t1"]), a=S(a["w"]), b=S(a["th"])),
           I("ADD", nb, d=S(a["bt"], "gather", T_BROW), a=S(a["t2"]), b=S(a["t1"]),
             note="bt = A_k z + b_k on the boxed rows")]
    if precondition:
        lin += [I("MAX", npr, d=S(a["t3"]), a=C(c["offp"]), b=S(a["diag"])),
                I("SQRT", npr, d=S(a["t3"]), a=S(a["t3"])),
                I("DIV", npr, d=S(a["d"], "gather", T_PRIM), a=C(c["one"], "scalar"), b=S(a["t3"]),
                  note="equilibration 1/sqrt(max|A_ij|)"),
                I("MOV", len(eq), d=S(a["d"], "gather", T_EQ), a=C(c["deq"]))]
    else:
        lin += [I("MOV", N, d=S(a["d"]), a=C(c["one"], "scalar"))]
    lin += [I("MUL", N, d=S(a["bt"]), a=S(a["d"]), b=S(a["bt"]), note="bh = d bt"),
            I("OUT", npr, a=S(a["diag"])), I("OUT", N, a=S(a["d"])), I("OUT", N, a=S(a["bt"])),
            I("OUT", N, a=S(a["z"]))]

    upd = [I("IN", N, d=S(a["x"])),
           I("MUL", N, d=S(a["dz"]), a=S(a["d"]), b=S(a["x"]), note="dz = d x"),
           I("MOV", nb, d=S(a["dth"]), a=S(a["dz"], "gather", T_BROW)),
           I("MUL", nb, d=S(DV), a=S(a["WT"]), b=S(a["dth"])),
           I("ADD", nb, d=S(DV), a=S(DV), b=S(a["TT"]), note="dlu"),
           I("MUL", nb, d=S(a["t2"]), a=S(a["WT"] + nb), b=S(a["dth"])),
           I("SUB", nb, d=S(DV + nb), a=S(a["TT"] + nb), b=S(a["t2"]), note="dll"),
           I("SUB", nb, d=S(DV + 2 * nb), a=S(a["RG"]), b=S(a["dth"]), note="dsu"),
           I("ADD", nb, d=S(DV + 3 * nb), a=S(a["RG"] + nb), b=S(a["dth"]), note="dsl"),
           I("DIV", nb4, d=S(a["t1"]), a=S(V), b=S(DV)),
           I("SELNEG", nb4, d=S(a["t1"]), a=S(a["t1"]), b=S(DV)),
           I("MINRED", nb4, d=S(a["amin"]), a=S(a["t1"])),
           I("MIN", 1, d=S(a["amax"]), a=C(c["one"]), b=S(a["amin"])),
           I("MUL", 1, d=S(a["alpha"]), a=C(c["tau"]), b=S(a["amax"]), note="line search (line 6)"),
           I("MUL", N, d=S(a["t4"]), a=S(a["alpha"], "scalar"), b=S(a["dz"])),
           I("ADD", N, d=S(a["z"]), a=S(a["z"]), b=S(a["t4"])),
           I("MUL", nb4, d=S(a["t1"]), a=S(a["alpha"], "scalar"), b=S(DV)),
           I("ADD", nb4, d=S(V), a=S(V), b=S(a["t1"]), note="line 7")]

    out = [I("MAX", m, d=S(a["u"]), a=S(a["z"], "gather", T_U0), b=S(a["lo"])),
           I("MIN", m, d=S(a["u"]), a=S(a["u"]), b=S(a["hi"])),
           I("ADD", m, d=S(a["u"]), a=S(a["u"]), b=S(a["ss"] + n), note="u0 = clamp(du0) + u_s"),
           I("OUT", m, a=S(a["u"])), I("OUT", 1, a=S(a["mu"]))]

    return Stage1(a, c, cw, tables, sa.size, {"sample": sample, "cold": cold, "warm": warm, "linearise": lin, "update": upd,
                                              "output": out})
