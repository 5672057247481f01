"""Generated solvers called from Python (tests/test_c.py, mpc_bench.c_timing): gcc builds the solver with a small shim
over its API into a shared library, ctypes calls it. The shim is the only part that is not C99 alone: it times the
solve with POSIX clock_gettime. Not needed to use the generated C."""
from __future__ import annotations

import ctypes
import shutil
import subprocess
from pathlib import Path

import numpy as np

from mpc_cores.csrc.emit import Names

STRICT = ("-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-pedantic")


def gcc() -> str | None:
    return shutil.which("gcc")


def compile_c(sources, out: Path, *flags: str, cwd=None) -> Path:
    """gcc STRICT + flags on the sources into `out`; a failure raises RuntimeError with gcc's messages."""
    cmd = [gcc() or "gcc", *STRICT, *flags, *map(str, sources), "-o", str(out)]
    p = subprocess.run(cmd, capture_output=True, text=True, cwd=cwd)
    if p.returncode:
        raise RuntimeError(f"{' '.join(cmd)}\n{p.stderr}")
    return Path(out)


def _shim(file: str, p: str, P: str, float_: bool, split: bool = False, exit_: bool = False) -> str:
    io, v = ("double", f"{p}_real_t") if float_ else ("int64_t", f"{p}_word_t")
    call = (f"linstep ? {p}_solve_split(({p}_state_t *)state, imax < 0 ? NULL : &c, wv, ov, &st, linstep, NULL)\n"
            f"                : {p}_solve(({p}_state_t *)state, imax < 0 ? NULL : &c, wv, ov, &st)" if split else
            f"{p}_solve(({p}_state_t *)state, imax < 0 ? NULL : &c, wv, ov, &st)")
    lin_t = f"{p}_linstep_fn" if split else "void *"
    flags = ("flags[1] = st.nonfinite;" if float_ else
             "flags[1] = st.sat;\n    flags[2] = st.overflow;\n    flags[3] = st.overflow_signals;")
    tol = f"\n    c.exit_tol = exit_tol < 0 ? {P}_EXIT_TOL : (uint32_t)exit_tol;" if exit_ else "\n    (void)exit_tol;"
    met = "st.met" if exit_ else "0"
    return f"""\
#define _POSIX_C_SOURCE 199309L
#include <stddef.h>
#include <string.h>
#include <time.h>
#include "{file}.h"

size_t shim_state_size(void)
{{
    return sizeof({p}_state_t);
}}

/* one solve (imax < 0: ctrl NULL, the reset values); flags: warm, then sat, overflow, overflow_signals (fixed) or
   nonfinite (float), then [4] the iterations run and [5] the exit test's MET; *ns: the solve's nanoseconds by
   CLOCK_MONOTONIC; linstep (a solver with the split): the linear-system step's function, NULL for the solve in C
   alone; exit_tol (a solver with the exit test): EXIT_TOL, < 0 its reset value */
int shim_solve(void *state, int imax, int warm, int out_all, const {io} *w, {io} *out, int *flags, long long *ns,
               {lin_t} linstep, int exit_tol)
{{
    {p}_ctrl_t c;
    {p}_status_t st;
    {v} wv[{P}_NW], ov[{P}_N];
    struct timespec t0, t1;
    int i, k;
    memset(&st, 0, sizeof st);
    c.imax = (uint16_t)imax;
    c.warm_start = (uint8_t)warm;
    c.out_all = (uint8_t)out_all;{tol}
    for (i = 0; i < {P}_NW; i++)
        wv[i] = ({v})w[i];
    clock_gettime(CLOCK_MONOTONIC, &t0);
    k = (int)({call});
    clock_gettime(CLOCK_MONOTONIC, &t1);
    (void)linstep;
    for (i = 0; i < k; i++)
        out[i] = ov[i];
    flags[0] = st.warm;
    {flags}
    flags[4] = st.iterations;
    flags[5] = {met};
    *ns = (long long)(t1.tv_sec - t0.tv_sec) * 1000000000LL + (t1.tv_nsec - t0.tv_nsec);
    return k;
}}
"""


class CSolver:
    """A generated solver (fixed point or float) in a shared library with the shim."""

    # the linear-system step of a split solve: (user, v, s) -> 1 a row saturated, 0 none, < 0 failure
    LINSTEP = ctypes.CFUNCTYPE(ctypes.c_int, ctypes.c_void_p, ctypes.POINTER(ctypes.c_int64),
                               ctypes.POINTER(ctypes.c_int64))

    def __init__(self, lib: Path, n: int, nw: int, float_: bool):
        self.lib = ctypes.CDLL(str(lib))
        self.n, self.nw, self.float_ = n, nw, float_
        self.dtype = np.float64 if float_ else np.int64
        ct = ctypes.c_double if float_ else ctypes.c_int64
        self.lib.shim_state_size.restype = ctypes.c_size_t
        self.lib.shim_solve.restype = ctypes.c_int
        self.lib.shim_solve.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_int, ctypes.c_int,
                                        ctypes.POINTER(ct), ctypes.POINTER(ct), ctypes.POINTER(ctypes.c_int),
                                        ctypes.POINTER(ctypes.c_longlong), ctypes.c_void_p, ctypes.c_int]
        self._ct = ct
        self._out = np.zeros(n, dtype=self.dtype)
        self._flags = (ctypes.c_int * 6)()
        self.iterations, self.met = 0, False        # the last solve's status: iterations run, exit test held
        self._ns = ctypes.c_longlong()
        self.linstep_error: Exception | None = None   # what the last failing linstep raised

    def new_state(self):
        """A zeroed state: the state after reset."""
        return ctypes.create_string_buffer(self.lib.shim_state_size())

    def solve(self, state, w, imax: int | None, warm: bool = True, out_all: bool = False, linstep=None,
              exit_tol: int | None = None):
        """(output words or reals, flags (warm, sat, overflow, overflow_signals) or (warm, nonfinite), nanoseconds);
        imax None: ctrl NULL (the reset values). linstep (a solver loaded with split=True): the linear-system step,
        a function of v (int64 words) returning (s words, saturated: bool), or None for a failure; the solve then
        calls `<p>_solve_split` (0 words back: linstep failed). exit_tol: EXIT_TOL of a solver with the exit test
        (None: its reset value). The status's iterations and MET are left in .iterations and .met."""
        cb = None
        if linstep is not None:
            n = self.n

            def step(_user, v, s):
                try:
                    r = linstep(np.ctypeslib.as_array(v, shape=(n,)).copy())
                except Exception as e:          # noqa: BLE001  (a Python error must not pass as an answer)
                    self.linstep_error = e
                    return -1
                if r is None:
                    return -1
                np.ctypeslib.as_array(s, shape=(n,))[:] = np.asarray(r[0], dtype=np.int64)
                return int(bool(r[1]))
            cb = self.LINSTEP(step)
        w = np.ascontiguousarray(w, dtype=self.dtype)
        assert w.shape == (self.nw,)
        k = self.lib.shim_solve(state, -1 if imax is None else int(imax), int(warm), int(out_all),
                                w.ctypes.data_as(ctypes.POINTER(self._ct)),
                                self._out.ctypes.data_as(ctypes.POINTER(self._ct)), self._flags,
                                ctypes.byref(self._ns), ctypes.cast(cb, ctypes.c_void_p) if cb else None,
                                -1 if exit_tol is None else int(exit_tol))
        flags = tuple(self._flags[: 2 if self.float_ else 4])
        self.iterations, self.met = int(self._flags[4]), bool(self._flags[5])
        return self._out[:k].copy(), flags, self._ns.value


def load(src_dir, nm: Names, cfg: dict, float_: bool = False, build_dir=None, split: bool = False) -> CSolver:
    """Build the solver `nm` generated into src_dir (the float variant with float_) with the shim into build_dir
    (default src_dir) and load it; split: the solver has `_solve_split` (the ADMM family), reachable through
    CSolver.solve(..., linstep=...)."""
    src = Path(src_dir).resolve()
    build = Path(build_dir or src).resolve()
    build.mkdir(parents=True, exist_ok=True)
    file = nm.stem + ("_float" if float_ else "")
    p, P = nm.p + ("_f" if float_ else ""), nm.P + ("_F" if float_ else "")
    shim = build / f"{file}_shim.c"
    shim.write_text(_shim(file, p, P, float_, split, exit_=bool(cfg.get("early_exit")) and not float_))
    lib = compile_c([src / f"{file}.c", shim], build / f"lib{file}.so", "-fPIC", "-shared", f"-I{src}")
    return CSolver(lib, int(cfg["n"]), int(cfg["nw"]), float_)
