"""The schema of the problem spec and of the command-line overrides, checked before any numerics.

One table for the spec's structure (`spec_schema()`: sections, their keys, the required ones), one for the
`solver:` section (`solver_rules()`: every key some core kind reads, with its type and range: the keys several
kinds share here, each kind's own in its CoreKind.spec_rules; each kind lists the keys it reads in its
`spec_section`), and the size limits. Shapes, symmetry and definiteness of the matrices are the parser's
(mpc_cores.problem); the design flows refuse what depends on the numbers (Assumptions 1 and 2 of 002, word
widths). Every violation is a SpecError naming the rule and the values; docs/spec.md lists the rules.

Size limits. The largest part the benchmark places and routes is the LFE5U-85F (156 MULT18X18D, 208 DP16KD
of 18 kbit, i.e. 1024 words of 18 bits each). The cores already exceed one such part (the ADMM core of
masses_rate_soft takes 864 MULT18X18D at P = 1, docs/benchmark.md), so the front end refuses only what would
not fit sixteen of them, before it builds anything:
  - the condensed QP's data, n (n + nw) words with n = N nu and nw = nx + ny (what the FGM core stores; the
    ADMM core stores the larger M11 of its sparse form): at most WORDS_MAX = 16 x 208 x 1024 words;
  - multipliers, P max(n, nw) for the row units P of the dense cores (the spec's `P`; Table I of 002: the
    FGM adds 2P, the ADMM has n_A >= n): at most MULTS_MAX = 16 x 156;
  - the order (N + 1)(2 nx + nu + ns) of the sparse form's KKT matrix (nx with u_prev under `input_rate`, ns
    soft states), which the MINRES, interior-point and ADMM flows build dense in float64: at most ORDER_MAX
    (a matrix of 512 MiB).
"""
from __future__ import annotations

import difflib
import functools
import math
import numbers
from dataclasses import dataclass

from mpc_cores.errors import SpecError
from mpc_cores.fixed import ROUNDING_MODES
from mpc_cores.float.latency import LATENCY_PRESETS
from mpc_cores.target import TARGETS

PART, PART_MULTS, PART_BLOCKS, BLOCK_WORDS = "LFE5U-85F", 156, 208, 1024
PARTS = 16
WORDS_MAX = PARTS * PART_BLOCKS * BLOCK_WORDS   # 3,407,872 words of 18 bits
MULTS_MAX = PARTS * PART_MULTS                  # 2,496
ORDER_MAX = 8192


# --------------------------------------------------------------------------
# rules: each checks one value and returns it (integral floats as int), or raises SpecError naming `fld`


@dataclass(frozen=True)
class Int:
    lo: int
    hi: int | None = None
    why: str = ""

    def check(self, v, fld: str):
        ok = not isinstance(v, bool) and (isinstance(v, numbers.Integral)
                                          or (isinstance(v, float) and v.is_integer()))
        if ok and self.lo <= int(v) and (self.hi is None or int(v) <= self.hi):
            return int(v)
        rng = f">= {self.lo}" if self.hi is None else f"in [{self.lo}, {self.hi}]"
        raise SpecError(f"{fld}: expected an integer {rng}{self.why}, got {v!r}")


@dataclass(frozen=True)
class Num:
    lo: float
    strict: bool = True     # v > lo (else v >= lo)
    why: str = ""

    def check(self, v, fld: str):
        ok = (not isinstance(v, bool) and isinstance(v, numbers.Real) and math.isfinite(v)
              and (v > self.lo if self.strict else v >= self.lo))
        if ok:
            return v
        what = "a positive number" if (self.lo, self.strict) == (0, True) else \
            f"a number {'>' if self.strict else '>='} {self.lo:g}"
        raise SpecError(f"{fld}: expected {what}{self.why}, got {v!r}")


@dataclass(frozen=True)
class Bool:
    def check(self, v, fld: str):
        if isinstance(v, bool):
            return v
        raise SpecError(f"{fld}: expected true or false, got {v!r}")


@dataclass(frozen=True)
class Choice:
    options: tuple

    def check(self, v, fld: str):
        if v in self.options:
            return v
        raise SpecError(f"{fld}: expected one of {', '.join(self.options)}, got {v!r}")


@dataclass(frozen=True)
class Text:
    def check(self, v, fld: str):
        if isinstance(v, str) and v:
            return v
        raise SpecError(f"{fld}: expected a non-empty string, got {v!r}")


@dataclass(frozen=True)
class FloatFormat:
    """binary32, binary16 or e<E>m<M> within the stream word: the rule of mpc_cores.float.format.parse_format."""

    def check(self, v, fld: str):
        from mpc_cores.errors import DesignError
        from mpc_cores.float.format import parse_format

        if not isinstance(v, str):
            raise SpecError(f"{fld}: expected a format name (binary32, binary16 or e<E>m<M>), got {v!r}")
        try:
            parse_format(v)
        except DesignError as e:
            raise SpecError(f"{fld}: {e}") from None
        return v


@dataclass(frozen=True)
class IntBits:
    """An integer (every signal) or a mapping signal -> integer; the FGM design names the signals."""

    def check(self, v, fld: str):
        rule = Int(0, 32)
        if isinstance(v, dict):
            return {k: rule.check(b, f"{fld}.{k}") for k, b in v.items()}
        return rule.check(v, fld)


@dataclass(frozen=True)
class Lanes:
    """Multipliers per row unit: an integer >= 1, or "fit" (the fewest chunks per row that fit the part's DSPs)."""

    def check(self, v, fld: str):
        if v == "fit":
            return v
        if isinstance(v, bool) or not isinstance(v, (int, float)) or v != int(v) or not 1 <= v <= 1024:
            raise SpecError(f"{fld}: expected an integer in [1, 1024] (multipliers of the row unit) or 'fit', "
                            f"got {v!r}")
        return int(v)


@dataclass(frozen=True)
class StreamWidth:
    def check(self, v, fld: str):
        v = Int(8, 64).check(v, fld)
        if v % 8:
            raise SpecError(f"{fld}: expected a multiple of 8 in [8, 64], got {v}")
        return v


@dataclass(frozen=True)
class Section:
    """A mapping with the given keys (rule, nested Section, or None: the value is the parser's to check); `check`
    returns a copy with the values the rules normalise (integral floats as int)."""
    keys: dict
    required: frozenset = frozenset()

    def check(self, d, fld: str):
        if not isinstance(d, dict):
            raise SpecError(f"{fld}: expected a mapping, got {type(d).__name__}")
        for k in d:
            if k not in self.keys:
                raise SpecError(unknown_key(fld, k, self.keys))
        missing = sorted(self.required - set(d))
        if missing:
            raise SpecError(f"{fld}: missing key(s) {missing}")
        out = dict(d)
        for k, v in d.items():
            rule = self.keys[k]
            if rule is None or (v is None and isinstance(rule, Section) and k not in self.required):
                continue  # the parser's to check, or an optional section left empty
            out[k] = rule.check(v, k if fld == "spec" else f"{fld}.{k}")
        return out


def unknown_key(fld: str, key, valid) -> str:
    """The refusal of an unknown key, naming the nearest valid one (case ignored) or else all of them."""
    by_lower = {str(k).lower(): k for k in valid}
    near = difflib.get_close_matches(str(key).lower(), list(by_lower), n=1, cutoff=0.6)
    if near:
        return f"{fld}: unknown key {str(key)!r}, did you mean {by_lower[near[0]]!r}?"
    return f"{fld}: unknown key {str(key)!r} (valid keys: {', '.join(map(str, valid))})"


# --------------------------------------------------------------------------
# the spec


_ITER = " (a 16-bit register)"
# the `solver:` keys that more than one kind reads; a kind's own keys are its CoreKind.spec_rules
SHARED_SOLVER = {
    "frac_bits": Int(1, 30, " (the word of 1.0 takes frac_bits + 2 bits, within the 32-bit AXI4-Lite word)"),
    "iterations": Int(1, 65535, _ITER),
    "P": Int(1, None, " (row units)"),
    "lat_add": Int(0, 64, " (pipeline registers)"),
    "lat_mul": Int(0, 64, " (pipeline registers)"),
    "rounding": Choice(ROUNDING_MODES),
    "warm_start": Bool(),
    "output_all": Bool(),
    "target": Choice(TARGETS),
    "problems": Int(1, 16, " (problems interleaved on the row units)"),
    "int_bits": IntBits(),
    "tol": Num(0),
    "accelerated": Bool(),
    "lanes": Lanes(),
}

# the design check (mpc_cores.check): its closed-loop scenario, sample count, target and budget; GAP= and CYCLES=
# override the last two
CHECK = {"x0": None, "steps": Int(1, 100000), "hold": Int(1, 100000), "seed": Int(0), "samples": Int(0, 100000),
         "gap": Num(0, why=" (percent above the optimal closed-loop cost)"),
         "violation": Num(0, strict=False, why=" (fraction of the constraint's range)"),
         "cycles": Int(1, None, " (cycles per solve)")}

_BOX = Section({"min": None, "max": None}, frozenset({"min", "max"}))


@functools.cache
def solver_rules() -> dict:
    """Every key of `solver:` some kind reads, with its rule: the shared ones and each registry kind's own
    (CoreKind.spec_rules). A key two kinds define must be one rule; a kind's own key may not shadow a shared one."""
    from mpc_cores import registry

    out = dict(SHARED_SOLVER)
    owner: dict[str, str] = {}
    for kind in registry.kinds().values():
        for key, rule in kind.spec_rules.items():
            if key in SHARED_SOLVER:
                raise ValueError(f"CORE={kind.name}: spec key {key!r} is a shared one (schema.SHARED_SOLVER)")
            if key in out and out[key] is not rule:
                raise ValueError(f"CORE={kind.name}: spec key {key!r} has another rule in CORE={owner[key]}")
            out[key], owner[key] = rule, owner.get(key, kind.name)
    return out


@functools.cache
def spec_schema() -> Section:
    """The spec's structure, with the `solver:` keys of solver_rules()."""
    return Section({
        "name": Text(),
        "description": None,
        "model": Section({"A": None, "B": None, "Ac": None, "Bc": None, "Ts": Num(0, why=" (seconds)")}),
        "cost": Section({"Q": None, "R": None, "QN": None}, frozenset({"Q", "R"})),
        "horizon": Int(1),
        "inputs": _BOX,
        "states": _BOX,
        "tracking": Section({"C": None, "outputs": None, "min": None, "max": None}, frozenset({"min", "max"})),
        "solver": Section(solver_rules()),
        "input_rate": Section({"min": None, "max": None, "weight": None}, frozenset({"min", "max"})),
        # sigma2 > 0: Remark 1 of 002, the quadratic slack penalty the fixed-point analysis relies on
        "soft_states": Section({"indices": None, "min": None, "max": None, "sigma1": Num(0),
                                "sigma2": Num(0, why=" (Remark 1 of 002)")},
                               frozenset({"indices", "min", "max", "sigma1", "sigma2"})),
        "hard_states": Section(dict.fromkeys(("indices", "min", "max")), frozenset({"indices", "min", "max"})),
        "check": Section(CHECK),
    }, frozenset({"model", "cost", "horizon", "inputs", "states"}))


def check_spec(d) -> dict:
    """The spec's structure, the types and ranges of its scalars and of the `solver:` keys."""
    return spec_schema().check(d, "spec")


def check_size(N: int, nx: int, nu: int, ny: int = 0, ns: int = 0, rate: bool = False,
               P: int | None = None) -> None:
    """Refuse a problem beyond the size limits (module docstring); P: the dense cores' row units, if known."""
    n, nw = N * nu, nx + ny
    words = n * (n + nw)
    if words > WORDS_MAX:
        raise SpecError(f"problem size: the condensed QP's data n (n + nw) must be at most {WORDS_MAX} words "
                        f"({PARTS} x the {PART}'s {PART_BLOCKS} DP16KD of {BLOCK_WORDS} x 18 bits): "
                        f"got n = N nu = {N} x {nu} = {n}, nw = {nw}, {words:.3g} words")
    if P is not None and P * max(n, nw) > MULTS_MAX:
        raise SpecError(f"multipliers: P max(n, nw) must be at most {MULTS_MAX} ({PARTS} x the {PART}'s "
                        f"{PART_MULTS} MULT18X18D): got P = {P}, n = {n}, nw = {nw}, {P * max(n, nw)} multipliers")
    nxa = nx + nu if rate else nx
    order = (N + 1) * (2 * nxa + nu + ns)
    if order > ORDER_MAX:
        raise SpecError(f"problem size: the sparse KKT matrix, of order (N + 1)(2 nx + nu + ns), must be at most "
                        f"{ORDER_MAX} (float64, 512 MiB): got N = {N}, nx = {nxa}, nu = {nu}, ns = {ns}, "
                        f"order {order}")


# --------------------------------------------------------------------------
# command-line overrides


def override_rule(kind, name: str):
    """The rule of override `name` for a core kind: that of the kind's own spec key `<kind>_<name>` when it
    reads one (minres_P, ipm_format, ...), else that of the shared key."""
    own = f"{kind.name}_{name}"
    rules = solver_rules()
    if own in kind.spec_section and own in rules:
        return rules[own]
    return rules[name] if name in rules else CHECK[name]


def _from_text(s):
    if not isinstance(s, str):
        return s
    if s.lower() in ("true", "false"):
        return s.lower() == "true"
    for conv in (int, float):
        try:
            return conv(s)
        except ValueError:
            pass
    return s


def check_override(kind, name: str, value):
    """A command-line value (text) checked by its rule and converted; the message names the option."""
    return override_rule(kind, name).check(_from_text(value), "--" + name.replace("_", "-"))
