"""The interior-point core kind (registry entry): Algorithm 1 of 001, Stage 1 and MINRES, 2P problems in flight."""
from mpc_cores.kind import CoreKind

KIND = CoreKind(
    name="ipm",
    title="primal-dual interior-point method (Algorithm 1 of 001): Stage 1 engine and MINRES, binary32 or "
          "e<E>m<M>, 2P problems in flight",
    constraints=("hard_states",),
    model_fn="mpc_cores.ipm.core_model:IpmCoreModel",
    spec_section=("ipm_P", "ipm_newton", "ipm_minres", "ipm_format", "ipm_latency", "ipm_mu_tol", "ipm_res_tol"),
    overrides=("P", "iterations", "newton", "lat_add", "lat_mul", "format", "latency", "target"),
    cycle_test="latency",
    controllers_fn="mpc_cores.ipm.kind:controllers",
    rtl_controller_fn="mpc_cores.ipm.control:rtl_controller",
    # a solve of masses is about 141,000 cycles: 20 steps (four references of 5 steps) keep the demo near 2 minutes
    demo_steps=(20, 5),
)


def controllers(d):
    """Closed loop of `make demo CORE=ipm`: OSQP to optimality and the bit-exact model, one channel (0); the RTL
    side is mpc_cores.ipm.control.rtl_controller (KIND.rtl_controller_fn)."""
    from mpc_cores.closedloop import OsqpController
    from mpc_cores.ipm.control import IpmModelController

    return OsqpController(d.problem), IpmModelController(d), 0.9
