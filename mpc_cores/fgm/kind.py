"""The FGM core kind (registry entry)."""
from mpc_cores.kind import CoreKind
from mpc_cores.schema import Bool, Num, StreamWidth

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
    spec_rules={
        "c": Num(1, strict=False, why=" (Assumption 1 of 002)"),
        "stream_width": StreamWidth(),
        "early_exit": Bool(),
        "exit_tol": Num(0, why=" (in the units of u)"),
    },
)


def small():
    """The per-kind suites' core: case rand_n4_p4_b10 of the FGM RTL suite (tests/conftest.py CASES)."""
    from mpc_cores.small import SmallCore, random_spec

    return SmallCore("fgm/rand_n4_p4_b10", random_spec("r4", 3, 1, 4, 1, 1), dict(P=4, frac_bits=10))


def controllers(d):
    """Closed loop of `make demo`: OSQP to optimality, the golden model, references filtered for holdability."""
    from mpc_cores.closedloop import OsqpController
    from mpc_cores.fgm.control import FixedController

    return OsqpController(d.problem), FixedController(d), KIND.holdable
