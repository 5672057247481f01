"""The DGP core kind (registry entry)."""
from mpc_cores.kind import CoreKind

KIND = CoreKind(
    name="dgp",
    title="dual gradient projection, input and state constraints (iteration (35) of 003), fixed point",
    constraints=("hard_states",),
    model_fn="mpc_cores.dgp.model:DgpFixed",
    spec_section=("P", "frac_bits", "int_bits", "iterations", "lat_add", "lat_mul", "warm_start", "output_all", "target",
                  "eps_g", "eps_V", "tol", "accelerated", "lanes", "dual_margin"),
    overrides=("P", "frac_bits", "lat_add", "lat_mul", "iterations", "target", "tol", "accelerated", "lanes"),
    controllers_fn="mpc_cores.dgp.control:controllers",
    c_fn="mpc_cores.dgp.c:write_c",
    tol_fn="mpc_cores.dgp.design:write_tol_spec",
    driver=True,
    answer_status_word=True,
)
