"""The ADMM core kind (registry entry)."""
from mpc_cores.kind import CoreKind
from mpc_cores.schema import Bool, Choice, Int, Num

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
    spec_rules={  # powers of two are checked by the design
        "rho": Num(0),
        "soft_scale": Num(0),
        "du_scale": Num(0),
        "safety": Num(1, strict=False, why=" (it multiplies the simulated magnitudes)"),
        "sizing_seed": Int(0),
        "sizing_solves": Int(1, 100000),
        "method": Choice(("admm", "ama", "vucondat")),
        "precondition": Bool(),
    },
)


RATE = {"min": -0.3, "max": 0.3, "weight": 0.1}


def small():
    """The per-kind suites' ADMM core: case rand_rate_n19_p5 of the ADMM RTL suite (tests/conftest.py ADMM_CASES):
    no soft states, P = 5 not dividing n_A = 19."""
    from mpc_cores.small import SmallCore, random_spec

    return SmallCore("admm/rand_rate_n19_p5", random_spec("rr19", 3, 1, 4, 1, 7, input_rate=RATE),
                     dict(P=5, frac_bits=15))


def small_ama():
    """The per-kind suites' AMA core: case rand_rate_n19_p2_ecp5_ama (the ECP5 target)."""
    from mpc_cores.small import SmallCore, random_spec

    return SmallCore("admm/rand_rate_n19_p2_ecp5_ama", random_spec("rm19", 3, 1, 4, 1, 7, input_rate=RATE),
                     dict(P=2, frac_bits=15, target="ecp5", method="ama"))


def small_vucondat():
    """The per-kind suites' Vu-Condat core: case rand_soft_n19_p3_k2_vucondat (soft pairs, K_p = 2)."""
    from mpc_cores.small import SmallCore, random_spec

    soft = {"indices": [0], "min": -0.5, "max": 0.5, "sigma1": 8, "sigma2": 1}
    return SmallCore("admm/rand_soft_n19_p3_k2_vucondat",
                     random_spec("rv19", 2, 1, 3, 1, 5, input_rate=RATE, soft_states=soft),
                     dict(P=3, frac_bits=16, problems=2, method="vucondat"))


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
        testbench="verif.admm.tb", fuzz="verif.admm.fuzz:FAMILY", small=f"mpc_cores.admm.kind:small_{method}",
        docs_page="docs/admm.md", lpf="constraints/admm_core.lpf", soak=f"mpc_cores.admm.soak:{method.upper()}_SOAK",
        spec_section=KIND.spec_section, spec_rules=KIND.spec_rules, overrides=KIND.overrides, constraints=KIND.constraints,
        controllers_fn="mpc_cores.admm.kind:controllers",
        c_fn="mpc_cores.admm.c:write_c", split_fn=KIND.split_fn, driver=True,
        rtl_controller_fn=KIND.rtl_controller_fn, holdable=KIND.holdable)


AMA_KIND = _method_kind("ama", "alternating minimisation algorithm (Tseng; 004) on the ADMM datapath, fixed point")
VUCONDAT_KIND = _method_kind("vucondat", "primal-dual method of Vu and Condat (004) on the ADMM datapath, fixed point")
