"""The plants of the scaling sweep (mpc_bench.scaling): a chain of M masses between two walls, horizon N
(examples/masses.yaml is M = 4, N = 10), and the same chain with hard position limits (examples/masses_state.yaml)."""
from __future__ import annotations

from contextlib import contextmanager

import numpy as np

POSITION_LIMIT = 0.5     # |p_i| <= 0.5 at stages 1..N, the hard rows (examples/masses_state.yaml)
ACCEPTED = 0.35          # the accepted positions and references; velocities within 0.25 (masses_state.yaml)


def chain_state(M: int, N: int):
    """chain_dict with masses_state.yaml's hard position limits, accepted box and references"""
    from mpc_cores.problem import problem_from_dict

    spec = chain_dict(M, N)
    spec.update(name=f"chain{M}_state_N{N}",
                states={"min": [-ACCEPTED] * M + [-0.25] * M, "max": [ACCEPTED] * M + [0.25] * M},
                hard_states={"indices": list(range(M)), "min": -POSITION_LIMIT, "max": POSITION_LIMIT},
                tracking={"outputs": list(range(M)), "min": -ACCEPTED, "max": ACCEPTED})
    return problem_from_dict(spec)


def chain_dict(M: int, N: int) -> dict:
    """The spec of M masses of 1 kg between two walls, springs of 1 N/m, one force per mass (masses.yaml
    generalised)"""
    K = -2 * np.eye(M) + np.eye(M, k=1) + np.eye(M, k=-1)
    Ac = np.block([[np.zeros((M, M)), np.eye(M)], [K, np.zeros((M, M))]])
    Bc = np.vstack([np.zeros((M, M)), np.eye(M)])
    return {"name": f"chain{M}_N{N}", "model": {"Ac": Ac.tolist(), "Bc": Bc.tolist(), "Ts": 0.5},
            "cost": {"Q": 1.0, "R": 1.0, "QN": "dare"}, "horizon": N, "inputs": {"min": -0.5, "max": 0.5},
            "states": {"min": -2.0, "max": 2.0}, "tracking": {"outputs": list(range(M)), "min": -1.0, "max": 1.0}}


def chain(M: int, N: int):
    """chain_dict as a problem"""
    from mpc_cores.problem import problem_from_dict

    return problem_from_dict(chain_dict(M, N))


class NoLoop(ValueError):
    """The instance has no closed loop to measure: no reference of its box can be held inside the input box"""


@contextmanager
def references_held():
    """mpc_cores.closedloop.reference_schedule's refusal (no reference of the box holdable inside the input box, as
    on long chains, whose steady-state forces grow with M) as NoLoop; any other error as it is"""
    try:
        yield
    except ValueError as e:
        if str(e).startswith("no reference in the box"):
            raise NoLoop(str(e)) from None
        raise
