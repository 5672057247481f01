"""The C header of a generated core: constants, register offsets, status and control bits, word conversion; the
core adds the addresses of its data memories."""
from __future__ import annotations

STATUS_BITS = ("BUSY", "SAT", "OVERFLOW", "WRITE_REJECTED", "TLAST_ERROR", "WARM_VALID")
CTRL_BITS = ("WARM_START", "HOLD", "OUT_ALL")


def c_header(core: dict, title: str, memories: list[str]) -> str:
    """`memories`: the lines describing the data memories (macros with the prefix of the module name)."""
    m = core["module"]
    pfx = m.upper()
    L = [f"/* {m}: register map and constants of a generated {title} ({core['name']}). */",
         f"#ifndef {pfx}_H", f"#define {pfx}_H", "", "#include <stdint.h>", ""]
    a = L.append
    for k in ("n", "nu", "nw", "P", "frac_bits", "stream_width", "iterations", "cycles_per_iteration",
              "solve_overhead_cycles", "cycles_per_solve"):
        a(f"#define {pfx}_{k.upper():<24} {core[k]}u")
    a(f"/* cycles per solve = {core['cycles_per_solve_formula']} (last input word to first output word) */")
    a("")
    a("/* Register byte offsets (32-bit words on AXI4-Lite). */")
    for r in core["registers"]:
        a(f"#define {pfx}_{r['name']:<24} 0x{r['offset']:04x}u /* {r['access']}: {r['desc']} */")
    a("")
    a("/* STATUS bits */")
    for i, nm in enumerate(STATUS_BITS):
        a(f"#define {pfx}_STATUS_{nm:<16} (1u << {i})")
    a("/* CTRL bits */")
    for i, nm in enumerate(CTRL_BITS):
        a(f"#define {pfx}_CTRL_{nm:<18} (1u << {i})")
    a("")
    a("/* Data memories (write-only, only while STATUS.BUSY is 0: otherwise SLVERR and WRITE_REJECTED). */")
    for nm, r in core["regions"].items():
        a(f"#define {pfx}_{nm}_BASE{'':<10} 0x{r['offset']:04x}u")
    L += memories
    a("")
    a("/* Stream words: signed, frac_bits fraction bits, sign-extended to stream_width. */")
    a(f"#define {pfx}_TO_FIXED(x) ((int32_t)((x) * (double)(1u << {pfx}_FRAC_BITS) + ((x) >= 0 ? 0.5 : -0.5)))")
    a(f"#define {pfx}_TO_REAL(q)  ((double)(q) / (double)(1u << {pfx}_FRAC_BITS))")
    a("")
    a(f"#endif /* {pfx}_H */")
    return "\n".join(L) + "\n"
