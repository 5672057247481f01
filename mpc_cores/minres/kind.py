"""The MINRES core kind (registry entry): the banded linear solver of the interior-point method (001)."""
from mpc_cores.float.latency import LATENCY_PRESETS
from mpc_cores.kind import CoreKind
from mpc_cores.schema import Choice, FloatFormat, Int

KIND = CoreKind(
    name="minres",
    title="MINRES banded KKT solver of the interior-point method (001), binary32 or e<E>m<M>, P problems "
          "interleaved",
    model_fn="mpc_cores.minres.model:MinresCoreModel.from_config",
    spec_section=("minres_P", "minres_iterations", "minres_format", "minres_latency"),
    overrides=("P", "iterations", "lat_add", "lat_mul", "format", "latency", "target"),
    cycle_test="cycles_per_iteration",
    spec_rules={
        "minres_P": Int(0, 64, " (0: eq. (15) of 001)"),
        "minres_iterations": Int(0, 65535, " (0: the default N)"),
        "minres_format": FloatFormat(),
        "minres_latency": Choice(LATENCY_PRESETS),
    },
)


def small():
    """The per-kind suites' core: case n2_m1_t3_pauto of tests/test_minres_rtl.py."""
    from mpc_cores.small import SmallCore, random_spec

    return SmallCore("minres/n2_m1_t3_pauto", random_spec("ra", 2, 1, 3, 0, 5), dict(P=0, iterations=8))
