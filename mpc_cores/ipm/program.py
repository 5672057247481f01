"""The Stage 1 programs of the interior-point core for one MPC problem, in the instruction set of mpc_cores.ipm.isa.

Per problem slot (slot space), vectors of the boxed variables (nb of them) pair the upper and the lower
inequalities so that one instruction covers both: V = (lu, ll, su, sl), DV = (dlu, dll, dsu, dsl), q = (hi - th,
th - lo) = h - G th, RG = (rGu, rGl), WT = (wu, wl), TT = (tu, tl). Programs:
  sample     IN x^ (n), r (ny); the steady state ss = (x_s, u_s) = Mxu r; lo, hi shifted by ss; bh = d f on the rows
             of x0 (f = -x0 = x_s - x^), which no other program writes
  cold       the cold start: z = 0, (lambda, s) = start value, and the words that never change afterwards (below)
  warm       the warm start: the previous iterate unshifted (001), (lambda, s) raised to a floor
  linearise  (6c-d), (7), W_k, the variable column, bt, the preconditioner d and bh = d bt on the boxed rows; OUT
             the MINRES frame (variable column, d, bh, z)
  receive    IN the MINRES solution x (a program of its own: the core takes a whole batch's solutions from MINRES
             before it updates, so that MINRES can start its next batch)
  update     dz = d x; lines 4-7 of Algorithm 1 (direction, line search, step)
  output     u0 = clamp(z_u0, lo, hi) + u_s, mu of the last linearise; OUT
  output_all output, then OUT the whole iterate z (N words, the KKT order of mpc_cores.minres.kkt: lambda_k, x_k,
             u_k per stage, the primal words as deviations from the steady state) and ss = (x_s, u_s)
A sample runs: sample, cold (the first sample of a slot, or on request) or warm, then I_NW times (linearise, MINRES,
receive, update), then output.

Multiplexed (a channel's copy of parallel multiplexed MPC, Algorithm 2 of 001; the problem is the single-input
problem of one channel): sample takes IN x^ (n), the steady state ss = (x_s, u_s,i) (n + 1) and the known term F
(n T: the rows of the dynamics at stages 1..T, F_k = -B_{-i} du_{-i,k} from the stored plan) instead of r; cold
and warm end by writing bh = d F on those rows (after cold's zeros); output adds the T planned moves du_i,k
(deviations from u_s,i, unclamped) after u0 and mu.

Persistent words. Only the boxed rows of the frame change between Newton iterations: the variable column of the
free primal rows (H_ii), d of every row but the boxed ones (1/sqrt(max(off_i, H_ii)) and 1/sqrt(off_i) on the
equality rows, float64 constants; 1 without the preconditioner) and bh = 0 on the free primal rows and on the
equality rows but those of x0 are written by `cold` and never again (warm, linearise and update write only the
boxed rows, sample only the rows of x0), so linearise and update work on nb words plus the stream and the step
of z.

Arithmetic (one rounded operation per step; "exact" means: equal to Algorithm 1 in exact arithmetic):
  smu = acc(lu su, ll sl) * (sigma / n_ineq)                       mu = acc(..) * (1 / n_ineq) in `output`
  TT  = (smu - l q) / s            = (rS - l rG) / s  exactly, since q = s + rG
  bt  = ((ll + tl) - (lu + tu)) + w th  on the boxed rows
  d   = 1 / sqrt(max(off, H_ii + w)) on the boxed rows; the MAX is left out when H_ii >= off_i on every boxed row
        (then max(off, H_ii + w) = H_ii + w since w >= 0)
  alpha = -tau / min(-1, min(dv / v)) = tau min(1, min over dv < 0 of -v / dv)
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mpc_cores.ipm.isa import Instr, Operand, cycles
from mpc_cores.ipm.sparse import SparseMpc

# index tables (at most six: the engine takes eight, and its test adds two random ones)
T_BROW, T_BPRIM, T_SHIFT, T_QA, T_QB, T_TD = range(6)


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
          warm_floor: float = 1e-2, multiplexed: bool = False, force_max: bool = False) -> Stage1:
    p = s.problem
    n, m, ny, N = p.nx, p.nu, p.ny, s.N
    L = s.L
    nb = len(s.bounded)
    npr = len(s.primal)
    if nb == 0:
        raise ValueError("the interior-point core needs at least one boxed variable")
    K0 = s.K0
    Hd = np.diag(K0)
    off = np.abs(K0 - np.diag(Hd)).max(axis=1)
    brow = np.asarray(s.primal[s.bounded])          # rows of the boxed variables
    x0 = L.lam(0)                                   # rows x0 .. x0 + n - 1: f = -x0
    # d of every row whose diagonal does not change (all but the boxed rows), in float64
    dfix = 1.0 / np.sqrt(np.where(np.isin(np.arange(N), s.primal), np.maximum(off, Hd), off))
    dinit = dfix.copy() if precondition else np.ones(N)
    dinit[brow] = 1.0                               # written by every linearise
    need_max = force_max or not bool(np.all(Hd[brow] >= off[brow]))

    # ---- constant region
    ca = Alloc()
    consts = {}

    def const(name, v):
        v = np.atleast_1d(np.asarray(v, dtype=float))
        consts[ca(name, len(v))] = v

    const("zero", 0.0)
    const("one", 1.0)
    const("mone", -1.0)
    const("ntau", -tau)
    const("inv_ineq", 1.0 / s.n_ineq)
    const("sig_inv", sigma / s.n_ineq)
    const("start", start_value)
    const("floor", warm_floor)
    const("Hd", Hd[s.primal])
    const("dinit", dinit)          # right after Hd: cold writes (diag, d) in one instruction
    const("offb", off[brow])
    const("dx0", dfix[x0: x0 + n])
    const("lo", s.lo)
    const("hi", s.hi)              # right after lo
    if multiplexed:                # d of the dynamics rows of stages 1..T, in the order of F
        const("dlam", np.concatenate([dinit[L.lam(k + 1): L.lam(k + 1) + n] for k in range(L.T)]))
    Mxu = np.vstack([s.Mx, s.Mu]) if ny else np.zeros((n + m, 0))
    for j in range(ny):
        const(f"Mxu{j}", Mxu[:, j])
    cw = np.zeros(ca.size)
    for a, v in consts.items():
        cw[a: a + len(v)] = v
    c = {k: a for k, (a, _) in ca.names.items()}

    # ---- slot region. z and V first (the model checks them there), then SM (b of the fused DIV is (su, sl, SM)),
    # lo, hi; the second block (dz, DV, w, t) has the first's layout, so that T_QA, read at the offset dz - z,
    # gives (wl dth, dth) = (t_l, dz on the boxed rows) as it gives (hi, th) at 0.
    sa = Alloc()
    for name, size in (("z", N), ("V", 4 * nb), ("SM", nb), ("lo", nb), ("hi", nb),
                       ("dz", N), ("DV", 4 * nb), ("w", nb), ("t", 2 * nb),
                       ("TN", 2 * nb), ("ones", nb), ("TT", 2 * nb), ("RG", 2 * nb), ("q", 2 * nb),
                       ("LS", 2 * nb), ("WT", 2 * nb), ("A", 2 * nb), ("B", nb), ("C", nb), ("bt", nb), ("mt", nb),
                       ("diag", npr), ("d", N), ("bh", N),
                       ("xin", n), ("r", max(ny, 1)), ("ss", n + m), ("ts", n + m), ("fx", n),
                       ("u", m), ("mu", 1), ("acc", 1), ("smu", 1), ("rmin", 1), ("rmin1", 1), ("alpha", 1),
                       *((("F", n * L.T),) if multiplexed else ())):
        sa(name, size)
    a = {k: v for k, (v, _) in sa.names.items()}
    nb2, nb4 = 2 * nb, 4 * nb
    V, DV = a["V"], a["DV"]
    D = a["dz"] - a["z"]
    assert a["z"] == 0 and V == N
    assert DV - V == D and a["t"] - a["lo"] == D and a["hi"] == a["lo"] + nb
    assert a["SM"] == V + nb4 and a["ones"] == a["TN"] + nb2 and a["RG"] == a["TT"] + nb2
    assert a["B"] == a["A"] + nb2 and a["C"] == a["B"] + nb        # A, B, C: the 4nb ratios of the line search
    assert a["d"] == a["diag"] + npr and a["bh"] == a["d"] + N
    assert a["r"] == a["xin"] + n and a["mu"] == a["u"] + m

    tables = [np.concatenate([brow, brow]),                           # T_BROW (twice: (dth, dth))
              np.asarray(s.bounded),                                  # T_BPRIM: boxed entries of the variable column
              np.concatenate([s.shift_of, s.shift_of]),               # T_SHIFT (twice: lo and hi)
              np.concatenate([a["hi"] + np.arange(nb), a["z"] + brow]),   # T_QA: (hi, th)
              np.concatenate([a["z"] + brow, a["lo"] + np.arange(nb)]),   # T_QB: (th, lo)
              np.concatenate([a["TT"] + np.arange(nb2), a["d"] + brow])]  # T_TD: (TT, d on the boxed rows)

    I = Instr
    th = S(a["z"], "gather", T_BROW)          # theta: z on the boxed rows
    dth = S(a["dz"], "gather", T_BROW)
    s_ = S(V + nb2)                           # (su, sl)

    if multiplexed:
        if ny:
            raise ValueError("a multiplexed channel's problem takes its steady state, not a reference")
        sample = [I("IN", n, d=S(a["xin"]), note="x^"), I("IN", n + m, d=S(a["ss"]), note="(x_s, u_s,i)"),
                  I("IN", n * L.T, d=S(a["F"]), note="F: the other channels' planned moves, -B_{-i} du_{-i,k}")]
    else:
        # x^ and r; the steady state (x_s, u_s) = sum_j Mxu_j r_j when tracking, else 0
        sample = [I("IN", n + ny, d=S(a["xin"]), note="x^, r")]
        if ny:
            sample += [I("MUL", n + m, d=S(a["ss"]), a=C(c["Mxu0"]), b=S(a["r"], "scalar"))]
            for j in range(1, ny):
                sample += [I("MUL", n + m, d=S(a["ts"]), a=C(c[f"Mxu{j}"]), b=S(a["r"] + j, "scalar")),
                           I("ADD", n + m, d=S(a["ss"]), a=S(a["ss"]), b=S(a["ts"]))]
        else:
            sample += [I("MOV", n + m, d=S(a["ss"]), a=C(c["zero"], "scalar"))]
    sample += [I("SUB", nb2, d=S(a["lo"]), a=C(c["lo"]), b=S(a["ss"], "gather", T_SHIFT), note="lo, hi shifted")]
    if precondition:
        sample += [I("SUB", n, d=S(a["fx"]), a=S(a["ss"]), b=S(a["xin"]), note="f = -x0 = x_s - x^"),
                   I("MUL", n, d=S(a["bh"] + x0), a=C(c["dx0"]), b=S(a["fx"]), note="bh = d f on the rows of x0")]
    else:
        sample += [I("SUB", n, d=S(a["bh"] + x0), a=S(a["ss"]), b=S(a["xin"]), note="bh = f = x_s - x^")]

    cold = [I("MOV", N, d=S(a["z"]), a=C(c["zero"], "scalar")),
            I("MOV", nb4, d=S(V), a=C(c["start"], "scalar")),
            I("MOV", npr + N, d=S(a["diag"]), a=C(c["Hd"]), note="persistent: H_ii, d of the unchanging rows")]
    for lo_, hi_ in ((0, x0), (x0 + n, N)):
        if hi_ > lo_:
            cold += [I("MOV", hi_ - lo_, d=S(a["bh"] + lo_), a=C(c["zero"], "scalar"), note="persistent: bh = 0")]
    if precondition:
        cold += [I("MOV", nb, d=S(a["ones"]), a=C(c["one"], "scalar"), note="persistent: numerators of d")]
    warm = [I("MAX", nb4, d=S(V), a=S(V), b=C(c["floor"], "scalar"), note="warm start: (lambda, s) >= floor")]
    if multiplexed:                # bh = d F on the dynamics rows of stages 1..T (cold's zeros come first)
        fk = [I("MUL", n, d=S(a["bh"] + L.lam(k + 1)), a=C(c["dlam"] + k * n), b=S(a["F"] + k * n),
                note="bh = d F" if k == 0 else "") if precondition else
              I("MOV", n, d=S(a["bh"] + L.lam(k + 1)), a=S(a["F"] + k * n), note="bh = F" if k == 0 else "")
              for k in range(L.T)]
        cold += fk
        warm += fk

    lin = [I("MUL", nb2, d=S(a["LS"]), a=S(V), b=s_, note="(lu su, ll sl)"),
           I("ACC", nb2, d=S(a["acc"]), a=S(a["LS"])),
           I("MUL", 1, d=S(a["smu"]), a=S(a["acc"]), b=C(c["sig_inv"]), note="sigma mu (7)"),
           I("SUB", nb2, d=S(a["q"]), a=S(0, "gather", T_QA), b=S(0, "gather", T_QB), note="q = (hi - th, th - lo)"),
           I("SUB", nb2, d=S(a["RG"]), a=S(a["q"]), b=s_, note="rG (6c)"),
           I("MUL", nb2, d=S(a["LS"]), a=S(V), b=S(a["q"])),
           I("SUB", nb2, d=S(a["TN"]), a=S(a["smu"], "scalar"), b=S(a["LS"]), note="rS - l rG (6d) = smu - l q"),
           I("DIV", nb2, d=S(a["WT"]), a=S(V), b=s_, note="(wu, wl)"),
           I("ADD", nb, d=S(a["w"]), a=S(a["WT"]), b=S(a["WT"] + nb), note="W_k"),
           I("ADD", nb, d=S(a["diag"], "gather", T_BPRIM), a=C(c["Hd"], "gather", T_BPRIM), b=S(a["w"]),
             note="variable column H_ii + w_i")]
    if precondition:
        dg = S(a["diag"], "gather", T_BPRIM)
        if need_max:
            lin += [I("MAX", nb, d=S(a["mt"]), a=C(c["offb"]), b=dg)]
            dg = S(a["mt"])
        lin += [I("SQRT", nb, d=S(a["SM"]), a=dg),
                I("DIV", nb2 + nb, d=S(0, "gather", T_TD), a=S(a["TN"]), b=s_,
                  note="(tu, tl) = TN / s and the equilibration d = 1 / sqrt(max(off, diag)), boxed rows")]
    else:
        lin += [I("DIV", nb2, d=S(a["TT"]), a=S(a["TN"]), b=s_, note="(tu, tl)")]
    lin += [I("ADD", nb2, d=S(a["A"]), a=S(V), b=S(a["TT"])),
            I("SUB", nb, d=S(a["B"]), a=S(a["A"] + nb), b=S(a["A"]), note="(ll + tl) - (lu + tu)"),
            I("MUL", nb, d=S(a["C"]), a=S(a["w"]), b=th),
            I("ADD", nb, d=S(a["bt"]) if precondition else S(a["bh"], "gather", T_BROW), a=S(a["B"]), b=S(a["C"]),
              note="bt = A_k z + b_k on the boxed rows")]
    if precondition:
        lin += [I("MUL", nb, d=S(a["bh"], "gather", T_BROW), a=S(a["d"], "gather", T_BROW), b=S(a["bt"]),
                  note="bh = d bt")]
    lin += [I("OUT", npr + 2 * N, a=S(a["diag"]), note="variable column, d, bh"), I("OUT", N, a=S(a["z"]))]

    receive = [I("IN", N, d=S(a["dz"]), note="x")]
    upd = []
    if precondition:
        upd += [I("MUL", N, d=S(a["dz"]), a=S(a["d"]), b=S(a["dz"]), note="dz = d x")]
    upd += [I("MUL", nb2, d=S(a["t"]), a=S(a["WT"]), b=dth, note="(wu dth, wl dth)"),
            I("ADD", nb, d=S(DV), a=S(a["t"]), b=S(a["TT"]), note="dlu = wu dth + tu"),
            I("SUB", nb2, d=S(DV + nb), a=S(a["TT"] + nb), b=S(D, "gather", T_QA),
              note="(dll, dsu) = (tl, rGu) - (wl dth, dth)"),
            I("ADD", nb, d=S(DV + 3 * nb), a=S(a["RG"] + nb), b=dth, note="dsl = rGl + dth"),
            I("DIV", nb4, d=S(a["A"]), a=S(DV), b=S(V), note="dv / v"),
            I("MINRED", nb4, d=S(a["rmin"]), a=S(a["A"])),
            I("MIN", 1, d=S(a["rmin1"]), a=S(a["rmin"]), b=C(c["mone"])),
            I("DIV", 1, d=S(a["alpha"]), a=C(c["ntau"]), b=S(a["rmin1"]),
              note="line search (line 6): alpha = tau min(1, min over dv < 0 of -v/dv)"),
            I("MUL", N + nb4, d=S(a["dz"]), a=S(a["alpha"], "scalar"), b=S(a["dz"])),
            I("ADD", N + nb4, d=S(a["z"]), a=S(a["z"]), b=S(a["dz"]), note="line 7: (z, V) += alpha (dz, DV)")]

    out = [I("MAX", m, d=S(a["u"]), a=S(a["z"] + L.u(0)), b=S(a["lo"])),
           I("MIN", m, d=S(a["u"]), a=S(a["u"]), b=S(a["hi"])),
           I("ADD", m, d=S(a["u"]), a=S(a["u"]), b=S(a["ss"] + n), note="u0 = clamp(du0) + u_s"),
           I("MUL", 1, d=S(a["mu"]), a=S(a["acc"]), b=C(c["inv_ineq"]), note="mu (7) of the last linearise"),
           I("OUT", m + 1, a=S(a["u"]), note="u0, mu")]
    if multiplexed:
        out += [I("OUT", 1, a=S(a["z"] + L.u(k)), note="the planned moves du_i,k" if k == 0 else "")
                for k in range(L.T)]
    out_all = out + [I("OUT", N, a=S(a["z"]), note="z, deviations from the steady state"),
                     I("OUT", n + m, a=S(a["ss"]), note="the steady state (x_s, u_s)")]

    return Stage1(a, c, cw, tables, sa.size, {"sample": sample, "cold": cold, "warm": warm, "linearise": lin,
                                              "receive": receive, "update": upd, "output": out,
                                              "output_all": out_all})
