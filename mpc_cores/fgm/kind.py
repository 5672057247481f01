"""The FGM core kind (registry entry)."""
from mpc_cores.kind import CoreKind

KIND = CoreKind(
    name="fgm",
    title="fast gradient method, input-constrained MPC (Algorithm 1 of 002), fixed point",
    model_fn="mpc_cores.fgm.model:FgmFixed",
    spec_section=("frac_bits", "iterations", "P", "lat_add", "lat_mul", "rounding", "warm_start", "output_all", "target",
                  "c", "int_bits", "stream_width", "tol", "problems", "early_exit", "exit_tol"),
    overrides=("P", "frac_bits", "lat_add", "lat_mul", "rounding", "iterations", "target", "problems", "early_exit",
               "exit_tol"),
    controllers_fn="mpc_cores.fgm.kind:controllers",
    c_fn="mpc_cores.fgm.c:write_c",
    tol_fn="mpc_cores.fgm.certify:write_certified_spec",
    certificate_fn="mpc_cores.fgm.certify:certificate_text",
    driver=True,
)


def controllers(d):
    """Closed loop of `make demo`: OSQP to optimality, the golden model, references filtered for holdability."""
    from mpc_cores.closedloop import OsqpController
    from mpc_cores.fgm.control import FixedController

    return OsqpController(d.problem), FixedController(d), KIND.holdable
