"""The MINRES core kind (registry entry): the banded linear solver of the interior-point method (001)."""
from mpc_cores.kind import CoreKind

KIND = CoreKind(
    name="minres",
    title="MINRES banded KKT solver of the interior-point method (001), binary32 or e<E>m<M>, P problems "
          "interleaved",
    model_fn="mpc_cores.minres.model:MinresCoreModel.from_config",
    spec_section=("minres_P", "minres_iterations", "minres_format", "minres_latency"),
    overrides=("P", "iterations", "lat_add", "lat_mul", "format", "latency", "target"),
    cycle_test="cycles_per_iteration",
)
