"""Silence for solver libraries that print from C whatever their settings (OSQP 1.x prints "Polishing not needed"
on standard output with verbose=False)."""
from __future__ import annotations

import contextlib
import os
import sys


@contextlib.contextmanager
def c_output_silenced():
    """Send what C code writes to file descriptor 1 to /dev/null for the block (Python's own prints included)."""
    try:
        sys.stdout.flush()
        saved = os.dup(1)
    except (OSError, ValueError):   # no real standard output (e.g. captured by a framework): nothing to silence
        yield
        return
    null = os.open(os.devnull, os.O_WRONLY)
    os.dup2(null, 1)
    try:
        yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)
        os.close(null)
