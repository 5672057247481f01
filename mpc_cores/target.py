"""The FPGA family a fixed-point core's multipliers are built for: `solver: target:` in the spec, `TARGET=` for make
(mirrors dsp.Target in src/main/scala/dsp/Target.scala).

- generic: portable RTL; the synthesis tool maps each product (bare MULT18X18D / DSP48E1 between fabric registers).
- ecp5: every product on MULT18X18D primitives with their input, pipeline and output registers on; wider products
  are split into 18 x 18 partial products summed in a registered fourth stage.
- xilinx7: registers around 25 x 18 partial products that Yosys synth_xilinx packs into the DSP48E1's AREG/BREG,
  MREG and PREG.

A target changes the RTL's structure only: the words and the cycle counts are those of the design's l_M, which must
cover the target's DSP pipeline (`min_lat_mul`). Without an explicit lat_mul the design takes that minimum.
"""
from __future__ import annotations

from mpc_cores.errors import DesignError

TARGETS = ("generic", "ecp5", "xilinx7")
# signed input widths (A, B) of one hard multiplier
DSP_PORTS = {"generic": (18, 18), "ecp5": (18, 18), "xilinx7": (25, 18)}
DEFAULT_LAT_MUL = 1    # generic, as the latencies of 002


def limb_count(w: int, dsp_w: int) -> int:
    return 1 if w <= dsp_w else (w - 2) // (dsp_w - 1) + 1


def parts(target: str, a_w: int, b_w: int) -> int:
    """DSPs of an a_w x b_w signed product (the wider operand on the A port if it fits there)."""
    pa, pb = DSP_PORTS[target]
    x, y = (b_w, a_w) if b_w > a_w and b_w <= pa else (a_w, b_w)
    return limb_count(x, pa) * limb_count(y, pb)


def min_lat_mul(target: str, products: list[tuple[int, int]]) -> int:
    """The fewest multiplier stages the target's DSP pipeline needs over the core's products: generic 0; ecp5 and
    xilinx7 3 (the DSP's registers), 4 where a product has partial products to sum."""
    if target == "generic":
        return 0
    return max(4 if parts(target, a, b) > 1 else 3 for a, b in products)


def check_target(target: str) -> str:
    if target not in TARGETS:
        raise DesignError(f"target must be one of {', '.join(TARGETS)}: got {target!r}")
    return target


def resolve_lat_mul(target: str, explicit: int | None, products: list[tuple[int, int]]) -> int:
    """l_M of a design: the explicit value if it covers the target's DSP pipeline (else a refusal naming both),
    or the target's minimum (generic: DEFAULT_LAT_MUL)."""
    need = min_lat_mul(target, products)
    if explicit is None:
        return max(DEFAULT_LAT_MUL, need)
    if explicit < need:
        worst = max(products, key=lambda p: parts(target, *p))
        raise DesignError(f"target {target} needs lat_mul >= {need} (the DSP's registers"
                          f"{', and a stage summing partial products' if need > 3 else ''}; widest product "
                          f"{worst[0]} x {worst[1]} bits): got lat_mul={explicit} (set lat_mul: {need} in the "
                          f"spec's solver section, LAT_MUL={need}, or leave it out)")
    return explicit


def report_line(target: str, lat_mul: int, products: list[tuple[int, int]], counts: list[int]) -> str:
    """The design report's line on the target: the DSPs the products take (`counts`: how many of each product the
    core has) and the multiplier stages against the target's minimum."""
    if target == "generic":
        return "  Target: generic (the synthesis tool maps the products)"
    dsps = sum(c * parts(target, a, b) for (a, b), c in zip(products, counts))
    cell = {"ecp5": "MULT18X18D", "xilinx7": "DSP48E1"}[target]
    need = min_lat_mul(target, products)
    extra = ""
    if target == "ecp5" and lat_mul > need:
        # the order in which FixedOps.mulStages spends stages beyond the DSP pipeline's
        uses = (["a register after the product's saturation"]
                + (["fabric registers landing the DSP outputs before their sum"] if need > 3 else [])
                + ["operands registered in fabric before the DSP"])
        more = lat_mul - need
        extra = f" (+{more}: {'; '.join(uses[:more])}{'; more registers after the saturation' if more > len(uses) else ''})"
    return (f"  Target: {target}, {dsps} {cell} (products "
            f"{', '.join(f'{a} x {b} bits: {parts(target, a, b)} each' for a, b in products)}); "
            f"l_M = {lat_mul}, the DSP pipeline needs {need}{extra}")


def dsp_count(target: str, products: list[tuple[int, int]], counts: list[int]) -> int:
    """DSPs of a core with counts[i] products of widths products[i]"""
    return sum(c * parts(target, a, b) for (a, b), c in zip(products, counts))


def single_dsp_advice(target: str, b: int, redesign, counts: list[int], floor: int = 8) -> str | None:
    """When some product of the design at b fraction bits takes several DSPs of the target: the largest b' < b at
    which every product is one DSP (`redesign(b')` gives that design's products; the bounds of the design flow
    size the words), as a line of the design report; None when every product already is one, or none is down to
    `floor`."""
    if target == "generic":
        return None
    now = redesign(b)
    if all(parts(target, *p) == 1 for p in now):
        return None
    for bb in range(b - 1, floor - 1, -1):
        try:
            prods = redesign(bb)
        except DesignError:
            return None
        if all(parts(target, *p) == 1 for p in prods):
            return (f"  Fit: b = {bb} keeps every product on one DSP ({dsp_count(target, prods, counts)} instead of "
                    f"{dsp_count(target, now, counts)}; B={bb}, or frac_bits: {bb} in the spec)")
    return None


#: the ECP5's DP16KD aspect ratios (words, bits): 18 kbit with parity, 16 kbit in the narrow ones
DP16KD_SHAPES = ((16384, 1), (8192, 2), (4096, 4), (2048, 9), (1024, 18), (512, 36))
#: mem.Ecp5BlockRam: a memory of at most this many words, built from primitives, 1024 x 18 per slice of a lane
PRIMITIVE_DEPTH = 1024


def dp16kd(memories: list[tuple]) -> int:
    """DP16KD blocks of memories (words, lanes, bits per lane, built from primitives): a primitive-built memory of
    at most 1024 words takes ceil(bits / 18) blocks per lane (mem.Ecp5BlockRam); any other, the best aspect ratio
    of its whole width (what synthesis may infer; an estimate: it may put a small one in LUTs, never in fewer)"""
    out = 0
    for d, lanes, w, primitive in memories:
        if primitive and d <= PRIMITIVE_DEPTH:
            out += lanes * -(-w // 18)
        else:
            out += min(-(-d // sd) * -(-(lanes * w) // sw) for sd, sw in DP16KD_SHAPES)
    return out
