"""The FGM core kind (registry entry)."""
from mpc_cores.kind import CoreKind

KIND = CoreKind(
    name="fgm",
    title="fast gradient method, input-constrained MPC (Algorithm 1 of 002), fixed point",
    generator_main="fgm.FgmMain",
    design_fn="mpc_cores.fgm.design:design_fgm",
    report_module="mpc_cores.fgm.report",
    model_fn="mpc_cores.fgm.model:FgmFixed",
    testbench="verif.fgm.tb",
    bench="mpc_bench.fgm",
    spec_section=("frac_bits", "iterations", "P", "lat_add", "lat_mul", "rounding", "warm_start", "output_all",
                  "c", "int_bits", "stream_width", "tol"),
    controllers_fn="mpc_cores.fgm.kind:controllers",
    tol_fn="mpc_cores.fgm.certify:design_for_tolerance",
    rdl_id="FGM1",
    extra={"design_extra": "mpc_cores.fgm.certify:certificate_text"},
)


def controllers(d):
    """Closed loop of `make demo`: OSQP to optimality, the golden model, references filtered for holdability."""
    from mpc_cores.closedloop import FixedController, OsqpController

    return OsqpController(d.problem), FixedController(d), 0.9
