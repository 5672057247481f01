"""The float formats of the float cores (minres, ipm) by name: binary32, binary16 or e<E>m<M>, within the 32-bit
stream word and the bit-exact model's range (the spec's `minres_format` and `ipm_format`, FORMAT=)."""
from __future__ import annotations

import re

from mpc_cores.errors import DesignError
from mpc_cores.float import vector as fv
from mpc_cores.float.model import Format

NAMES = {"binary32": Format(8, 23), "binary16": Format(5, 10)}
STREAM_BITS = 32


def parse_format(name) -> Format:
    """`binary32` (e8m23, the default), `binary16` (e5m10) or e<E>m<M>: E exponent and M stored mantissa bits with
    the float library's rules, within the 32-bit stream word and the golden model's range."""
    key = str(name).strip().lower()
    if key in NAMES:
        return NAMES[key]
    mt = re.fullmatch(r"e(\d+)m(\d+)", key)
    if not mt:
        raise DesignError(f"format must be binary32, binary16 or e<E>m<M> (e.g. e8m17): got '{name}'")
    try:
        f = Format(int(mt[1]), int(mt[2]))
    except ValueError as e:
        raise DesignError(f"format {name}: {e}") from None
    if f.width > STREAM_BITS:
        raise DesignError(f"format must fit the {STREAM_BITS}-bit stream word (1 + E + M <= {STREAM_BITS}): "
                          f"got {name}, {f.width} bits")
    try:
        fv.check(f)
    except ValueError as e:
        raise DesignError(f"format {name}: the bit-exact model {e}") from None
    return f


def format_name(f: Format) -> str:
    return next((k for k, v in NAMES.items() if v == f), f"e{f.expW}m{f.manW}")
