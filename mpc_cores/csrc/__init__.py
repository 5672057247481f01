"""Portable C99 solvers of the fixed-point cores (`make c`): the shared part of the emitters.

A kind with C support names its writer in `CoreKind.c_fn` ("module:function(design, out_dir) -> [paths]"); the
writer (mpc_cores/<kind>/c.py) builds the solve function of its algorithm and uses, from here:

  emit     names, data arrays, the integer helpers (rounding, saturation, the core's adder tree) with the golden
           models' semantics, the int64 headroom check, writing the files
  api      the header (sizes, control, warm-start state, status, the one solve function), the frame of the solve
           function, the golden-model self test under -DMPC_C_SELFTEST
  harness  gcc and a ctypes shim over the generated API (tests/test_c.py and mpc_bench.c_timing)

The fixed-point solver `<module>_solver.{h,c}` is bit-exact against the kind's golden model; the float variant
`<module>_solver_float.{h,c}` runs the same algorithm in double (or float) on the unquantised data. docs/c.md.
"""
