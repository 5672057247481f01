"""The QP solvers a user would pick for the cores' QPs, behind one interface. mpc_bench.baselines replays the closed
loop into them and times them.

  problem A ("box")   the condensed box QP of the FGM section (masses: n = 40, H dense): OSQP (default and tuned),
                      DAQP (hot start), PIQP (dense), ProxQP (dense, warm start), Clarabel, quadprog;
  problem B ("soft")  the soft-constrained sparse QP (8) of 002 of the ADMM section (masses_rate_soft, n_A = 216):
                      OSQP (default and tuned), PIQP (sparse), Clarabel.

Interface: a solver class is made once on the loop's QP (a LoopQp) with a name and its settings, and
`solve(w) -> (z, own_s)` gives the solution at the parameter w and the time the solver's own timer gave the solve in
seconds (None when it has none; a function giving it when reading the timer takes work of its own, to be called
after the wall clock of the solve has stopped); `.settings` says what it runs with, `.timer` what its own time
covers and `.iters` collects its iterations. SOLVERS is the one table of which solver runs on which problem;
`solver_makers` turns it into the makers of a mpc_bench.baselines.SwCase (whose report cells set their times against
a core). Every solver runs single-threaded: their thread options are set to 1 where they have one, and the timing
pins the process to one CPU (mpc_bench.baselines.pinned)."""
from __future__ import annotations

import importlib.util
import os
import re
import sys
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

# OSQP settings. "default": the library's (1.x: eps 1e-3, no polishing, warm start on, termination checked
# every 25 iterations, adaptive rho). "tuned": embedded settings for this warm-started loop; with a warm start
# the solver converges in a few iterations, so checking termination every 5 saves most of the default's 25;
# a fixed rho avoids refactorisations, and 0.3 was the fastest of 0.03, 0.1, 0.3 and 1 on this loop.
OSQP_DEFAULT: dict = {}
OSQP_TUNED = dict(eps_abs=1e-3, eps_rel=1e-3, polishing=False, warm_starting=True, check_termination=5,
                  adaptive_rho=False, rho=0.3)
# The same for the soft-constrained QP of masses_rate_soft: rho = 1 had the lowest median time of 0.1, 0.3, 1
# and 3 (0.3 as fast at the median, but 510 iterations at worst against 140).
OSQP_TUNED_ADMM = dict(OSQP_TUNED, rho=1.0)


# ----------------------------------------------------------------------------------------- the loop's QP

@dataclass
class LoopQp:
    """min 1/2 z'H z + q(w)'z subject to A_eq z = b(w) (the first neq rows of A) and l <= A z <= u (the other rows,
    their bounds constant), with q(w) = Qw w + q0 and b(w) = Bw w: every QP of one closed loop."""
    H: np.ndarray                # n x n, dense
    Qw: np.ndarray               # n x nw
    q0: np.ndarray
    A: sp.csc_matrix             # m x n
    l: np.ndarray                # m (the first neq entries are b(0) and unused)
    u: np.ndarray
    Bw: np.ndarray               # neq x nw

    @property
    def n(self) -> int:
        return self.H.shape[0]

    @property
    def neq(self) -> int:
        return self.Bw.shape[0]

    def q(self, w: np.ndarray) -> np.ndarray:
        return self.Qw @ w + self.q0

    def b(self, w: np.ndarray) -> np.ndarray:
        return self.Bw @ w

    def parts(self) -> tuple:
        """(A_eq, x_l, x_u, G, h_l, h_u): the equality rows; the rows that bound one variable (a single entry 1) as
        variable bounds (+-inf where none); the other rows as h_l <= G z <= h_u. Dense arrays, G with 0 rows when
        there are none."""
        A = self.A.tocsr()
        E, R, l, u = A[: self.neq], A[self.neq:], self.l[self.neq:], self.u[self.neq:]
        nnz = np.diff(R.indptr)
        single = nnz == 1
        single[single] = R.data[R.indptr[:-1][single]] == 1.0
        x_l, x_u = np.full(self.n, -np.inf), np.full(self.n, np.inf)
        for i in np.flatnonzero(single):
            j = R.indices[R.indptr[i]]
            x_l[j], x_u[j] = max(x_l[j], l[i]), min(x_u[j], u[i])
        G = R[~single]
        return E.toarray(), x_l, x_u, G.toarray(), l[~single], u[~single]


def box_qp(qp) -> LoopQp:
    """Problem A: the condensed QP of mpc_cores.problem.condense, min 1/2 z'H z + (Phi w)'z over lb <= z <= ub."""
    n = qp.n
    return LoopQp(np.asarray(qp.H, dtype=float), np.asarray(qp.Phi, dtype=float), np.zeros(n),
                  sp.identity(n, format="csc"), np.array(qp.lb, dtype=float), np.array(qp.ub, dtype=float),
                  np.zeros((0, qp.nw)))


def soft_qp(qp) -> LoopQp:
    """Problem B: the soft-constrained QP (8) of 002 as mpc_cores.admm.problem gives it to OSQP (F z = b(w), the
    boxes, three rows per soft pair); only q = h(w) and the equality rows' b(w) change with w."""
    from mpc_cores.admm.problem import _osqp_data

    A, l, u = _osqp_data(qp, np.zeros(qp.nw), hard=False)
    neq = qp.F.shape[0]
    _, l1, u1 = _osqp_data(qp, np.ones(qp.nw), hard=False)
    assert np.array_equal(l1[neq:], l[neq:]) and np.array_equal(u1[neq:], u[neq:])
    H = qp.H.toarray() if sp.issparse(qp.H) else np.asarray(qp.H, dtype=float)
    return LoopQp(H, np.asarray(qp.h_w, dtype=float), np.asarray(qp.h0, dtype=float), sp.csc_matrix(A), l, u,
                  np.asarray(qp.b_w, dtype=float))


# ----------------------------------------------------------------------------------------- the solvers

class Osqp:
    """OSQP (ADMM, C library) set up once for the loop; each solve updates q(w) (and the equality rows' bounds b(w))
    and starts from the previous solution (warm_starting)."""
    module = "osqp"
    # info.run_time would add the set-up time to the first solve after the set-up
    timer = "info update_time + solve_time + polish_time"

    def __init__(self, lqp: LoopQp, name: str, settings: dict):
        import osqp

        self.name, self.lqp = name, lqp
        self.l, self.u = lqp.l.copy(), lqp.u.copy()
        self.solver = osqp.OSQP()
        self.solver.setup(P=sp.triu(sp.csc_matrix(lqp.H), format="csc"), q=lqp.q0.copy(), A=lqp.A, l=self.l,
                          u=self.u, verbose=False, **settings)
        st = self.solver.settings
        self.settings = ", ".join(f"{k} = {getattr(st, k)}" for k in (
            "eps_abs", "eps_rel", "polishing", "warm_starting", "check_termination", "adaptive_rho", "rho"))
        self.iters: list[int] = []

    def solve(self, w: np.ndarray) -> tuple[np.ndarray, float]:
        if self.lqp.neq:
            b = self.lqp.b(w)
            self.l[: len(b)] = b
            self.u[: len(b)] = b
            self.solver.update(q=self.lqp.q(w), l=self.l, u=self.u)
        else:
            self.solver.update(q=self.lqp.q(w))
        res = self.solver.solve(raise_error=False)
        i = res.info
        self.iters.append(i.iter)
        return res.x, i.update_time + i.solve_time + i.polish_time


class Daqp:
    """DAQP (dual active set, C library) on a QP with variable bounds and no equality rows, hot-started.

    Hot start: the workspace (daqp.Model) is set up once, factorising H; each step changes only the linear term
    (Model.update(f=q), which recomputes v = R^-T q and nothing else). The working set of the previous solve -- the
    constraints active at its solution, with the LDL' factors of their part of the dual Hessian -- stays in the
    workspace, so the next solve starts its active-set iterations from it instead of from the empty set: one
    iteration when the active set has not changed (DAQP's own hot start, not a primal or dual guess passed in)."""
    module = "daqp"
    timer = "info solve_time (the solve, not the update of q)"

    def __init__(self, lqp: LoopQp, name: str, settings: dict):
        import daqp

        _, x_l, x_u, G, h_l, h_u = lqp.parts()
        assert lqp.neq == 0, "DAQP is run here on QPs without equality rows (their b(w) would reset the working set)"
        self.name, self.lqp = name, lqp
        self.model = daqp.Model()
        if settings:
            self.model.settings = dict(self.model.settings, **settings)
        inf = 1e30                                   # DAQP_INF: no bound
        # DAQP keeps pointers into the arrays it is given: writable copies of its own
        ok, _ = self.model.setup(np.array(lqp.H, order="C"), np.zeros(lqp.n), np.array(G, order="C"),
                                 np.clip(np.concatenate([x_u, h_u]), -inf, inf),
                                 np.clip(np.concatenate([x_l, h_l]), -inf, inf))
        if ok < 0:
            raise RuntimeError(f"DAQP setup failed: exit flag {ok}")
        st = self.model.settings
        self.settings = (f"primal_tol = {st['primal_tol']:g}, dual_tol = {st['dual_tol']:g} (defaults), bounds as "
                         "simple bounds, working set kept between solves")
        self.iters: list[int] = []

    def solve(self, w: np.ndarray) -> tuple[np.ndarray, float]:
        self.model.update(f=self.lqp.q(w))
        x, _, flag, info = self.model.solve()
        if flag < 0:
            raise RuntimeError(f"DAQP failed: exit flag {flag}")
        self.iters.append(int(info["iterations"]))
        return x, info["solve_time"]


class _Piqp:
    """PIQP (proximal interior point, C++ library), set up once; each solve updates c = q(w) (and b(w)). An
    interior-point method: no warm start."""
    module = "piqp"
    # info.run_time would add the set-up time to the first solve after the set-up
    timer = "info update_time + solve_time"
    dense = True

    def __init__(self, lqp: LoopQp, name: str, settings: dict):
        import piqp

        E, x_l, x_u, G, h_l, h_u = lqp.parts()
        self.name, self.lqp = name, lqp
        self.solver = piqp.DenseSolver() if self.dense else piqp.SparseSolver()
        st = self.solver.settings
        st.verbose, st.compute_timings, st.num_threads = False, True, 1
        for k, v in settings.items():
            setattr(st, k, v)
        if self.dense:
            mat = np.asfortranarray
            P = mat(lqp.H)
        else:
            def mat(M):
                return sp.csc_matrix(M)
            P = sp.triu(sp.csc_matrix(lqp.H), format="csc")
        eq = dict(A=mat(E), b=np.zeros(lqp.neq)) if lqp.neq else {}
        ineq = dict(G=mat(G), h_l=h_l, h_u=h_u) if len(G) else {}
        self.solver.setup(P, lqp.q0.copy(), x_l=x_l, x_u=x_u, **eq, **ineq)
        self.settings = (f"eps_abs = {st.eps_abs:g}, eps_rel = {st.eps_rel:g} (defaults), num_threads = 1, "
                         "bounds as x_l / x_u")
        self.iters: list[int] = []

    def solve(self, w: np.ndarray) -> tuple[np.ndarray, float]:
        if self.lqp.neq:
            self.solver.update(c=self.lqp.q(w), b=self.lqp.b(w))
        else:
            self.solver.update(c=self.lqp.q(w))
        self.solver.solve()
        res = self.solver.result
        self.iters.append(int(res.info.iter))
        return np.array(res.x), res.info.update_time + res.info.solve_time


class PiqpDense(_Piqp):
    dense = True


class PiqpSparse(_Piqp):
    dense = False


class ProxqpDense:
    """ProxQP (proximal augmented Lagrangian, proxsuite, dense backend), set up once with the variable bounds as its
    box constraints; each solve updates g = q(w) (and b(w)) and starts from the previous primal and dual solution
    (initial_guess WARM_START_WITH_PREVIOUS_RESULT)."""
    module = "proxsuite"
    timer = "info.run_time (the update and the solve)"

    def __init__(self, lqp: LoopQp, name: str, settings: dict):
        from proxsuite import proxqp

        E, x_l, x_u, G, h_l, h_u = lqp.parts()
        self.name, self.lqp = name, lqp
        self.qp = proxqp.dense.QP(lqp.n, lqp.neq, len(G), True)
        st = self.qp.settings
        st.verbose, st.compute_timings = False, True
        st.initial_guess = proxqp.InitialGuess.WARM_START_WITH_PREVIOUS_RESULT
        for k, v in settings.items():
            setattr(st, k, v)
        self.qp.init(lqp.H, lqp.q0.copy(), E if lqp.neq else None, np.zeros(lqp.neq) if lqp.neq else None,
                     G if len(G) else None, h_l if len(G) else None, h_u if len(G) else None, x_l, x_u)
        # one solve at q0 in the set-up: the first warm start needs a previous result (without one, proxsuite 0.8
        # starts from uninitialised iterates)
        self.qp.solve()
        self.settings = (f"eps_abs = {st.eps_abs:g}, eps_rel = {st.eps_rel:g} (defaults), bounds as box "
                         "constraints, warm start with the previous result")
        self.iters: list[int] = []

    def solve(self, w: np.ndarray) -> tuple[np.ndarray, float]:
        if self.lqp.neq:
            self.qp.update(g=self.lqp.q(w), b=self.lqp.b(w))
        else:
            self.qp.update(g=self.lqp.q(w))
        self.qp.solve()
        res = self.qp.results
        self.iters.append(int(res.info.iter))
        return np.array(res.x), res.info.run_time * 1e-6           # proxsuite times in microseconds


_UNITS = {"ns": 1e-9, "µs": 1e-6, "us": 1e-6, "ms": 1e-3, "s": 1.0}


def _clarabel_timers(solver) -> dict[str, float]:
    """The top-level timers of a Clarabel solver in seconds ("setup", "solve", "post-process"), from its timer report
    (print_timers writes to the standard output from Rust: read through a temporary file on file descriptor 1);
    empty when there is no report."""
    import tempfile

    try:
        sys.stdout.flush()
        saved = os.dup(1)
    except (OSError, ValueError):
        return {}
    with tempfile.TemporaryFile() as f:
        os.dup2(f.fileno(), 1)
        try:
            solver.print_timers()
        finally:
            os.dup2(saved, 1)
            os.close(saved)
        f.seek(0)
        text = f.read().decode(errors="replace")
    return {m.group(1): float(m.group(2)) * _UNITS[m.group(3)]
            for m in re.finditer(r"^(\S[^:]*?)\s*:\s*([0-9.]+)\s*(ns|µs|us|ms|s)\s*$", text, re.MULTILINE)}


class Clarabel:
    """Clarabel (interior point, homogeneous embedding, Rust library), set up once: the equality rows as a zero cone,
    every finite bound (variable or row) as one nonnegative-cone row; each solve updates q(w) (and b(w)).

    Its solve_time is the sum of its top-level timers, where the set-up timer (the equilibration and the KKT
    initialisation at construction) stays on every later solve and the post-process timer adds up over the solves
    (clarabel 0.11): the own time here is solve_time less the set-up and less the post-processing of the solves
    before, both read from the solver's timer report after the wall clock of the solve has stopped (solve returns
    the own time as a function for that)."""
    module = "clarabel"
    timer = "solve_time less the set-up and the earlier solves' post-processing"

    def __init__(self, lqp: LoopQp, name: str, settings: dict):
        import clarabel

        E, x_l, x_u, G, h_l, h_u = lqp.parts()
        self.name, self.lqp = name, lqp
        n, I = lqp.n, np.eye(lqp.n)
        rows, rhs = [], []
        for M, hi, lo in ((I, x_u, x_l), (G, h_u, h_l)):
            up, dn = np.isfinite(hi), np.isfinite(lo)
            rows += [M[up], -M[dn]]
            rhs += [hi[up], -lo[dn]]
        Ain = sp.csc_matrix(np.vstack(rows))
        self.b = np.concatenate([np.zeros(lqp.neq)] + rhs)
        st = clarabel.DefaultSettings()
        st.verbose, st.max_threads = False, 1
        for k, v in settings.items():
            setattr(st, k, v)
        cones = ([clarabel.ZeroConeT(lqp.neq)] if lqp.neq else []) + [clarabel.NonnegativeConeT(Ain.shape[0])]
        self.solver = clarabel.DefaultSolver(sp.triu(sp.csc_matrix(lqp.H), format="csc"), lqp.q0.copy(),
                                             sp.vstack([sp.csc_matrix(E.reshape(-1, n)), Ain], format="csc"),
                                             self.b, cones, st)
        self.settings = (f"tol_gap_abs = {st.tol_gap_abs:g}, tol_feas = {st.tol_feas:g} (defaults), max_threads = 1, "
                         f"{Ain.shape[0]} inequality rows")
        self.iters: list[int] = []
        self.post = 0.0              # the post-process timer after the last solve

    def _own(self, total: float) -> float | None:
        t = _clarabel_timers(self.solver)
        if "setup" not in t:
            return None
        own = total - t["setup"] - self.post
        self.post = t.get("post-process", 0.0)
        return own

    def solve(self, w: np.ndarray):
        if self.lqp.neq:
            self.b[: self.lqp.neq] = self.lqp.b(w)
            self.solver.update(q=self.lqp.q(w), b=self.b)
        else:
            self.solver.update(q=self.lqp.q(w))
        sol = self.solver.solve()
        self.iters.append(int(sol.iterations))
        total = sol.solve_time
        return np.array(sol.x), lambda: self._own(total)


class Quadprog:
    """quadprog (Goldfarb-Idnani dual active set, Fortran), given R^-1 with H = R'R once (factorized=True), so a solve
    does not factorise H again; every finite bound is one row of C'z >= b. It keeps nothing between calls: each solve
    starts from the unconstrained minimum. No timer of its own."""
    module = "quadprog"
    timer = "n/a"

    def __init__(self, lqp: LoopQp, name: str, settings: dict):
        E, x_l, x_u, G, h_l, h_u = lqp.parts()
        self.name, self.lqp = name, lqp
        self.Rinv = np.linalg.inv(np.linalg.cholesky(lqp.H).T)
        I = np.eye(lqp.n)
        cols, rhs = [E], [np.zeros(lqp.neq)]
        for M, hi, lo in ((I, x_u, x_l), (G, h_u, h_l)):
            up, dn = np.isfinite(hi), np.isfinite(lo)
            cols += [-M[up], M[dn]]
            rhs += [-hi[up], lo[dn]]
        self.C = np.ascontiguousarray(np.vstack(cols).T)
        self.rhs = np.concatenate(rhs)
        self.settings = f"factorized (R^-1 given), {self.C.shape[1] - lqp.neq} inequality columns"
        self.iters: list[int] = []

    def solve(self, w: np.ndarray) -> tuple[np.ndarray, None]:
        import quadprog

        if self.lqp.neq:
            self.rhs[: self.lqp.neq] = self.lqp.b(w)
        x, _, _, it, _, _ = quadprog.solve_qp(self.Rinv, -self.lqp.q(w), self.C, self.rhs, self.lqp.neq, True)
        self.iters.append(int(it[0]))
        return x, None


class TinyMpc:
    """TinyMPC (ADMM on the MPC problem itself, Riccati-cached, single precision; the `tinympc` package built from
    its source) on the spec's model: N + 1 knot points, the input box, the references as steady-state targets
    (x_s, u_s) = (M_x r, M_u r) over the horizon. Its terminal cost is its own (the infinite-horizon Riccati cost of
    Q + rho I, R + rho I), so it solves a neighbour of the core's QP (the error column says how near). Set up once;
    each solve sets x0 and the references and starts from its previous iterates. No timer of its own."""
    module = "tinympc"
    timer = "n/a"

    def __init__(self, problem, name: str, settings: dict):
        import tinympc

        from mpc_cores.problem import steady_state_maps

        p = problem
        if not (np.allclose(p.Q, np.diag(np.diag(p.Q))) and np.allclose(p.R, np.diag(np.diag(p.R)))):
            raise RuntimeError("TinyMPC takes diagonal Q and R only")
        self.name, self.p = name, p
        self.Mx, self.Mu = steady_state_maps(p)
        self.solver = tinympc.TinyMPC()
        st = dict(settings)
        rho = st.pop("rho", 1.0)
        self.solver.setup(np.array(p.A, dtype=float), np.array(p.B, dtype=float), np.array(p.Q, dtype=float),
                          np.array(p.R, dtype=float), p.N + 1, rho=rho, u_min=np.asarray(p.umin, dtype=float),
                          u_max=np.asarray(p.umax, dtype=float), verbose=False, **st)
        s = self.solver.settings
        self.settings = (f"rho = {rho:g}, abs_pri_tol = {s.abs_pri_tol:g}, abs_dua_tol = {s.abs_dua_tol:g}, "
                         f"max_iter = {s.max_iter}, check_termination = {s.check_termination} (defaults), float32")
        self.iters: list[int] = []

    def solve(self, w: np.ndarray):
        p = self.p
        x, r = np.asarray(w[: p.nx], dtype=float), np.asarray(w[p.nx:], dtype=float)
        self.solver.set_x0(x)
        self.solver.set_x_ref(np.tile((self.Mx @ r)[:, None], (1, p.N + 1)))
        self.solver.set_u_ref(np.tile((self.Mu @ r)[:, None], (1, p.N)))
        sol = self.solver.solve()
        self.iters.append(int(self.solver._solver.solution.iter))
        return np.asarray(sol["controls"], dtype=float), None


# The one table: problem -> (name, class, settings) in report order. "box" is problem A (the FGM section), "soft"
# problem B (the ADMM section). OSQP comes first (the latency plots draw the first rows).
SOLVERS: dict[str, tuple] = {
    "box": (("OSQP default", Osqp, OSQP_DEFAULT), ("OSQP tuned", Osqp, OSQP_TUNED),
            ("DAQP hot start", Daqp, {}), ("PIQP dense", PiqpDense, {}), ("ProxQP dense", ProxqpDense, {}),
            ("Clarabel", Clarabel, {}), ("quadprog", Quadprog, {})),
    "soft": (("OSQP default", Osqp, OSQP_DEFAULT), ("OSQP tuned", Osqp, OSQP_TUNED_ADMM),
             ("PIQP sparse", PiqpSparse, {}), ("Clarabel", Clarabel, {})),
}


def installed(cls) -> bool:
    return importlib.util.find_spec(cls.module) is not None


def solver_makers(problem: str, lqp: LoopQp) -> tuple[list, list[str]]:
    """The makers of the installed solvers of `problem` on `lqp` (SOLVERS order), and the names of those whose
    package is missing."""
    rows = SOLVERS[problem]
    makers = [lambda c=c, nm=nm, st=st: c(lqp, nm, st) for nm, c, st in rows if installed(c)]
    return makers, [nm for nm, c, _ in rows if not installed(c)]


def versions() -> str:
    """'osqp 1.1.3, daqp 0.11.0, ...': the installed packages of the solvers of SOLVERS."""
    from importlib.metadata import PackageNotFoundError, version

    out = []
    for m in dict.fromkeys(c.module for rows in SOLVERS.values() for _, c, _ in rows):
        try:
            out.append(f"{m} {version(m)}")
        except PackageNotFoundError:
            pass
    return ", ".join(out)
