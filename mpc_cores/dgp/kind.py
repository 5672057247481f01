"""The DGP core kind (registry entry)."""
from mpc_cores.kind import CoreKind
from mpc_cores.schema import Bool, Num

KIND = CoreKind(
    name="dgp",
    title="dual gradient projection, input and state constraints (iteration (35) of 003), fixed point",
    constraints=("hard_states",),
    model_fn="mpc_cores.dgp.model:DgpFixed",
    spec_section=("P", "frac_bits", "int_bits", "iterations", "lat_add", "lat_mul", "warm_start", "warm_shift",
                  "output_all", "target", "eps_g", "eps_V", "tol", "accelerated", "lanes", "dual_margin", "ram_state"),
    overrides=("P", "frac_bits", "lat_add", "lat_mul", "iterations", "target", "tol", "accelerated", "lanes"),
    controllers_fn="mpc_cores.dgp.control:controllers",
    c_fn="mpc_cores.dgp.c:write_c",
    tol_fn="mpc_cores.dgp.design:write_tol_spec",
    driver=True,
    answer_status_word=True,
    spec_rules={
        "eps_g": Num(0),
        "eps_V": Num(0),
        "dual_margin": Num(1, strict=False, why=" (d_i >= max(y*_i, 1), (14) of 003)"),
        "warm_shift": Bool(),
        "ram_state": Bool(),
    },
)


def small():
    """The per-kind suites' core: case small_accel of tests/test_dgp_rtl.py (accelerated, 2 lanes; an input box
    that binds at a third of the states, so that duals, restarts and warm starts from nonzero duals occur)."""
    from mpc_cores.small import SmallCore, random_spec

    return SmallCore("dgp/small_accel", random_spec("dg5", 2, 1, 4, 0, 5, states={"min": -0.5, "max": 0.5},
                                                    hard_states={"indices": [0], "min": -1.0, "max": 1.0},
                                                    inputs={"min": -0.3, "max": 0.2}),
                     dict(lanes=2, iterations=60))
