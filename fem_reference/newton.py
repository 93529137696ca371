"""Newton's method for energy minimisation, with positive-definiteness and lowest-mode checks.

The tangent is factorised by a supernodal sparse Cholesky (CHOLMOD, through cvxopt; its
fill-reducing ordering and symbolic factor are made once per sparsity pattern and reused along
the path, after a symmetric Jacobi scaling). The factorisation fails exactly when the matrix is
not positive definite, so an indefinite tangent is seen at no extra cost. Where the tangent is
not positive definite the step uses K + mu M (M the consistent mass matrix, mu raised until the
factor exists), so every step is a descent direction; a backtracking line search on the total
energy accepts it. The lowest eigenpair of K phi = omega M phi comes from shift-invert Lanczos
with the shift below it.
"""

from __future__ import annotations

import time
from collections import Counter
from dataclasses import dataclass, field
from typing import Callable, Protocol

import cvxopt
import cvxopt.cholmod
import numpy as np
import scipy.linalg
import scipy.sparse as sp
import scipy.sparse.linalg as sla

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
    """The matrix is not positive definite (indefinite, or singular to working precision)."""


@dataclass
class Factor:
    """Cholesky factor of a symmetric positive definite A."""

    solve: Callable[[np.ndarray], np.ndarray]
    n: int


@dataclass(eq=False)
class _Pattern:
    """One lower-triangular sparsity structure and CHOLMOD's symbolic factor of it."""

    indptr: np.ndarray  # the CSC structure of the matrices it factorises
    indices: np.ndarray
    lower: np.ndarray  # mask of their lower-triangle entries, in CSC (column-major) order
    matrix: object  # cvxopt.spmatrix on these entries, its values overwritten by each matrix
    symbolic: object | None = None  # cvxopt.cholmod factor, overwritten by each numeric factor

    def matches(self, A: sp.csc_matrix) -> bool:
        return np.array_equal(self.indptr, A.indptr) and np.array_equal(self.indices, A.indices)


class _Symbolic:
    """Symbolic factors by matrix structure: a Newton path factorises matrices of one structure
    hundreds of times, and the fill-reducing ordering and supernodes are made once.

    The symbolic factor is that of the matrix's own structure, never of a structure another
    problem left behind: the ordering sets the order of the factor's sums, so a factor made for
    a union of the structures seen so far would make a state's last bits depend on what the
    process solved before (measured: the quick validation's FEM r0 at 1.3 differed in the 14th
    digit between a worker process and a process that had solved r1 first). Entries of a
    tangent that happen to be zero drop out of scipy's sums, so a path sees a few structures
    (the flat state's, the curled state's, those with slack film elements, the mass matrix's):
    the most recent :data:`PER_SIZE` of each size are kept, :data:`SIZE` in all, which bounds
    the memory of the factors of a fine mesh. CHOLMOD writes each numeric factor over the
    symbolic one: a stamp counts the factorisations, so that a stale factor is refused instead
    of silently used.
    """

    SIZE = 8
    PER_SIZE = 2

    def __init__(self) -> None:
        self._patterns: list[_Pattern] = []  # most recent last
        self._stamps: dict[int, int] = {}
        self.counts: Counter[int] = Counter()  # numeric factorisations by size, failed ones too

    def factorise(self, A: sp.csc_matrix) -> tuple[_Pattern, int]:
        """Cholesky-factorise the symmetric A (CSC, sorted indices); raises ArithmeticError if
        not positive definite."""
        n = A.shape[0]
        pattern = next((p for p in reversed(self._patterns) if p.matches(A)), None)
        if pattern is None:
            pattern = self._new_pattern(A)
        else:
            self._patterns.remove(pattern)
        self._patterns.append(pattern)
        while sum(p.indptr.size == n + 1 for p in self._patterns) > self.PER_SIZE:
            self._forget(next(p for p in self._patterns if p.indptr.size == n + 1))
        while len(self._patterns) > self.SIZE:
            self._forget(self._patterns[0])
        L = pattern.matrix
        L.V = cvxopt.matrix(A.data[pattern.lower])  # CSC order is the column-major order of L's values
        stamp = self._stamps.get(id(pattern), 0) + 1
        self._stamps[id(pattern)] = stamp  # the old factor is gone whether or not this one exists
        if pattern.symbolic is None:
            pattern.symbolic = cvxopt.cholmod.symbolic(L, uplo="L")
        self.counts[n] += 1
        cvxopt.cholmod.numeric(L, pattern.symbolic)
        return pattern, stamp

    def _forget(self, pattern: _Pattern) -> None:
        self._patterns.remove(pattern)
        self._stamps.pop(id(pattern), None)

    @staticmethod
    def _new_pattern(A: sp.csc_matrix) -> _Pattern:
        n = A.shape[0]
        cols = np.repeat(np.arange(n, dtype=np.int64), np.diff(A.indptr))
        lower = A.indices >= cols
        ones = cvxopt.matrix(1.0, (int(lower.sum()), 1))
        rows = cvxopt.matrix(A.indices[lower].astype(np.int64))
        matrix = cvxopt.spmatrix(ones, rows, cvxopt.matrix(cols[lower]), (n, n))
        return _Pattern(A.indptr.copy(), A.indices.copy(), lower, matrix)

    def current(self, pattern: _Pattern, stamp: int) -> bool:
        return self._stamps.get(id(pattern)) == stamp


_SYMBOLIC = _Symbolic()
cvxopt.cholmod.options["supernodal"] = 2  # supernodal (BLAS 3): 10x QDLDL's simplicial LDL^T at 115 k DOFs


def factor(A: sp.spmatrix) -> Factor:
    """Cholesky factor of a symmetric positive definite sparse matrix (CHOLMOD, supernodal, in a
    fill-reducing order, after a symmetric Jacobi scaling).

    The factor is valid until the next call on a matrix of the same size.

    Raises
    ------
    NotFactorizable
        If A is not positive definite (to working precision).
    """
    A = sp.csc_matrix(A)
    d = A.diagonal()
    if np.any(d <= 0.0) or not np.all(np.isfinite(A.data)):  # a non-positive diagonal: not definite
        raise NotFactorizable("non-positive or non-finite diagonal entry")
    s = 1.0 / np.sqrt(d)
    scaled = A.copy()
    scaled.sort_indices()
    scaled.data *= s[scaled.indices] * np.repeat(s, np.diff(scaled.indptr))
    try:
        pattern, stamp = _SYMBOLIC.factorise(scaled)
    except ArithmeticError as exc:  # CHOLMOD met a non-positive pivot
        raise NotFactorizable(f"not positive definite (pivot {exc})") from None

    def solve(b: np.ndarray) -> np.ndarray:
        if not _SYMBOLIC.current(pattern, stamp):
            raise RuntimeError("this factor was overwritten by a later one of the same size")
        x = cvxopt.matrix(s * b)
        cvxopt.cholmod.solve(pattern.symbolic, x)
        return s * np.asarray(x).ravel()

    return Factor(solve, A.shape[0])


def factorisation_count(size: int) -> int:
    """Numeric factorisations of size x size matrices so far in this process (failed included)."""
    return _SYMBOLIC.counts[size]


def is_positive_definite(A: sp.spmatrix) -> bool:
    """Whether a symmetric sparse matrix is positive definite (its Cholesky factor exists)."""
    try:
        factor(A)
    except NotFactorizable:
        return False
    return True


def positive_shift(K: sp.spmatrix, M: sp.spmatrix, start: float, resume: float = 0.0
                   ) -> tuple[float, Factor]:
    """Smallest tried mu >= 0 (0 first, then start * 10^k from ``resume`` on) with K + mu M
    positive definite, and its factor; mu = 0 says K itself is positive definite.

    ``resume``: skip the rungs of the ladder above zero below it (a Newton solve passes a tenth
    of its previous shift: the curvature it has to overcome changes little from one step to the
    next, and each rung is a factorisation).
    """
    mu = 0.0
    rung = start * 10.0 ** max(0, int(np.floor(np.log10(resume / start) + 1e-9))) if resume > start else start
    for _ in range(40):
        try:
            return mu, factor(K + mu * M if mu > 0 else K)
        except NotFactorizable:
            mu = rung if mu == 0.0 else 10.0 * mu
    raise NotFactorizable("no shift made the tangent positive definite")


def shift_scale(K: sp.spmatrix, M: sp.spmatrix) -> float:
    """A small reference shift (N/mm^3): 1e-6 of the median stiffness-to-mass diagonal ratio."""
    ratio = np.abs(K.diagonal()) / np.maximum(M.diagonal(), 1e-300)
    return 1e-6 * float(np.median(ratio[ratio > 0])) if np.any(ratio > 0) else 1e-6


def lowest_mode(K: sp.spmatrix, M: sp.spmatrix) -> tuple[float, np.ndarray]:
    """Lowest eigenpair of K phi = omega M phi (omega in N/mm^3 for a mass per unit area)."""
    start = shift_scale(K, M)
    mu, f = positive_shift(K, M, start)
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
    positive_definite: bool | None = None  # the tangent at the returned point (None: not factorised)
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
            return NewtonResult(y, False, "not_finite", it, r, history, ev.total, None, shifted,
                                int(nodes[0]) if nodes.size else -1)
        Kff = ev.tangent[free][:, free].tocsc()
        if start_shift is None:
            start_shift = shift_scale(Kff, Mff)
        if r < tol or (r < 1e3 * tol and it > 0 and last_step < round_off_step):
            return NewtonResult(y, True, "converged", it, r, history, ev.total, is_positive_definite(Kff),
                                shifted)
        if it == max_iterations:
            break
        if deadline is not None and time.perf_counter() > deadline:
            return NewtonResult(y, False, "time_limit", it, r, history, ev.total, None, shifted)
        try:
            mu, f = positive_shift(Kff, Mff, start_shift, 0.1 * mu)
        except NotFactorizable:
            return NewtonResult(y, False, "diverged", it, r, history, ev.total, None, shifted)
        if mu > 0 and r < saddle:
            # closing in on a saddle: a shifted Newton creeps along its unstable direction
            return NewtonResult(y, False, "saddle", it, r, history, ev.total, False, shifted)
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
            return NewtonResult(y, False, "line_search", it, r, history, e0, None, shifted)
        y = trial
        last_step = alpha * float(np.abs(d).max())
    return NewtonResult(y, False, "max_iterations", max_iterations, history[-1], history,
                        ev.total, None, shifted)
