"""Configuration and generation of the Stage 1 engine (src/main/scala/ipm/): config.json from the programs of
mpc_cores.ipm.program (a Stage1), the float format and the operator latencies; the generator run
(`ipm.Stage1Main <config.json> <outDir>`, skipped when the configuration and the generator sources are unchanged);
and the way back from config.json to the interpreter (decode, machine) for the testbench.

config.json: core "ipm_stage1", name, exp_w, man_w, slots, slot_words, const (raw words of the format), tables, programs
[{name, code: instruction words as hex strings (mpc_cores.ipm.isa.encode)}], lat_add, lat_mul, lat_div, lat_sqrt,
lat_cmp. The generator writes <module>.sv and hw.json (module, latencies, per program its entry, length and cycles).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from mpc_cores.float.model import Format
from mpc_cores.ipm import isa
from mpc_cores.ipm.isa import Instr, Operand
from mpc_cores.minres.model import ops_for

MAIN = "ipm.Stage1Main"
# binary32 defaults of the float library (docs/float.md)
DEFAULT_LAT = {"add": 4, "mul": 3, "div": 16, "sqrt": 16, "cmp": 1}


def fmt_of(exp_w: int = 8, man_w: int = 23) -> Format:
    return Format(int(exp_w), int(man_w))


def const_words(values, exp_w: int = 8, man_w: int = 23) -> list[int]:
    """Raw words of the constant region in the format e<exp_w>m<man_w>. binary32: float32 arrays keep their bits,
    others are rounded to float32; other formats: the values rounded to the format (to nearest even, as
    mpc_cores.float.vector.encode; NaN the canonical quiet NaN)."""
    v = np.asarray(values)
    if (exp_w, man_w) != (8, 23):
        return [int(w) for w in ops_for(fmt_of(exp_w, man_w)).value(np.atleast_1d(v).astype(np.float64))]
    if v.dtype != np.float32:
        v = v.astype(np.float32)
    return [int(u) for u in np.atleast_1d(v).view(np.uint32)]


def debug_programs(slot_words: int) -> dict:
    """`load`: IN the whole slot region; `dump`: OUT it (the testbench writes and reads a slot through them)."""
    return {"load": [Instr("IN", slot_words, d=Operand("slot", 0))],
            "dump": [Instr("OUT", slot_words, a=Operand("slot", 0))]}


def check(programs: dict, tables, lat: dict) -> None:
    """Refuse what the engine cannot run as the interpreter does: a stream hazard inside an instruction, an ACC
    of lat_add terms or fewer (the generator checks addresses and tables)."""
    for name, prog in programs.items():
        for k, i in enumerate(prog):
            h = isa.stream_hazards(i, tables)
            if h:
                raise ValueError(f"program {name}, instruction {k} ({i.op}): element {h[0][1]} reads a word that "
                                 f"element {h[0][0]} writes")
            if i.op == "ACC" and i.n <= lat["add"]:
                raise ValueError(f"program {name}, instruction {k}: ACC needs more than lat_add={lat['add']} terms")


def config(st1, name: str, slots: int = 1, lat: dict | None = None, exp_w: int = 8, man_w: int = 23,
           debug: bool = False, target: str = "generic", banks=None) -> dict:
    """config.json of an engine running the programs of `st1` (mpc_cores.ipm.program.Stage1, or anything with
    programs, const_words, tables and slot_words) on `slots` problem slots; `debug` adds the load and dump
    programs; `target` the FPGA family (mpc_cores.target: ecp5 builds the slot memory from DP16KD primitives with
    their output register). `banks`: Stage1s of the same programs and layouts whose constant regions become the
    engine's banks (the multiplexed core's channels; slot s reads bank s mod len(banks))."""
    lat = dict(DEFAULT_LAT, **(lat or {}))
    programs = dict(st1.programs)
    if debug:
        programs.update(debug_programs(st1.slot_words))
    tables = [[int(t) for t in tab] for tab in st1.tables]
    check(programs, tables, lat)
    const = const_words(st1.const_words, exp_w, man_w)
    extra = {}
    if banks and len(banks) > 1:
        for b in banks:
            same_tables = len(b.tables) == len(st1.tables) and all(
                np.array_equal(x, y) for x, y in zip(b.tables, st1.tables))
            if b.programs != st1.programs or b.const != st1.const or b.slot != st1.slot or not same_tables:
                raise ValueError("the constant banks need one layout, one set of programs and tables")
        const = [w for b in banks for w in const_words(b.const_words, exp_w, man_w)]
        extra = {"const_banks": len(banks)}
    return {
        "core": "ipm_stage1", "name": name, "exp_w": exp_w, "man_w": man_w, "slots": slots,
        "slot_words": int(st1.slot_words), "const": const, "tables": tables, **extra,
        "programs": [{"name": k, "code": [hex(isa.encode(i)) for i in v]} for k, v in programs.items()],
        "lat_add": lat["add"], "lat_mul": lat["mul"], "lat_div": lat["div"], "lat_sqrt": lat["sqrt"],
        "lat_cmp": lat["cmp"], "target": target,
    }


def _current(out: Path) -> bool:
    try:
        hw = json.loads((out / "hw.json").read_text())
    except (OSError, ValueError):
        return False
    return "module" in hw and (out / f"{hw['module']}.sv").exists()


def generate(jobs: list) -> list[dict]:
    """Elaborate engines in one generator run: jobs are (config dict, out_dir). Writes config.json into out_dir
    and runs the generator for the jobs whose outputs are not current (same configuration and generator
    sources: mpc_cores.flow.run_stale); returns their hw.json dicts."""
    from mpc_cores.flow import GENERATE_LOCK, locked, run_stale

    with locked(GENERATE_LOCK):
        run_stale(MAIN, [(json.dumps(cfg, sort_keys=True), Path(out),
                          lambda path, t=json.dumps(cfg, sort_keys=True): path.write_text(t)) for cfg, out in jobs],
                  _current)
        return [json.loads((Path(out) / "hw.json").read_text()) for _, out in jobs]


# ---- from config.json back to the interpreter
def _operand(w: int) -> Operand:
    mask = (1 << isa.ADDR_W) - 1
    return Operand(space=isa.SPACES[w & 1], mode=isa.MODES[(w >> 1) & 3], addr=(w >> 3) & mask,
                   table=(w >> (3 + isa.ADDR_W)) & 7)


def decode(word: int) -> Instr:
    """The instruction of an encoded word (inverse of mpc_cores.ipm.isa.encode, without the note)."""
    w = int(word)
    ow = 1 + 2 + isa.ADDR_W + isa.TABLE_W
    ops = [_operand((w >> (isa.OP_W + isa.N_W + k * ow)) & ((1 << ow) - 1)) for k in range(3)]
    return Instr(isa.OPS[w & 15], (w >> isa.OP_W) & ((1 << isa.N_W) - 1), *ops)


def programs(cfg: dict) -> dict:
    """name -> list of Instr, decoded from config.json."""
    return {p["name"]: [decode(int(c, 16)) for c in p["code"]] for p in cfg["programs"]}


def machine(cfg: dict):
    """The interpreter of the configured engine in its float format (exp_w, man_w): slots, slot region, the
    constant words (bit for bit), tables, lat_add."""
    from mpc_cores.ipm.machine import Machine

    fmt = fmt_of(cfg["exp_w"], cfg["man_w"])
    m = Machine(cfg["slots"], cfg["slot_words"], np.zeros(0), [np.asarray(t, dtype=np.int64) for t in cfg["tables"]],
                cfg["lat_add"], fmt, const_banks=cfg.get("const_banks", 1))
    m.set_const_words(cfg["const"])
    return m
