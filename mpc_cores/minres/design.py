"""Design of a MINRES core from an MPC problem: sizes, float format, latencies, P (or eq. (15)), the constant ROM
as raw words of the format, written to the config.json the Chisel generator (minres.MinresMain) reads."""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mpc_cores.errors import DesignError  # the error the command line reports
from mpc_cores.float import vector as fv
from mpc_cores.float.latency import LAT, format_latencies, min_lat_mul
from mpc_cores.float.format import NAMES, STREAM_BITS, format_name, parse_format  # noqa: F401  (this module's API)
from mpc_cores.float.model import Format
from mpc_cores.minres.band import BandPattern, band_patterns
from mpc_cores.minres.kkt import Layout, const_rom, kkt_matrix, problem_matrices
from mpc_cores.target import check_target


@dataclass
class MinresDesign:
    name: str
    n: int
    m: int
    T: int
    P: int                 # 0: from eq. (15) (the generator computes it)
    iterations: int
    lat: dict = field(default_factory=lambda: dict(LAT))
    flush_cycles: int = 32
    rom: np.ndarray = None  # (2n+m) x (M-1) values of the format (float32 in binary32)
    h_diag: np.ndarray = None  # diagonal of the Hessian on the primal rows (the variable part without W)
    problem: object = None
    fmt: Format = NAMES["binary32"]
    warm: bool = False     # the interior-point core's form (MinresParams.warm)
    latency: str = "compact"  # the operator latency preset (mpc_cores.float.latency)
    target: str = "generic"   # FPGA family (mpc_cores.target): ecp5 builds the memories from DP16KD with OUTREG
    tables: list = None    # several matrices of one layout (the multiplexed interior-point core), each a ROM as
                           # `rom` (which is tables[0]): a problem takes the table its id chooses
                           # (MinresCoreModel.table_of)

    @property
    def layout(self) -> Layout:
        return Layout(self.n, self.m, self.T)

    @property
    def format(self) -> str:
        return format_name(self.fmt)

    def config(self) -> dict:
        rom = fv.encode(self.fmt, np.asarray(self.rom, dtype=np.float64)).astype(np.int64)
        return {"core": "minres", "name": self.name, "n": self.n, "m": self.m, "T": self.T, "P": self.P,
                "iterations": self.iterations, "flush_cycles": self.flush_cycles, **self.lat,
                "format": self.format, "exp_width": self.fmt.expW, "man_width": self.fmt.manW,
                "h_diag": [float(v) for v in self.h_diag], "rom": rom.tolist(), "warm": self.warm,
                "target": self.target,
                **self.pattern.config(self._encode), **self._tables_config()}

    def _encode(self, v):
        return fv.encode(self.fmt, np.asarray(v, dtype=np.float64)).astype(np.int64)

    def _tables_config(self) -> dict:
        """band_tables (matrices x keys x K raw words) and roms, with more than one matrix"""
        if not self.tables or len(self.tables) == 1:
            return {}
        return {"band_tables": [pat.config(self._encode)["band_coefs"] for pat in self.patterns],
                "roms": [self._encode(r).tolist() for r in self.tables]}

    @property
    def patterns(self) -> list[BandPattern]:
        """The pattern per matrix (one slot and offset assignment for all of them)."""
        roms = self.tables or [self.rom]
        return band_patterns(self.n, self.m, self.T, [np.asarray(r, dtype=np.float64) for r in roms])

    @property
    def pattern(self) -> BandPattern:
        """The sparse rows of the band the core multiplies by (mpc_cores.minres.band)."""
        return self.patterns[0]

    def write_config(self, path) -> None:
        Path(path).write_text(json.dumps(self.config()))


def design_minres(problem, P: int | None = None, iterations: int | None = None, lat_add: int | None = None,
                  lat_mul: int | None = None, name: str | None = None, format: str | None = None,
                  warm: bool = False, latency: str | None = None, target: str | None = None,
                  channels=None, **_ignored) -> MinresDesign:
    """`channels`: problems of the same sizes whose KKT matrices the core holds (MinresDesign.tables; a problem's id
    chooses one, MinresCoreModel.table_of); `problem` gives the rest of the design."""
    A, B, Q, R, QN, T = problem_matrices(problem)
    n, m = problem.nx, problem.nu
    solver = problem.solver or {}
    P = int(P if P is not None else solver.get("minres_P", 0) or 0)
    if P < 0 or P > 64:
        raise DesignError(f"P must be in [1, 64] (0 or none: eq. (15)): got P={P}")
    fmt = parse_format(format if format not in (None, "") else solver.get("minres_format", "binary32"))
    preset = latency or solver.get("minres_latency", "compact")
    tgt = check_target(str(target or solver.get("target", "generic")))
    lat = format_latencies(fmt, preset, tgt)
    if lat_add is not None:
        lat["lat_add"] = int(lat_add)
    if lat_mul is not None:
        lat["lat_mul"] = int(lat_mul)
    if lat["lat_mul"] < min_lat_mul(fmt, tgt):
        raise DesignError(f"target {tgt} in {format_name(fmt)} needs lat_mul >= {min_lat_mul(fmt, tgt)} (the MULT18X18D's "
                          f"input, pipeline and output registers and the output's): got lat_mul={lat['lat_mul']}")
    if lat["lat_add"] < 1:
        raise DesignError(f"lat_add must be >= 1 (the streaming accumulator): got {lat['lat_add']}")
    it = int(iterations or solver.get("minres_iterations", 0) or Layout(n, m, T).N)
    # the constant columns rounded to the format (float32 values in binary32)
    def rounded(rom):
        return rom.astype(np.float32) if fmt == NAMES["binary32"] else fv.decode(fmt, fv.encode(fmt, rom))
    rom = rounded(const_rom(A, B, Q, R, QN, T))
    tables = None
    if channels:
        mats = [problem_matrices(c) for c in channels]
        sizes = sorted({(c.nx, c.nu, mt[5]) for c, mt in zip(channels, mats)})
        if sizes != [(n, m, T)]:
            raise DesignError(f"channels must share the problem's sizes (n, m, T) = {(n, m, T)}: got {sizes}")
        tables = [rounded(const_rom(*mt)) for mt in mats]
        rom = tables[0]
    h = np.diagonal(kkt_matrix(A, B, Q, R, QN, T))[Layout(n, m, T).primal_rows()]
    return MinresDesign(name or problem.name, n, m, T, P, min(it, 65535), lat, rom=rom, h_diag=h, problem=problem,
                        fmt=fmt, warm=warm, latency=preset, target=tgt, tables=tables)
