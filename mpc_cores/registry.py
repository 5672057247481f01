"""The core kinds of the project, one line each: CORE=<name> selects one everywhere (command line, make targets,
tables, benchmark, tests). A new kind adds its subpackage with a `KIND` object and one line here."""
from __future__ import annotations

from mpc_cores.kind import CoreKind, load

_KINDS = (
    "mpc_cores.fgm.kind:KIND",
    "mpc_cores.admm.kind:KIND",
    "mpc_cores.admm.kind:AMA_KIND",
    "mpc_cores.admm.kind:VUCONDAT_KIND",
    "mpc_cores.minres.kind:KIND",
    "mpc_cores.ipm.kind:KIND",
    "mpc_cores.dgp.kind:KIND",
)


def kinds() -> dict[str, CoreKind]:
    """name -> CoreKind, in registry order."""
    out = {}
    for ref in _KINDS:
        k = load(ref)
        out[k.name] = k
    return out


def names() -> tuple[str, ...]:
    return tuple(kinds())


def get(name: str) -> CoreKind:
    """The kind called `name`; a KeyError names the kinds there are."""
    ks = kinds()
    if name not in ks:
        raise KeyError(f"CORE={name}: the core kinds are {', '.join(ks)}")
    return ks[name]
