"""core.json and the design report of a generated interior-point core."""
from __future__ import annotations

from mpc_cores.ipm.design import stage1_cycles
from mpc_cores.ipm.timing import simulate, timing


def core_json(d, hw: dict) -> dict:
    mr, st1 = hw["minres"], hw["stage1"]
    p = d.problem
    c = {"core": "ipm", "name": d.name, "module": hw["module"], "sv": f"{hw['module']}.sv",
         "n": p.nx, "m": p.nu, "ny": p.ny, "T": p.N, "N": hw["N"], "M": mr["M"], "P": hw["P"],
         "P_eq15": mr["P_eq15"], "problems_in_flight": hw["problems_in_flight"], "format": hw["format"],
         "exp_width": hw["exp_width"], "man_width": hw["man_width"], "word_width": mr["word_width"],
         "stream_width": 32, "i_nw": d.i_nw, "iterations": d.i_mr, "mu_tol": d.mu_tol, "res_tol": d.res_tol,
         "in_words": hw["in_words"], "out_words": hw["out_words"], **d.md.lat, "lat_cmp": d.lat_cmp,
         "latency_preset": d.md.latency, "target": d.md.target,
         "axil_addr_width": hw["axil_addr_width"], "registers": hw["registers"], "regions": hw["regions"]}
    assert hw["format"] == d.format, f"the generator built {hw['format']}, the design asks for {d.format}"
    progs = {q["name"]: q["cycles"] for q in st1["programs"]}
    assert progs == stage1_cycles(d), "the generator's Stage 1 cycles differ from mpc_cores.ipm.isa.cycles"
    c["stage1_cycles"] = progs
    c["stage1_module"] = st1["module"]
    c["minres_module"] = mr["module"]
    c["slot_cycles"] = mr["slot_cycles"]
    c["cycles_per_iteration"] = mr["cycles_per_iteration"]
    c["minres_batch_cycles_formula"] = mr["batch_cycles_formula"]
    c["minres_batch_cycles_imax0"] = mr["batch_cycles_imax0"]
    c["multipliers_minres"] = mr["multipliers"]
    c["storage_words"] = {"minres": mr["storage_words"] + mr["storage_warm"],
                          "stage1_slots": st1["slot_words"] * st1["slots"], "stage1_const": st1["const_words"]}
    c.update(timing(c))
    c["reference_clocks_mhz"] = [150]  # 001's Virtex-6 clock
    c["multiplexed"] = bool(hw.get("multiplexed", False))
    if c["multiplexed"]:
        # the core's problems are single-input: m = 1 per channel, no reference; a round of Algorithm 2 is the m
        # copies on channels 0 .. m - 1 (input c mod m), in one MINRES batch when P >= m
        chans = list(range(p.nu))
        rnd = simulate(c, chans, warm=set(chans))
        c.update({"m": 1, "ny": 0, "inputs": p.nu, "channels_used": p.nu, "plan_words": hw["plan_words"],
                  "latency_cycles_per_sample": max(v["latency"] for v in rnd.values()),
                  "latency_per_sample_note": "one round of the m copies on channels 0 .. m - 1, warm (a sample "
                                             "whose reference changed runs rounds of them, the first sample more: "
                                             "mpc_cores.ipm.mux_loop)"})
    return c


def design_report(d, core: dict | None = None) -> str:
    p = d.problem
    lines = [f"Interior-point core for {d.name}: n = {p.nx}, m = {p.nu}, T = {p.N}: N = {d.md.layout.N}, "
             f"format {d.format} ({d.md.latency} latencies: add {d.md.lat['lat_add']}, mul {d.md.lat['lat_mul']}, "
             f"div {d.md.lat['lat_div']}, sqrt {d.md.lat['lat_sqrt']}), I_NW = {d.i_nw}, I_MR = {d.i_mr}, "
             "sigma = 0.1, tau = 0.99, equilibration on"]
    if core:
        lines += [f"P = {core['P']} (eq. (15): {core['P_eq15']}): {core['problems_in_flight']} problems in flight",
                  f"Stage 1 cycles per problem: " + ", ".join(f"{k} {v}" for k, v in core["stage1_cycles"].items()),
                  f"MINRES: {core['cycles_per_iteration']} cycles per iteration of P problems, batch "
                  f"{core['minres_batch_cycles_formula']}",
                  f"cycles per Newton iteration (2P in flight): {core['cycles_per_newton_iteration']}",
                  f"latency: {core['latency_formula']}",
                  f"Stage 1 hidden behind MINRES: {'yes' if core['stage1_hidden'] else 'no: ' + core['stage1_note']}"]
    return "\n".join(lines)


def facts(d) -> dict:
    """What the design check and the gallery print of a design (mpc_cores.check): the latency of one problem
    (channel 0, warm) from the cycle model (mpc_cores.ipm.timing.simulate); the float operators' multipliers are
    counted by the bench's synthesis, not here."""
    from mpc_cores.ipm.design import planned_core
    from mpc_cores.ipm.timing import simulate

    c = planned_core(d, d.i_mr)
    return {"iterations": d.i_mr, "iterations_text": f"I_NW = {d.i_nw}, I_MR = {d.i_mr}",
            "cycles": simulate(c, [0], warm={0})[0]["latency"], "multipliers": None, "dsp_ecp5": None, "bram_ecp5": None,
            "words": d.format}
