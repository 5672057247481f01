"""core.json and the design report of a generated MINRES core."""
from __future__ import annotations

from mpc_cores.minres.kkt import dense_cds_words, paper_bound_words
from mpc_cores.minres.schedule import schedule


def core_json(d, hw: dict) -> dict:
    c = {"core": "minres", "name": d.name, "module": hw["module"], "sv": f"{hw['module']}.sv",
         "n": d.n, "m": d.m, "T": d.T, "iterations": d.iterations,
         "flush_cycles": d.flush_cycles, "stream_width": 32, "format": d.format, "exp_width": d.fmt.expW,
         "man_width": d.fmt.manW, "word_width": d.fmt.width, **d.lat, "latency_preset": d.latency,
         "target": d.target}
    assert (hw["format"], hw["exp_width"], hw["man_width"]) == (c["format"], c["exp_width"], c["man_width"]), \
        f"the generator built {hw['format']}, the design asks for {c['format']}"
    for k in ("N", "M", "K", "P", "P_eq15", "k1", "k2", "slot_cycles", "cycles_per_iteration", "cycles_bound",
              "batch_cycles_formula", "batch_cycles_imax0", "schedule", "storage_words", "storage_variable",
              "storage_constant", "storage_dense_cds", "storage_bound_001", "frame_words", "multipliers",
              "out_words", "warm", "storage_warm",
              "axil_addr_width", "registers", "regions"):
        c[k] = hw[k]
    planned = schedule(c["N"], c["M"], c["K"], d.lat, d.P, d.warm)
    got = {k: c[k] for k in planned}
    assert planned == got, f"the MINRES schedule of mpc_cores.minres.schedule {planned} differs from the generator's {got}"
    assert c["storage_dense_cds"] == dense_cds_words(d.n, d.m, d.T, c["P"])
    assert c["storage_bound_001"] == paper_bound_words(d.n, d.m, d.T, c["P"])
    c["eq15"] = (f"P = ceil((2N + M + k1 ceil(log2(K)) + k2) / N), K = {c['K']} products per row, k1 = {c['k1']}, "
                 f"k2 = {c['k2']} (001: 3N, 2M - 1 products, k1 = 24, k2 = 154)")
    return c


def design_report(d, core: dict | None = None) -> str:
    L = d.layout
    lines = [f"MINRES core for {d.name}: n = {d.n}, m = {d.m}, T = {d.T}: N = {L.N}, M = {L.M} (eq. (14) of 001), "
             f"format {d.format} ({d.fmt.width}-bit words, low bits of the 32-bit stream words)"]
    if core:
        lines += [f"P = {core['P']} (eq. (15) form of this core: {core['P_eq15']}; {core['eq15']})",
                  f"cycles per MINRES iteration: {core['cycles_per_iteration']} (P N + P = {core['cycles_bound']})",
                  f"storage words: {core['storage_words']} structured (variable {core['storage_variable']}, "
                  f"constant {core['storage_constant']}), dense-band CDS {core['storage_dense_cds']}, "
                  f"bound of 001 {core['storage_bound_001']}"]
    return "\n".join(lines)
