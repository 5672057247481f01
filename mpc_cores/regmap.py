"""Byte addresses of a core's AXI4-Lite registers and data memories, from its core.json (the same arithmetic as
the macros of the generated C header)."""
from __future__ import annotations


class Regmap:
    STATUS_BITS = {"BUSY": 0, "SAT": 1, "OVERFLOW": 2, "WRITE_REJECTED": 3, "TLAST_ERROR": 4, "WARM_VALID": 5}
    CTRL_BITS = {"WARM_START": 0, "HOLD": 1, "OUT_ALL": 2}

    def __init__(self, core: dict):
        self.core = core
        self.reg = {r["name"]: r["offset"] for r in core["registers"]}
        self.base = {k: v["offset"] for k, v in core["regions"].items()}
        self.P = core["P"]
        self.pb = core.get("p_bits", 0)
        self.cb = core["col_bits"]

    def __getitem__(self, name: str) -> int:
        return self.reg[name]

    def slot(self, i: int) -> int:
        return ((i // self.P) << self.pb) | (i % self.P)

    def mat_a(self, i: int, j: int) -> int:
        """(I - H_n)[i][j]"""
        return self.base["MAT_A"] + (((self.slot(i) << self.cb) | j) << 2)

    def mat_f(self, i: int, j: int) -> int:
        """Phi_n[i][j]"""
        return self.base["MAT_F"] + (((self.slot(i) << self.cb) | j) << 2)

    def ubox(self, i: int, hi: bool) -> int:
        return self.base["UBOX"] + (((self.slot(i) << 1) | int(hi)) << 2)

    def xbox(self, j: int, hi: bool) -> int:
        return self.base["XBOX"] + (((j << 1) | int(hi)) << 2)

    # ---- ADMM: rows addressed by component index
    def _row(self, region: str, i: int, j: int) -> int:
        return self.base[region] + (((i << self.cb) | j) << 2)

    def mat_m(self, i: int, j: int) -> int:
        """M11[i][j]"""
        return self._row("MAT_M", i, j)

    def mat_g(self, i: int, j: int) -> int:
        """G~[i][j], j over (x, u_prev, r, 1)"""
        return self._row("MAT_G", i, j)

    def bnd(self, i: int, hi: bool) -> int:
        """(lo, hi) of a box component, (centre, radius) at a soft pair's slack"""
        return self.base["BND"] + (((i << 1) | int(hi)) << 2)

    def wbox(self, j: int, hi: bool) -> int:
        return self.base["WBOX"] + (((j << 1) | int(hi)) << 2)

    def status(self, word: int) -> dict:
        return {k: bool(word >> b & 1) for k, b in self.STATUS_BITS.items()}


def export(out, core: dict) -> dict:
    """Register-map outputs of a generated core in `out`; returns the core.json entries naming them."""
    from pathlib import Path

    from mpc_cores import registry
    from mpc_cores.kind import load

    kind = registry.get(core["core"])
    (Path(out) / core["header"]).write_text(load(kind.report_module).c_header(core))
    return {}
