"""The interior-point core kind (registry entry): Algorithm 1 of 001, Stage 1 and MINRES, 2P problems in flight."""
from mpc_cores.float.latency import LATENCY_PRESETS
from mpc_cores.kind import CoreKind
from mpc_cores.schema import Bool, Choice, FloatFormat, Int, Num

KIND = CoreKind(
    name="ipm",
    title="primal-dual interior-point method (Algorithm 1 of 001): Stage 1 engine and MINRES, binary32 or "
          "e<E>m<M>, 2P problems in flight",
    constraints=("hard_states",),
    model_fn="mpc_cores.ipm.core_model:IpmCoreModel",
    spec_section=("ipm_P", "ipm_newton", "ipm_minres", "ipm_format", "ipm_latency", "ipm_mu_tol", "ipm_res_tol",
                  "ipm_multiplexed"),
    overrides=("P", "iterations", "newton", "lat_add", "lat_mul", "format", "latency", "target", "multiplexed"),
    cycle_test="latency",
    controllers_fn="mpc_cores.ipm.kind:controllers",
    rtl_controller_fn="mpc_cores.ipm.control:rtl_controller",
    # a solve of masses is about 141,000 cycles: 20 steps (four references of 5 steps) keep the demo near 2 minutes
    demo_steps=(20, 5),
    spec_rules={
        "ipm_P": Int(0, 64, " (0: eq. (15) of 001)"),
        "ipm_newton": Int(1, 65535, " (I_NW)"),
        "ipm_minres": Int(0, 65535, " (I_MR; 0: the default)"),
        "ipm_format": FloatFormat(),
        "ipm_latency": Choice(LATENCY_PRESETS),
        "ipm_mu_tol": Num(0),
        "ipm_res_tol": Num(0),
        "ipm_multiplexed": Bool(),
    },
)


def small():
    """The per-kind suites' core: case n2_m1_t3_p1 of tests/test_ipm_rtl.py (P = 1, one output tracked, a state
    box)."""
    from mpc_cores.small import SmallCore, random_spec

    return SmallCore("ipm/n2_m1_t3_p1",
                     random_spec("ia", 2, 1, 3, 1, 5, hard_states={"indices": [0], "min": -1.0, "max": 1.0}),
                     dict(P=1, iterations=6, newton=3))


def controllers(d):
    """Closed loop of `make demo CORE=ipm`: OSQP to optimality and the bit-exact model, one channel (0); the RTL
    side is mpc_cores.ipm.control.rtl_controller (KIND.rtl_controller_fn)."""
    from mpc_cores.closedloop import OsqpController
    from mpc_cores.ipm.control import IpmModelController

    return OsqpController(d.problem), IpmModelController(d), 0.9
