"""The float operators' latencies a core uses, by preset: what the float library's operators (src/main/scala/float)
are built with, and what the cores' cycle contracts count."""
from __future__ import annotations

from mpc_cores.errors import DesignError

# the float library's default latencies in binary32 (divide and square root follow the format)
LAT = {"lat_add": 4, "lat_mul": 3, "lat_div": 16, "lat_sqrt": 16}

# operator latency presets (spec key minres_latency / ipm_latency, override `latency`)
LATENCY_PRESETS = ("compact", "fast")


# target ecp5: a significand of at most 18 bits is multiplied on a MULT18X18D with its input, pipeline and output
# registers (float.FMul), which takes one cycle more than the same placement of the other registers, and at least 4
def mul_on_dsp(f, target: str) -> bool:
    return target == "ecp5" and f.manW + 1 <= 18


def min_lat_mul(f, target: str) -> int:
    return 4 if mul_on_dsp(f, target) else 0


def format_latencies(f, preset: str = "compact", target: str = "generic") -> dict:
    """The float operators' latencies in format f (M stored significand bits).
    compact: the float library's defaults, the fewest cycles: add 4, mul 3, divide ceil((M + 9) / 2), square root
      ceil((M + 8) / 2) (FDiv / FSqrt.defaultLatency: about two quotient or root bits per cycle).
    fast: the lowest latencies measured to pass 150 MHz on the LFE5U-85F (docs/float.md): add 7, mul 7 when the
      significand fits one MULT18X18D (M <= 17) else 9, divide and square root fully pipelined (one digit step a
      cycle: M + 14 and M + 13, their step counts in e8m17 and binary32).
    Target ecp5 with the product on a MULT18X18D (mul_on_dsp): lat_mul one more (4 and 8 in e8m17), the other
    registers where the generic multiplier has them."""
    dsp = 1 if mul_on_dsp(f, target) else 0
    if preset == "compact":
        return dict(LAT, lat_mul=LAT["lat_mul"] + dsp, lat_div=(f.manW + 10) // 2, lat_sqrt=(f.manW + 9) // 2)
    if preset == "fast":
        return {"lat_add": 7, "lat_mul": (7 if f.manW <= 17 else 9) + dsp, "lat_div": f.manW + 14,
                "lat_sqrt": f.manW + 13}
    raise DesignError(f"latency must be one of {', '.join(LATENCY_PRESETS)}: got {preset!r}")
