"""The ADMM core kind (registry entry)."""
from mpc_cores.kind import CoreKind

KIND = CoreKind(
    name="admm",
    title="ADMM with input-rate and soft state constraints (Algorithm 2 of 002), fixed point",
    constraints=("input_rate", "soft_states", "hard_states"),
    model_fn="mpc_cores.admm.model:AdmmFixed",
    spec_section=("frac_bits", "iterations", "P", "lat_add", "lat_mul", "rounding", "warm_start", "output_all", "target",
                  "safety", "rho", "soft_scale", "du_scale", "sizing_seed", "sizing_solves", "problems", "method", "precondition", "accelerated", "lanes"),
    overrides=("P", "frac_bits", "lat_add", "lat_mul", "rounding", "iterations", "target", "problems", "lanes"),
    controllers_fn="mpc_cores.admm.kind:controllers",
    c_fn="mpc_cores.admm.c:write_c",
    split_fn="mpc_cores.admm.split:write_split",
    driver=True,
    rtl_controller_fn="mpc_cores.admm.control:rtl_controller",
    holdable=0.0,
)


def controllers(d):
    """Closed loop of `make demo`: the soft QP (8) by OSQP to optimality, the golden model (u = clip(u_prev + du_0),
    or clip(u_0) without input_rate), references over 80 % of the box with the soft limits, the input box and the
    rate limit active (Fig. 5 of 002)."""
    from mpc_cores.admm.control import AdmmFixedController, AdmmOsqpController

    return AdmmOsqpController(d.problem), AdmmFixedController(d), KIND.holdable


def _method_kind(method: str, title: str) -> CoreKind:
    """A method of the splitting family (004) on the ADMM core's datapath: the ADMM generator, golden model,
    report, testbench and C emitter, with the design's method set (mpc_cores/admm/design.py)."""
    return CoreKind(
        name=method, title=title, model_fn="mpc_cores.admm.model:AdmmFixed", generator_main="admm.AdmmMain",
        design_fn=f"mpc_cores.admm.design:design_{method}", report_module="mpc_cores.admm.report",
        testbench="verif.admm.tb", soak=f"mpc_cores.admm.soak:{method.upper()}_SOAK",
        spec_section=KIND.spec_section, overrides=KIND.overrides, constraints=KIND.constraints,
        controllers_fn="mpc_cores.admm.kind:controllers",
        c_fn="mpc_cores.admm.c:write_c", split_fn=KIND.split_fn, driver=True,
        rtl_controller_fn=KIND.rtl_controller_fn, holdable=KIND.holdable)


AMA_KIND = _method_kind("ama", "alternating minimisation algorithm (Tseng; 004) on the ADMM datapath, fixed point")
VUCONDAT_KIND = _method_kind("vucondat", "primal-dual method of Vu and Condat (004) on the ADMM datapath, fixed point")
