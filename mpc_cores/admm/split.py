"""The heterogeneous split of 004 (section 5) for the ADMM family (admm, ama, vucondat): the linear-system step
s = M11 v in hardware, the rest of the method on a CPU.

- `linstep_config(d)`: the matrix-vector block (src/main/scala/linalg/MatVecCore.scala) for design d: M = M11 and the
  core's own word formats (operand v, coefficient, sum) and adder tree, so that its s is the core's tree sum word for
  word; `generate_linstep` elaborates it (`<module>_linstep.sv` and `linstep.json`).
- `LinStep`: its bit-exact model (the golden model's dot product, per row flags).
- The generated C (`make c`, mpc_cores/admm/c.py) has `<p>_solve_split(..., linstep, user)`, which calls the block
  once per iteration; with equal words from it the solve equals `<p>_solve`, the golden model and so the core.
docs/c.md, section "Heterogeneous split"."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from mpc_cores.fixed import saturate, shift_round, tree_sum, wmax, wmin

MAIN = "linalg.MatVecMain"
# tuser bits of the block's answer words
OVF_ROW, SAT_IN, TLAST_ERR = 1, 2, 4


def linstep_config(d, P: int | None = None) -> dict:
    """The block's config.json for ADMM-family design d (its config(), or the dict itself); P row units (default
    the core's)."""
    cfg = d if isinstance(d, dict) else d.config()
    w = cfg["widths"]
    module = (cfg["module"] if "module" in cfg else d.module_name) + "_linstep"
    n = int(cfg["n"])
    return {"core": "matvec", "module": module, "n": n, "P": int(P or cfg["P"]), "frac_bits": int(cfg["frac_bits"]),
            "lat_mul": int(cfg["lat_mul"]), "lat_add": int(cfg["lat_add"]), "rounding": cfg["rounding"],
            "target": cfg.get("target", "generic"), "coef_width": int(w["coef"]), "op_width": int(w["v"]),
            "sum_width": int(w["sum"]), "M": np.asarray(cfg["M11"], dtype=np.int64).reshape(n, n).tolist()}


def _current(out: Path) -> bool:
    try:
        hw = json.loads((out / "hw.json").read_text())
    except (OSError, ValueError):
        return False
    return (out / f"{hw['module']}.sv").exists()


def generate_linstep(d, out_dir, P: int | None = None) -> dict:
    """Elaborate the block of design d into out_dir (cached like the cores); returns linstep.json: hw.json (sizes,
    stream widths, the cycle contract) with `sv` and the word formats."""
    from mpc_cores import flow

    cfg = linstep_config(d, P)
    out = Path(out_dir)
    text = json.dumps(cfg, sort_keys=True)

    def write_config(path):
        Path(path).write_text(text)

    with flow.locked(flow.GENERATE_LOCK):
        flow.run_stale(MAIN, [(text, out, write_config)], _current)
    hw = json.loads((out / "hw.json").read_text())
    meta = {**hw, "sv": f"{hw['module']}.sv", "frac_bits": cfg["frac_bits"], "rounding": cfg["rounding"],
            "target": cfg["target"], "lat_mul": cfg["lat_mul"], "lat_add": cfg["lat_add"],
            "coef_width": cfg["coef_width"],
            "tuser": {"0": "the row's product or partial sum saturated", "1": "a word of v saturated",
                      "2": "a tlast of v misplaced"}}
    (out / "linstep.json").write_text(json.dumps(meta, indent=2))
    return meta


class LinStep:
    """Bit-exact model of the block: s = M v with the core's rounded products and pairwise saturating tree."""

    def __init__(self, cfg: dict):
        self.n = int(cfg["n"])
        self.M = np.asarray(cfg["M"], dtype=np.int64).reshape(self.n, self.n)
        self.b, self.rounding = int(cfg["frac_bits"]), cfg["rounding"]
        self.opW, self.sumW = int(cfg["op_width"]), int(cfg["sum_width"])

    def __call__(self, v) -> tuple[np.ndarray, np.ndarray, bool]:
        """(s, per-row saturation flags, a word of v saturated) for the words v."""
        v_in = np.asarray(v, dtype=np.int64)
        assert v_in.shape == (self.n,)
        vs = np.clip(v_in, wmin(self.opW), wmax(self.opW))
        s = np.empty(self.n, dtype=np.int64)
        ovf = np.zeros(self.n, dtype=bool)
        for i in range(self.n):
            p, f1 = saturate(shift_round(self.M[i] * vs, self.b, self.rounding), self.sumW)
            s[i], f2 = tree_sum(p, self.sumW)
            ovf[i] = f1 or f2
        return s, ovf, bool(np.any(vs != v_in))


def write_split(d, out_dir) -> tuple[list[Path], str]:
    """`make split` (CoreKind.split_fn): the block and the C solvers of design d into out_dir, and a short report."""
    from mpc_cores.admm.c import write_c
    from mpc_cores.admm.report import form
    from mpc_cores.csrc.emit import names

    out = Path(out_dir)
    meta = generate_linstep(d, out)
    files = [out / meta["sv"], out / "linstep.json"] + write_c(d, out)
    p = names(d.module_name).p
    report = "\n".join([
        f"heterogeneous split of {d.module_name} ({d.method}; {form(d)}): s = M11 v in hardware, the rest in C",
        f"  block {meta['module']}: n = {meta['n']}, P = {meta['P']} row units, {meta['multipliers']} multipliers, "
        f"v words {meta['op_width']} bits in {meta['in_stream_width']}-bit beats, s words {meta['sum_width']} bits "
        f"in {meta['out_stream_width']}-bit beats (tuser: row saturated, v saturated, tlast misplaced)",
        f"  cycles: {meta['latency_cycles']} from v's last beat to s's first (then one word a cycle), a frame every "
        f"{meta['period_cycles']} back to back; one call per iteration, {d.iterations} per solve at the reset IMAX",
        f"  C: {p}_solve_split(state, ctrl, w, out, status, linstep, user) calls linstep(user, v, s) for the block; "
        f"{p}_solve is the same in C alone (docs/c.md)"])
    return files, report
