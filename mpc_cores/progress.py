"""Progress of long work on the terminal (tqdm on standard error; off when that is not a terminal)."""
from __future__ import annotations

import contextlib
import sys

from tqdm import tqdm


def bar(iterable=None, total: int | None = None, desc: str = "", unit: str = "it"):
    """A progress bar over `iterable` (or a manual one of `total` steps)."""
    return tqdm(iterable, total=total, desc=desc, unit=unit, file=sys.stderr, disable=None, leave=False,
                dynamic_ncols=True)


@contextlib.contextmanager
def stages(names: list[str], desc: str):
    """A bar over named stages: `with stages([...], "demo") as step: step("generate"); ...`; each call marks the
    previous stage done and names the current one."""
    b = bar(total=len(names), desc=desc, unit="stage")
    started = []

    def step(name: str) -> None:
        if started:
            b.update(1)
        started.append(name)
        b.set_postfix_str(name)

    try:
        yield step
    finally:
        if started:
            b.update(1)
        b.close()
