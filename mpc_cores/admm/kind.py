"""The ADMM core kind (registry entry)."""
from mpc_cores.kind import CoreKind

KIND = CoreKind(
    name="admm",
    title="ADMM with input-rate and soft state constraints (Algorithm 2 of 002), fixed point",
    model_fn="mpc_cores.admm.model:AdmmFixed",
    spec_section=("frac_bits", "iterations", "P", "lat_add", "lat_mul", "rounding", "warm_start", "output_all", "target",
                  "safety", "rho", "soft_scale", "du_scale", "sizing_seed", "sizing_solves", "problems"),
    overrides=("P", "frac_bits", "lat_add", "lat_mul", "rounding", "iterations", "target", "problems"),
    controllers_fn="mpc_cores.admm.kind:controllers",
    c_fn="mpc_cores.admm.c:write_c",
)


def controllers(d):
    """Closed loop of `make demo`: the soft QP (8) by OSQP to optimality, the golden model (u = clip(u_prev + du_0)),
    references over 80 % of the box with the soft limits, the input box and the rate limit active (Fig. 5 of 002)."""
    from mpc_cores.admm.control import AdmmFixedController, AdmmOsqpController

    return AdmmOsqpController(d.problem), AdmmFixedController(d), 0.0
