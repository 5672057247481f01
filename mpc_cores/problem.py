"""MPC problem specification, validation and condensing.

A spec (YAML or JSON) describes a linear time-invariant model, quadratic
cost, horizon, input box, the box of initial states the core must accept and
optionally an output-tracking reference.  `condense` eliminates the states
and yields the box-constrained QP

    minimise 0.5 z'Hz + z'(Phi w)   subject to   lb <= z <= ub,

with z = (u_0, ..., u_{N-1}) and w = (x0, r) the parameter vector.

Optional sections for the state-constrained (ADMM) formulation of mpc_cores/admm/problem.py: `input_rate`
(box on u_k - u_{k-1}, plus a weight on it), `soft_states` (|x_i - c_i| <= r_i + delta_i, penalty
sigma1 1'delta + sigma2 ||delta||^2, eq. (2)-(3) of 002) and `hard_states` (x_min <= x_i <= x_max). The
FGM design refuses specs that have them.
"""

from __future__ import annotations

import json
import numbers
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.linalg

from mpc_cores.errors import SpecError
from mpc_cores.schema import check_size, check_spec


# Weight on (u_k - u_{k-1}) when `input_rate.weight` is absent: small next to R = I so that it barely moves the
# optimum, nonzero so that every decision variable of the sparse form carries curvature.
DU_WEIGHT_DEFAULT = 0.01


@dataclass(frozen=True, eq=False)
class InputRate:
    """dumin <= u_k - u_{k-1} <= dumax, cost du' W du per stage."""
    dumin: np.ndarray
    dumax: np.ndarray
    weight: np.ndarray


@dataclass(frozen=True, eq=False)
class SoftStates:
    """|x_i - c_i| <= r_i + delta_i, delta_i >= 0 for i in indices; c = (min + max)/2, r = (max - min)/2."""
    indices: tuple
    xmin: np.ndarray
    xmax: np.ndarray
    sigma1: float
    sigma2: float

    @property
    def center(self) -> np.ndarray:
        return 0.5 * (self.xmin + self.xmax)

    @property
    def radius(self) -> np.ndarray:
        return 0.5 * (self.xmax - self.xmin)


@dataclass(frozen=True, eq=False)
class HardStates:
    indices: tuple
    xmin: np.ndarray
    xmax: np.ndarray


@dataclass(frozen=True, eq=False)
class CheckSpec:
    """The spec's `check:` section (mpc_cores.check): the closed-loop scenario (initial state, samples, samples per
    reference, the seed of the reference draw), the number of sampled states and the target, if any: the closed-loop
    cost gap in percent, the hard constraints' tolerance as a fraction of each constraint's range, and the budget
    of cycles per solve within which a flow may raise the iteration counts."""
    x0: np.ndarray | None = None
    steps: int = 60
    hold: int = 20
    seed: int = 0
    samples: int = 24
    gap: float | None = None
    violation: float = 1e-3
    cycles: int = 100_000


# eq=False: element-wise array comparison makes generated __eq__/__hash__ unusable.
@dataclass(frozen=True, eq=False)
class MpcProblem:
    name: str
    A: np.ndarray
    B: np.ndarray
    Q: np.ndarray
    R: np.ndarray
    QN: np.ndarray
    N: int
    umin: np.ndarray
    umax: np.ndarray
    xmin: np.ndarray
    xmax: np.ndarray
    C: np.ndarray | None
    rmin: np.ndarray
    rmax: np.ndarray
    Ts: float | None
    solver: dict = field(default_factory=dict)
    input_rate: InputRate | None = None
    soft_states: SoftStates | None = None
    hard_states: HardStates | None = None
    check: CheckSpec = field(default_factory=CheckSpec)

    @property
    def nx(self) -> int:
        return self.A.shape[0]

    @property
    def nu(self) -> int:
        return self.B.shape[1]

    @property
    def ny(self) -> int:
        return 0 if self.C is None else self.C.shape[0]

    @property
    def n(self) -> int:
        return self.N * self.nu

    @property
    def nw(self) -> int:
        return self.nx + self.ny


@dataclass(frozen=True, eq=False)
class CondensedQP:
    H: np.ndarray
    Phi: np.ndarray
    lb: np.ndarray
    ub: np.ndarray
    n: int
    nw: int
    nu: int


# --------------------------------------------------------------------------
# parsing helpers


def _fmt(v) -> str:
    return np.array2string(np.asarray(v), precision=6, separator=", ")


def _shape(a: np.ndarray) -> str:
    return "x".join(str(s) for s in a.shape) if a.ndim else "scalar"


def _array(value, fld: str) -> np.ndarray:
    if isinstance(value, (str, bytes, bool)) or value is None:
        raise SpecError(f"{fld}: expected numbers, got {value!r}")
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise SpecError(f"{fld}: not a numeric array (ragged or non-numeric entries): {value!r}") from None
    if not np.all(np.isfinite(a)):
        raise SpecError(f"{fld}: entries must be finite, got {_fmt(a)}")
    return a


def _matrix(value, fld: str) -> np.ndarray:
    a = _array(value, fld)
    if a.ndim != 2 or a.size == 0:
        raise SpecError(f"{fld}: expected a non-empty matrix (list of rows), got shape {_shape(a)}")
    return a


def _square_weight(value, n: int, fld: str) -> np.ndarray:
    """Scalar (times identity), list (diagonal) or n x n matrix."""
    if isinstance(value, str):
        raise SpecError(f"{fld}: unknown value {value!r} (expected a scalar, a list or a matrix)")
    a = _array(value, fld)
    if a.ndim == 0:
        return float(a) * np.eye(n)
    if a.ndim == 1:
        if a.shape[0] != n:
            raise SpecError(f"{fld}: expected a diagonal of {n} values, got {a.shape[0]}")
        return np.diag(a)
    if a.ndim == 2:
        if a.shape != (n, n):
            raise SpecError(f"{fld}: expected a {n}x{n} matrix, got {_shape(a)}")
        if not np.allclose(a, a.T, rtol=1e-9, atol=1e-12 * max(1.0, np.abs(a).max())):
            raise SpecError(f"{fld}: matrix must be symmetric (max |M - M'| = {np.abs(a - a.T).max():.3g})")
        return 0.5 * (a + a.T)
    raise SpecError(f"{fld}: expected a scalar, a list or a matrix, got shape {_shape(a)}")


def _min_eig(M: np.ndarray) -> float:
    return float(np.linalg.eigvalsh(M).min())


def _check_psd(M: np.ndarray, fld: str) -> None:
    lam = _min_eig(M)
    if lam < -1e-12 * max(1.0, np.abs(M).max()):
        raise SpecError(f"{fld} must be positive semidefinite: smallest eigenvalue {lam:.3g}")


def _check_pd(M: np.ndarray, fld: str) -> None:
    lam = _min_eig(M)
    if lam <= 1e-12 * max(1.0, np.abs(M).max()):
        raise SpecError(f"{fld} must be positive definite: smallest eigenvalue {lam:.3g}")


def _vector(value, n: int, fld: str) -> np.ndarray:
    """Scalar (broadcast) or list of n values."""
    a = _array(value, fld)
    if a.ndim == 0:
        return np.full(n, float(a))
    if a.ndim != 1 or a.shape[0] != n:
        raise SpecError(f"{fld}: expected a scalar or a list of {n} values, got shape {_shape(a)}")
    return a.copy()


def _box(d, n: int, fld: str) -> tuple[np.ndarray, np.ndarray]:
    """d: {min, max} (keys checked by mpc_cores.schema)"""
    lo = _vector(d["min"], n, f"{fld}.min")
    hi = _vector(d["max"], n, f"{fld}.max")
    bad = np.flatnonzero(~(lo < hi))
    if bad.size:
        i = int(bad[0])
        raise SpecError(
            f"{fld}: min must be < max elementwise, violated at index {i}: min {lo[i]:g} >= max {hi[i]:g}"
        )
    return lo, hi


def zoh(Ac: np.ndarray, Bc: np.ndarray, Ts: float) -> tuple[np.ndarray, np.ndarray]:
    """Zero-order-hold discretisation via the exponential of the augmented matrix."""
    nx, nu = Bc.shape
    M = np.zeros((nx + nu, nx + nu))
    M[:nx, :nx] = Ac
    M[:nx, nx:] = Bc
    E = scipy.linalg.expm(M * Ts)
    return E[:nx, :nx].copy(), E[:nx, nx:].copy()


def _parse_model(d) -> tuple[np.ndarray, np.ndarray, float | None]:
    discrete = "A" in d or "B" in d
    continuous = "Ac" in d or "Bc" in d
    if discrete == continuous:
        raise SpecError("model: give either a discrete model {A, B} or a continuous one {Ac, Bc, Ts}, "
                        f"got keys {sorted(d)}")
    a, b = ("A", "B") if discrete else ("Ac", "Bc")
    for k in (a, b):
        if k not in d:
            raise SpecError(f"model: missing key {k!r}")
    A = _matrix(d[a], f"model.{a}")
    if A.shape[0] != A.shape[1]:
        raise SpecError(f"model.{a}: expected a square matrix, got {_shape(A)}")
    nx = A.shape[0]
    Braw = _array(d[b], f"model.{b}")
    if Braw.ndim == 1:  # a flat list is a single input column
        Braw = Braw[:, None]
    if Braw.ndim != 2 or Braw.size == 0:
        raise SpecError(f"model.{b}: expected a non-empty matrix, got shape {_shape(Braw)}")
    if Braw.shape[0] != nx:
        raise SpecError(f"model.{b}: expected {nx} rows to match {a} ({nx}x{nx}), got {Braw.shape[0]}")
    Ts = float(d["Ts"]) if "Ts" in d else None
    if continuous:
        if Ts is None:
            raise SpecError("model.Ts: required for a continuous model {Ac, Bc}")
        A, B = zoh(A, Braw, Ts)
    else:
        B = Braw
    return A, B, Ts


def _parse_tracking(d, nx: int):
    if ("C" in d) == ("outputs" in d):
        raise SpecError("tracking: give exactly one of 'C' (matrix) or 'outputs' (state indices)")
    if "C" in d:
        C = _array(d["C"], "tracking.C")
        if C.ndim == 1:  # a flat list is a single output row
            C = C[None, :]
        if C.ndim != 2 or C.size == 0 or C.shape[1] != nx:
            raise SpecError(f"tracking.C: expected ny x {nx} to match the {nx} states, got shape {_shape(C)}")
    else:
        idx = list(_state_indices(d["outputs"], nx, "tracking.outputs"))
        C = np.eye(nx)[idx]
    rmin, rmax = _box({"min": d["min"], "max": d["max"]}, C.shape[0], "tracking")
    return C, rmin, rmax


def _state_indices(v, nx: int, fld: str) -> tuple:
    if not isinstance(v, list) or not v or not all(isinstance(i, numbers.Integral) and not isinstance(i, bool) for i in v):
        raise SpecError(f"{fld}: expected a non-empty list of state indices, got {v!r}")
    bad = [i for i in v if not 0 <= i < nx]
    if bad:
        raise SpecError(f"{fld}: indices {bad} out of range 0..{nx - 1}")
    if len(set(v)) != len(v):
        raise SpecError(f"{fld}: duplicate indices in {v}")
    return tuple(int(i) for i in v)


def _parse_input_rate(d, nu: int) -> InputRate:
    lo, hi = _box({"min": d["min"], "max": d["max"]}, nu, "input_rate")
    bad = np.flatnonzero((lo > 0) | (hi < 0))
    if bad.size:
        i = int(bad[0])
        raise SpecError(f"input_rate: the box must contain 0 (holding the input must stay feasible), "
                        f"violated at index {i}: [{lo[i]:g}, {hi[i]:g}]")
    W = _square_weight(d.get("weight", DU_WEIGHT_DEFAULT), nu, "input_rate.weight")
    _check_psd(W, "input_rate.weight")
    for a in (lo, hi, W):
        a.setflags(write=False)
    return InputRate(dumin=lo, dumax=hi, weight=W)


def _parse_state_set(d, nx: int, fld: str, soft: bool):
    idx = _state_indices(d["indices"], nx, f"{fld}.indices")
    lo, hi = _box({"min": d["min"], "max": d["max"]}, len(idx), fld)
    lo.setflags(write=False)
    hi.setflags(write=False)
    if not soft:
        return HardStates(indices=idx, xmin=lo, xmax=hi)
    return SoftStates(indices=idx, xmin=lo, xmax=hi, sigma1=float(d["sigma1"]), sigma2=float(d["sigma2"]))


def _parse_check(d: dict, xmin: np.ndarray, xmax: np.ndarray) -> CheckSpec:
    x0 = None
    if d.get("x0") is not None:
        x0 = _vector(d["x0"], len(xmin), "check.x0")
        bad = np.flatnonzero((x0 < xmin) | (x0 > xmax))
        if bad.size:
            i = int(bad[0])
            raise SpecError(f"check.x0: the initial state must lie in the box of `states`, violated at index {i}: "
                            f"{x0[i]:g} not in [{xmin[i]:g}, {xmax[i]:g}]")
        x0.setflags(write=False)
    return CheckSpec(x0=x0, **{k: v for k, v in d.items() if k != "x0" and v is not None})


def problem_from_dict(d: dict, name: str = "problem") -> MpcProblem:
    """The problem of a spec: structure, types, ranges (mpc_cores.schema), then the sections, the size limits,
    and only then the numerics of the cost (the DARE)."""
    d = check_spec(d)
    name = d.get("name", name)
    A, B, Ts = _parse_model(d["model"])
    nx, nu = B.shape
    N = d["horizon"]
    umin, umax = _box(d["inputs"], nu, "inputs")
    xmin, xmax = _box(d["states"], nx, "states")

    if d.get("tracking") is not None:
        C, rmin, rmax = _parse_tracking(d["tracking"], nx)
    else:
        C, rmin, rmax = None, np.zeros(0), np.zeros(0)

    input_rate = _parse_input_rate(d["input_rate"], nu) if d.get("input_rate") is not None else None
    soft = _parse_state_set(d["soft_states"], nx, "soft_states", True) if d.get("soft_states") is not None else None
    hard = _parse_state_set(d["hard_states"], nx, "hard_states", False) if d.get("hard_states") is not None else None
    if soft is not None and hard is not None and set(soft.indices) & set(hard.indices):
        raise SpecError(f"soft_states and hard_states: index sets must be disjoint (eq. (3) of 002), "
                        f"both contain {sorted(set(soft.indices) & set(hard.indices))}")
    check = _parse_check(d.get("check") or {}, xmin, xmax)
    solver = d.get("solver") or {}
    check_size(N, nx, nu, 0 if C is None else C.shape[0], 0 if soft is None else len(soft.indices),
               input_rate is not None, solver.get("P"))

    cost = d["cost"]
    Q = _square_weight(cost["Q"], nx, "cost.Q")
    _check_psd(Q, "cost.Q")
    R = _square_weight(cost["R"], nu, "cost.R")
    _check_pd(R, "cost.R")
    qn = cost.get("QN", "dare")
    if isinstance(qn, str):
        if qn != "dare":
            raise SpecError(f"cost.QN: unknown value {qn!r} (expected 'dare', a scalar, a list or a matrix)")
        try:
            QN = scipy.linalg.solve_discrete_are(A, B, Q, R)
        except (np.linalg.LinAlgError, ValueError) as e:
            raise SpecError(f"cost.QN: 'dare' failed, (A, B) not stabilisable or (Q, A) not detectable? ({e})") from None
        QN = 0.5 * (QN + QN.T)
    else:
        QN = _square_weight(qn, nx, "cost.QN")
    _check_psd(QN, "cost.QN")

    arrays = [A, B, Q, R, QN, umin, umax, xmin, xmax, rmin, rmax] + ([C] if C is not None else [])
    for a in arrays:
        a.setflags(write=False)
    return MpcProblem(name=name, A=A, B=B, Q=Q, R=R, QN=QN, N=N, umin=umin, umax=umax,
                      xmin=xmin, xmax=xmax, C=C, rmin=rmin, rmax=rmax, Ts=Ts, solver=dict(solver),
                      input_rate=input_rate, soft_states=soft, hard_states=hard, check=check)


def load_spec(path) -> MpcProblem:
    path = Path(path)
    ext = path.suffix.lower()
    if ext not in (".yaml", ".yml", ".json"):
        raise SpecError(f"{path}: unknown spec extension {ext!r} (expected .yaml, .yml or .json)")
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise SpecError(f"spec file not found: {path}") from None
    except (OSError, UnicodeDecodeError) as e:
        raise SpecError(f"spec file not readable: {path}: {getattr(e, 'strerror', None) or e}") from None
    if ext in (".yaml", ".yml"):
        import yaml
        try:
            d = yaml.safe_load(text)
        except yaml.YAMLError as e:
            mark = getattr(e, "problem_mark", None)
            where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
            raise SpecError(f"{path}: invalid YAML{where}: {getattr(e, 'problem', None) or e}") from None
    elif ext == ".json":
        try:
            d = json.loads(text)
        except json.JSONDecodeError as e:
            raise SpecError(f"{path}: invalid JSON: {e}") from None
    return problem_from_dict(d, name=path.stem)


# --------------------------------------------------------------------------
# steady state, condensing, cost evaluation


def steady_state_maps(p: MpcProblem) -> tuple[np.ndarray, np.ndarray]:
    """(Mx, Mu) with xs = Mx r, us = Mu r solving A xs + B us = xs, C xs = r."""
    nx, nu, ny = p.nx, p.nu, p.ny
    if p.C is None:
        return np.zeros((nx, 0)), np.zeros((nu, 0))
    M = np.block([[p.A - np.eye(nx), p.B], [p.C, np.zeros((ny, nu))]])
    rhs = np.vstack([np.zeros((nx, ny)), np.eye(ny)])
    if M.shape[0] == M.shape[1] and np.linalg.cond(M) < 1e12:
        S = np.linalg.solve(M, rhs)
    else:
        S = np.linalg.pinv(M) @ rhs
    return S[:nx], S[nx:]


def _prediction(p: MpcProblem) -> tuple[np.ndarray, np.ndarray]:
    """Sx (N nx x nx), Su (N nx x N nu) with (x_1..x_N) = Sx x0 + Su z."""
    nx, nu, N = p.nx, p.nu, p.N
    Sx = np.zeros((N * nx, nx))
    Su = np.zeros((N * nx, N * nu))
    Ak = np.eye(nx)
    AkB = []  # A^k B, k = 0..N-1
    for k in range(N):
        AkB.append(Ak @ p.B)
        Ak = p.A @ Ak
        Sx[k * nx:(k + 1) * nx] = Ak
    for k in range(N):  # block row of x_{k+1}
        for j in range(k + 1):
            Su[k * nx:(k + 1) * nx, j * nu:(j + 1) * nu] = AkB[k - j]
    return Sx, Su


def condense(p: MpcProblem) -> CondensedQP:
    N, nx, nu = p.N, p.nx, p.nu
    Sx, Su = _prediction(p)
    Qbar = scipy.linalg.block_diag(*([p.Q] * (N - 1) + [p.QN]))
    Rbar = np.kron(np.eye(N), p.R)
    SuQ = Su.T @ Qbar
    H = 2.0 * (SuQ @ Su + Rbar)
    H = 0.5 * (H + H.T)
    Mx, Mu = steady_state_maps(p)
    Phi_x = 2.0 * SuQ @ Sx
    Phi_r = -2.0 * (SuQ @ np.tile(Mx, (N, 1)) + Rbar @ np.tile(Mu, (N, 1)))
    Phi = np.hstack([Phi_x, Phi_r])
    lb = np.tile(p.umin, N)
    ub = np.tile(p.umax, N)
    for a in (H, Phi, lb, ub):
        a.setflags(write=False)
    return CondensedQP(H=H, Phi=Phi, lb=lb, ub=ub, n=N * nu, nw=p.nw, nu=nu)


def qp_objective(qp: CondensedQP, z, w) -> float:
    z = np.asarray(z, dtype=float)
    w = np.asarray(w, dtype=float)
    return float(0.5 * z @ qp.H @ z + z @ (qp.Phi @ w))


def _targets(p: MpcProblem, r) -> tuple[np.ndarray, np.ndarray]:
    if r is None or (p.C is None and np.size(r) == 0):
        return np.zeros(p.nx), np.zeros(p.nu)
    if p.C is None:
        raise ValueError(f"problem {p.name!r} is a regulator, got a reference of size {np.size(r)}")
    r = np.asarray(r, dtype=float).reshape(-1)
    if r.shape[0] != p.ny:
        raise ValueError(f"reference has {r.shape[0]} entries, expected ny = {p.ny}")
    Mx, Mu = steady_state_maps(p)
    return Mx @ r, Mu @ r


def stage_cost(p: MpcProblem, x, u, r=None) -> float:
    xs, us = _targets(p, r)
    dx = np.asarray(x, dtype=float) - xs
    du = np.asarray(u, dtype=float) - us
    return float(dx @ p.Q @ dx + du @ p.R @ du)


def simulate(p: MpcProblem, x0, U) -> np.ndarray:
    U = np.asarray(U, dtype=float).reshape(p.N, p.nu)
    X = np.zeros((p.N + 1, p.nx))
    X[0] = np.asarray(x0, dtype=float)
    for k in range(p.N):
        X[k + 1] = p.A @ X[k] + p.B @ U[k]
    return X


def horizon_cost(p: MpcProblem, x0, U, r=None) -> float:
    U = np.asarray(U, dtype=float).reshape(p.N, p.nu)
    X = simulate(p, x0, U)
    xs, us = _targets(p, r)
    J = sum(stage_cost(p, X[k], U[k], r) for k in range(p.N))
    dN = X[p.N] - xs
    return float(J + dN @ p.QN @ dN)
