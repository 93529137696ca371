"""Newton's method for energy minimisation, with inertia and lowest-mode checks.

The tangent is factorised as L D L^T (QDLDL, diagonal pivots in an AMD order kept per sparsity
pattern, after a symmetric Jacobi scaling); by Sylvester's law the signs of D give the number of negative
eigenvalues, so an indefinite tangent is seen at no extra cost. Where the tangent is not positive
definite the step uses K + mu M (M the consistent mass matrix, mu raised until the factor is
positive), so every step is a descent direction; a backtracking line search on the total energy
accepts it. The lowest eigenpair of K phi = omega M phi comes from shift-invert Lanczos with the
shift below it.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable, Protocol

import numpy as np
import scipy.linalg
import scipy.sparse as sp
import scipy.sparse.linalg as sla
import qdldl

DENSE_EIGEN_LIMIT = 4000
"""Free DOFs up to which a dense eigensolver is the last resort for the lowest mode (0.6 s at
1800 DOFs; the cost grows as the cube)."""


class Evaluation(Protocol):
    total: float
    gradient: np.ndarray
    tangent: sp.csr_matrix | None
    force_scale: float


class Problem(Protocol):
    """What Newton needs: DOF count, free DOFs, a mass matrix, energy and derivatives."""

    n_dofs: int
    free: np.ndarray
    mass: sp.csr_matrix

    def energy(self, y: np.ndarray) -> float: ...

    def evaluate(self, y: np.ndarray, order: int = 2) -> Evaluation: ...


# ----------------------------------------------------------------------------- factorisation


class NotFactorizable(RuntimeError):
    """The matrix is singular to working precision."""


@dataclass
class Factor:
    """Symmetric factorisation of A with its inertia (number of negative pivots)."""

    solve: Callable[[np.ndarray], np.ndarray]
    negative: int
    n: int


@dataclass
class _Pattern:
    """A fixed upper-triangular sparsity pattern (CSC) and the QDLDL solver made on it."""

    keys: np.ndarray  # col * n + row of its entries, ascending (CSC order)
    indptr: np.ndarray
    indices: np.ndarray
    solver: qdldl.Solver | None = None


class _Symbolic:
    """QDLDL solvers by matrix size: a Newton path factorises matrices of one structure hundreds
    of times, and the fill-reducing ordering and elimination tree are made once.

    Each size keeps one upper-triangular pattern, the union of the structures seen (entries of
    a tangent that happen to be zero drop out of scipy's sums, and the mass matrix has fewer);
    a matrix is scattered into it, and only an entry outside it makes a new symbolic factor.
    A solver holds the latest numeric factor only: its stamp counts the factorisations, so
    that a stale factor is refused instead of silently used.
    """

    SIZE = 4

    def __init__(self) -> None:
        self._patterns: dict[int, _Pattern] = {}
        self._stamps: dict[int, int] = {}

    def factorise(self, A: sp.csc_matrix) -> tuple[qdldl.Solver, int]:
        """Factorise the symmetric A (CSC with sorted indices)."""
        n = A.shape[0]
        cols = np.repeat(np.arange(n, dtype=np.int64), np.diff(A.indptr))
        upper = A.indices <= cols
        keys = cols[upper] * n + A.indices[upper]
        values = A.data[upper]
        pattern = self._patterns.pop(n, None)
        if pattern is None:
            pattern = self._new_pattern(keys, n)
        pos = np.minimum(np.searchsorted(pattern.keys, keys), pattern.keys.size - 1)
        if not np.array_equal(pattern.keys[pos], keys):  # an entry outside: a new symbolic factor
            self._stamps.pop(id(pattern.solver), None)
            pattern = self._new_pattern(np.union1d(pattern.keys, keys), n)
            pos = np.searchsorted(pattern.keys, keys)
        data = np.zeros(pattern.keys.size)
        data[pos] = values
        U = sp.csc_matrix((data, pattern.indices, pattern.indptr), shape=(n, n))
        if pattern.solver is None:
            pattern.solver = qdldl.Solver(U, upper=True)
        else:
            pattern.solver.update(U, upper=True)
        self._patterns[n] = pattern  # most recent last
        if len(self._patterns) > self.SIZE:
            self._stamps.pop(id(self._patterns.pop(next(iter(self._patterns))).solver), None)
        stamp = self._stamps.get(id(pattern.solver), 0) + 1
        self._stamps[id(pattern.solver)] = stamp
        return pattern.solver, stamp

    @staticmethod
    def _new_pattern(keys: np.ndarray, n: int) -> _Pattern:
        cols, rows = np.divmod(keys, n)
        indptr = np.searchsorted(cols, np.arange(n + 1)).astype(np.int64)
        return _Pattern(keys, indptr, rows.astype(np.int64))

    def current(self, solver: qdldl.Solver, stamp: int) -> bool:
        return self._stamps.get(id(solver)) == stamp


_SYMBOLIC = _Symbolic()


def factor(A: sp.spmatrix) -> Factor:
    """L D L^T of a symmetric sparse matrix (QDLDL: diagonal pivots in a fill-reducing order,
    after a symmetric Jacobi scaling), with the count of negative eigenvalues (Sylvester).

    The factor is valid until the next call on a matrix of the same sparsity pattern.

    Raises
    ------
    NotFactorizable
        If A is singular (a zero pivot) or has a zero on its diagonal.
    """
    A = sp.csc_matrix(A)
    A.sort_indices()
    d = np.abs(A.diagonal())
    if np.any(d == 0.0):  # no diagonal pivot there: the inertia is out of reach
        raise NotFactorizable("zero diagonal entry")
    s = 1.0 / np.sqrt(d)
    scaled = A.copy()
    scaled.data *= s[scaled.indices] * np.repeat(s, np.diff(scaled.indptr))
    try:
        solver, stamp = _SYMBOLIC.factorise(scaled)
    except RuntimeError as exc:  # a zero pivot
        raise NotFactorizable(str(exc)) from None
    pivots = solver.factors()[1]
    if not np.all(np.isfinite(pivots)) or np.any(pivots == 0.0):
        raise NotFactorizable("zero or non-finite pivot")

    def solve(b: np.ndarray) -> np.ndarray:
        if not _SYMBOLIC.current(solver, stamp):
            raise RuntimeError("this factor was overwritten by a later one of the same pattern")
        return s * solver.solve(s * b)

    return Factor(solve, int(np.count_nonzero(pivots < 0)), A.shape[0])


def positive_shift(K: sp.spmatrix, M: sp.spmatrix, start: float, resume: float = 0.0
                   ) -> tuple[float, Factor, int]:
    """Smallest tried mu >= 0 (0, then start * 10^k from ``resume`` on) with K + mu M positive
    definite, its factor, and the number of negative eigenvalues of K itself (-1 if K is
    singular).

    ``resume``: skip the rungs of the ladder below it (a Newton solve passes a tenth of its
    previous shift: the curvature it has to overcome changes little from one step to the next,
    and each rung is a factorisation).
    """
    mu, negative = 0.0, -1
    rung = start * 10.0 ** max(0, int(np.floor(np.log10(resume / start) + 1e-9))) if resume > start else start
    for _ in range(40):
        try:
            f = factor(K + mu * M if mu > 0 else K)
            if mu == 0.0:
                negative = f.negative
            if f.negative == 0:
                return mu, f, negative
        except NotFactorizable:
            pass
        mu = rung if mu == 0.0 else 10.0 * mu
    raise NotFactorizable("no shift made the tangent positive definite")


def shift_scale(K: sp.spmatrix, M: sp.spmatrix) -> float:
    """A small reference shift (N/mm^3): 1e-6 of the median stiffness-to-mass diagonal ratio."""
    ratio = np.abs(K.diagonal()) / np.maximum(M.diagonal(), 1e-300)
    return 1e-6 * float(np.median(ratio[ratio > 0])) if np.any(ratio > 0) else 1e-6


def lowest_mode(K: sp.spmatrix, M: sp.spmatrix) -> tuple[float, np.ndarray]:
    """Lowest eigenpair of K phi = omega M phi (omega in N/mm^3 for a mass per unit area)."""
    start = shift_scale(K, M)
    mu, f, _ = positive_shift(K, M, start)
    sigma = -max(mu, start)
    if mu < -sigma:  # refactor at the shift actually used
        f = factor(K - sigma * M)
    op = sla.LinearOperator(K.shape, matvec=f.solve, dtype=float)
    v0 = np.random.default_rng(0).standard_normal(K.shape[0])
    # A slack film has a cluster of exact zero modes (one per free slack node direction;
    # measured 25 at lambda 1.12 with a 100x softer frame): ARPACK finds the lowest only with
    # more Lanczos vectors than the cluster holds, and stalls for minutes with fewer.
    n = K.shape[0]
    for ncv, restarts in ((min(n, 40), 50), (min(n, 160), 300)):
        try:
            w, v = sla.eigsh(K, k=1, M=M, sigma=sigma, which="LM", OPinv=op, v0=v0, ncv=ncv, maxiter=restarts)
            return float(w[0]), v[:, 0]
        except sla.ArpackNoConvergence as exc:
            failure = exc
    if n <= DENSE_EIGEN_LIMIT:
        w, v = scipy.linalg.eigh(K.toarray(), M.toarray(), subset_by_index=[0, 0])
        return float(w[0]), v[:, 0]
    raise NotFactorizable(f"the lowest eigenvalue of the tangent did not converge ({failure})")


# ----------------------------------------------------------------------------- Newton


@dataclass
class NewtonResult:
    """Outcome of one Newton solve."""

    y: np.ndarray
    converged: bool
    status: str  # 'converged', 'saddle', 'max_iterations', 'line_search', 'diverged', 'not_finite', 'time_limit'
    iterations: int
    residual: float
    history: list[float] = field(default_factory=list)
    energy: float = float("nan")
    negative_pivots: int = -1  # of the tangent at the returned point (-1: not factorised)
    shifted_steps: int = 0
    bad_node: int = -1  # 'not_finite': the first node with a non-finite force or position


def residual_of(ev: Evaluation, free: np.ndarray) -> float:
    """Largest free nodal force component / the problem's force scale."""
    g = ev.gradient[free]
    return float(np.max(np.abs(g)) / ev.force_scale) if g.size else 0.0


def newton(problem: Problem, y0: np.ndarray, tol: float = 1e-10, max_iterations: int = 40,
           saddle: float = 0.0, deadline: float | None = None) -> NewtonResult:
    """Minimise ``problem``'s energy from ``y0`` over its free DOFs.

    Converged when the largest free force component is below ``tol`` times the force scale (or
    below 1000 ``tol`` once the step is at round-off, 1e-12 of the model size). With ``saddle`` > 0 it stops (status 'saddle') when the residual is below ``saddle`` while
    the tangent is indefinite, so that the caller can step off along the unstable mode. Past
    ``deadline`` (a ``time.perf_counter()`` value) it stops with status 'time_limit'.
    """
    free = problem.free
    Mff = problem.mass[free][:, free].tocsc()
    nodes = y0.reshape(-1, 3)
    # a step this small is round-off: stiff frames put a floor under the relative residual
    round_off_step = 1e-12 * float(np.ptp(nodes, axis=0).max() or 1.0)
    y = y0.copy()
    history: list[float] = []
    shifted = 0
    start_shift = None
    mu = 0.0
    last_step = np.inf
    for it in range(max_iterations + 1):
        ev = problem.evaluate(y, 2)
        r = residual_of(ev, free)
        history.append(r)
        if not np.isfinite(r) or not np.isfinite(ev.total):
            nodes = np.flatnonzero(~np.isfinite(ev.gradient.reshape(-1, 3)).all(axis=1)
                                   | ~np.isfinite(y.reshape(-1, 3)).all(axis=1))
            return NewtonResult(y, False, "not_finite", it, r, history, ev.total, -1, shifted,
                                int(nodes[0]) if nodes.size else -1)
        Kff = ev.tangent[free][:, free].tocsc()
        if start_shift is None:
            start_shift = shift_scale(Kff, Mff)
        if r < tol or (r < 1e3 * tol and it > 0 and last_step < round_off_step):
            try:
                neg = factor(Kff).negative
            except NotFactorizable:
                neg = -1
            return NewtonResult(y, True, "converged", it, r, history, ev.total, neg, shifted)
        if it == max_iterations:
            break
        if deadline is not None and time.perf_counter() > deadline:
            return NewtonResult(y, False, "time_limit", it, r, history, ev.total, -1, shifted)
        try:
            mu, f, negative = positive_shift(Kff, Mff, start_shift, 0.1 * mu)
        except NotFactorizable:
            return NewtonResult(y, False, "diverged", it, r, history, ev.total, -1, shifted)
        if negative != 0 and r < saddle:
            # closing in on a saddle: a shifted Newton creeps along its unstable direction
            return NewtonResult(y, False, "saddle", it, r, history, ev.total, negative, shifted)
        shifted += mu > 0
        g = ev.gradient[free]
        d = -f.solve(g)
        slope = float(g @ d)
        alpha, e0 = 1.0, ev.total
        slack = 1e-12 * max(abs(e0), 1e-30)
        for _ in range(40):
            trial = y.copy()
            trial[free] += alpha * d
            e = problem.energy(trial)
            if np.isfinite(e) and e <= e0 + 1e-4 * alpha * slope + slack:
                break
            alpha *= 0.5
        else:
            return NewtonResult(y, False, "line_search", it, r, history, e0, -1, shifted)
        y = trial
        last_step = alpha * float(np.abs(d).max())
    return NewtonResult(y, False, "max_iterations", max_iterations, history[-1], history,
                        ev.total, -1, shifted)
