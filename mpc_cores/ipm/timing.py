"""Cycle model of the interior-point core (placeholder until calibrated against Verilator)."""
from __future__ import annotations


def timing(c: dict) -> dict:
    st1 = c["stage1_cycles"]
    per_problem_st1 = st1["linearise"] + st1["update"]
    P, N, imr, inw = c["P"], c["N"], c["iterations"], c["i_nw"]
    minres_per_problem = (imr + 1) * c["slot_cycles"]
    hidden = per_problem_st1 <= minres_per_problem
    return {"stage1_hidden": hidden,
            "stage1_note": "" if hidden else f"linearise + update = {per_problem_st1} cycles per problem > "
                                             f"(I_MR + 1) S = {minres_per_problem}",
            "latency_formula": f"2 I_NW (P N + P) I_MR = {2 * inw * (P * N + P) * imr} cycles (eq. (18) of 001)"}
