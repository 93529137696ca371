"""Is a DR equilibrium stable? The lowest mode of its stiffness, and the step off a saddle.

DR settles wherever the residual vanishes, and the flat pre-stretched DEMES is such a place:
an equilibrium whose lowest mode (the curl) has a negative stiffness once the pre-stretch
passes the buckling load. A fast relaxation (the frame mass) reaches it before that mode has
grown. The test is the generalised eigenproblem K v = w M v on the free DOFs, with K the
stiffness (central differences of the exact gradient, never assembled) and M the run's own
masses (so w <= 1 for f = 2, and the masses precondition the search): w < -:data:`NEUTRAL`
is a saddle, which :func:`dr.saddles.off_saddles` leaves along that mode, as the FEM's
continuation does.
"""

from __future__ import annotations

import copy
from typing import Callable, NamedTuple

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import ArpackNoConvergence, LinearOperator, cg, eigsh, splu

from . import dielectric, hessian
from .kernels import Packed, energy, gradient
from .masses import masses_at

NEUTRAL = 1e-6
"""Generalised eigenvalues w above minus this count as zero (slack film, round-off of the
central differences): w is dimensionless, about 1 for the stiffest mode."""

ROUND_OFF = 1e-11
"""Generalised eigenvalues w above minus this are zero to the round-off of the central
differences (the matrix-free K u's noise, about 1e-11 of the stiffest mode): a node whose
triangles are all slack has such a mode, along which the energy does not change at all."""

FLOOR = 1e-3
"""The node blocks get this fraction of their median diagonal added: a slack film node's mass
is a sliver of its stiffness in the slack direction, and there the central differences' noise
over the sliver would read as a large negative w. Any SPD metric gives the eigenvalues the same
signs (Sylvester's law of inertia)."""

MODE_TOLERANCE = 1e-6
"""Relative accuracy of the lowest eigenvalue (ARPACK's ``tol``)."""

SPECTRUM_KRYLOV = 60
"""Lanczos vectors kept for the ends of the spectrum (ARPACK's ``ncv``)."""

MODE_KRYLOV = 40
"""Lanczos vectors kept for the lowest mode (ARPACK's ``ncv``): 40 against ARPACK's 20 halved
the applications of K on a curled 581-node rectangle (1461 -> 681)."""

MODE_ITERATIONS = 2000
"""Largest number of Lanczos restarts for the lowest mode."""

NEWTON_RTOL = 1e-10
"""Relative residual to which the Newton step K d = r is solved."""

NEWTON_CG_ITERATIONS = 200
"""Largest number of conjugate-gradient iterations for the Newton step before K is factorised
instead (the factor of K - s M makes it a few on a stable state: the preconditioned spectrum
is w / (w - s), 1 but for the modes softer than |s|)."""

MODE_DESCENT_STEPS = 20
"""Largest number of preconditioned descent steps that take a saddle's mode from the assembled
K to the matrix-free one (two to five reach the differences' noise on the octagon)."""

SHIFT_INVERT_MODES = 3
"""Eigenpairs the second shift-invert search finds (the lowest of them is kept): more than one,
since the soft end of a DEMES's spectrum comes in near pairs."""

BELOW = 1e-3
"""The lowest eigenvalue found is checked by the inertia of K - w' M at w' this fraction of
its size (at least :data:`NEUTRAL`) below it."""

MAX_DIFFERENCES = 300
"""K is assembled only where it takes at most this many central differences (3 per node
group, :mod:`dr.hessian`); else the search is Lanczos on C, whose checks took 100-3,800
products on the gallery's scenes and about 300 on the paper's. A clustered net's cable ties a
whole row of nodes together: 67 groups on 14 divisions, 342 on 28, 1,169 on 56 (7,000
gradients a check, against about 600 for Lanczos)."""

LOWEST_SHIFT = -10.0
"""The lowest shift the inertia test tries: every eigenvalue of K v = w M v is above about -1
where the masses bound the stiffness (f = 2)."""


class Mode(NamedTuple):
    """The lowest eigenpair of K v = w M v at a state."""

    eigenvalue: float  # w = v^T K v / v^T M v (the masses' scale: the stiffest mode is about 1)
    shape: np.ndarray  # (n, 3), the largest nodal displacement 1; fixed DOFs 0
    iterations: int  # applications of K (two gradients each)
    found: bool  # converged to MODE_TOLERANCE
    stiffness: float  # its Rayleigh quotient v^T K v / v^T v, N/mm
    per_area: float  # v^T K v / v^T A v, A the nodal film areas (flat), N/mm^3: the FEM's measure
    newton_step: np.ndarray | None = None  # (n, 3) mm, K^-1 r: where K is definite, the step to the equilibrium


def potential_energy(X: np.ndarray, P: Packed, loads: np.ndarray) -> float:
    """Strain energy plus the dielectric's (electrical) part, less the loads' work from the
    origin, N mm: the energy DR minimises. X: (n_total, 3) mm."""
    return float(sum(energy(X, P))) + float(dielectric.energy(X, P)) - float(np.sum(loads * X[: P.n]))


class _Operator(NamedTuple):
    """C = M^-1/2 K M^-T/2 on the free DOFs of a state, and the maps it is built from."""

    C: LinearOperator
    free: np.ndarray  # (m,) the DOFs C acts on, of the 3n
    to_displacement: Callable[[np.ndarray], np.ndarray]  # y (m,) -> u = M^-T/2 y (3n,), zero where held
    to_scaled: Callable[[np.ndarray], np.ndarray]  # r (3n,) -> M^-1/2 r (m,): a residual as C sees it
    stiffness: Callable[[np.ndarray], np.ndarray]  # u (3n,) -> K u (3n,), N/mm
    applications: list[int]  # [applications of C so far]
    mass: sp.csr_matrix  # M (3n, 3n), the masses C is scaled by
    assembled: Callable[[], tuple[sp.csr_matrix, int] | None]  # () -> K (3n, 3n) N/mm, gradient pairs it took; None: too dear


def _operator(model, x: np.ndarray, masses: str) -> _Operator:
    P0 = model.pack()
    n = P0.n
    X = np.zeros((P0.n_total, 3))
    X[:n] = x
    built = masses_at(model, P0, X.copy(), masses, 2.0)
    movable = (~model.fixed).reshape(-1)
    free = np.flatnonzero(movable)
    h = 1e-6 * max(float(np.ptp(x, axis=0).max()), 1e-9)
    G, no_blocks = np.zeros_like(X), np.zeros((0, 6))

    def stiffness(d: np.ndarray) -> np.ndarray:
        """K d on all DOFs (d zero at held ones), by central differences moving no node more
        than h: the differences stay linear however large d is."""
        step = h / max(float(np.abs(d).max()), 1e-300)
        out = []
        for sign in (1.0, -1.0):
            X[:n] = x + sign * step * d.reshape(n, 3)
            gradient(X, P0, G, no_blocks)
            out.append(G[:n].reshape(-1).copy())
        return (out[0] - out[1]) / (2.0 * step)

    half, half_t, mass = _mass_halves(built, n)
    applications = [0]

    def to_displacement(y: np.ndarray) -> np.ndarray:
        u = np.zeros(3 * n)
        u[free] = y
        return half_t(u) * movable

    def to_scaled(r: np.ndarray) -> np.ndarray:
        return half(r)[free]

    def C(y: np.ndarray) -> np.ndarray:
        applications[0] += 1
        return to_scaled(stiffness(to_displacement(y)))

    def assembled() -> tuple[sp.csr_matrix, int] | None:
        held = model.fixed.reshape(n, 3)
        pattern = hessian.pattern(P0, (~held).any(axis=1))
        if 3 * (int(pattern.colour.max(initial=-1)) + 1) > MAX_DIFFERENCES:
            return None
        return hessian.stiffness_matrix(P0, x, ~held, pattern, h)

    m = free.size
    return _Operator(LinearOperator((m, m), matvec=C, dtype=float), free, to_displacement, to_scaled, stiffness, applications,
                     mass, assembled)


def _shape(u: np.ndarray, n: int) -> np.ndarray:
    return u.reshape(n, 3) / max(float(np.linalg.norm(u.reshape(n, 3), axis=1).max()), 1e-300)


def lowest_mode(model, x: np.ndarray, *, masses: str = "frame", guess: np.ndarray | None = None) -> Mode:
    """The lowest mode of ``model`` at positions ``x`` (n, 3) mm, against the masses
    ``masses`` ('frame', 'tensor' or 'scalar') that :func:`dr.relax` would use there (f = 2).
    ``guess`` (n, 3): a shape to start the search from (e.g. the scene's lift).

    K is assembled (:mod:`dr.hessian`) and the lowest eigenvalue bracketed by the inertia of
    K - s M (:func:`_below`); shift-invert Lanczos at the bracket's lower end then finds it in
    a few steps, where Lanczos on C = M^-1/2 K M^-T/2 alone needed hundreds to thousands of
    products (the soft end of the spectrum is clustered near 0). Where the inertia cannot be
    read (a zero pivot) or K would take more than :data:`MAX_DIFFERENCES` differences to
    assemble (a clustered net on a fine mesh), Lanczos on C, whose spectrum lies in about
    [-1, 1] because the masses bound the stiffness, is the search."""
    n = model.n
    op = _operator(model, x, masses)
    m = op.free.size
    start = np.ones(m) if guess is None else np.asarray(guess, dtype=float).reshape(-1)[op.free] + 1e-3
    found, u, K, factor = _by_inertia(op, start)
    Ku = op.stiffness(u) if u is not None else None
    if u is not None and u @ Ku < 0.0:
        # a saddle's mode is the one the step off it follows: that of the matrix-free K the
        # step's slopes use (on a hexagon's weak saddle, w = -1.2e-7, the assembled K's mode,
        # cos 0.99998 to it, led five steps back onto the saddle, the matrix-free one off it in
        # one), found from the assembled one (:func:`_matrix_free_mode`)
        u = _matrix_free_mode(op, u, Ku, factor)
        Ku = op.stiffness(u)
    if u is None:
        try:
            _, v = eigsh(op.C, k=1, which="SA", tol=MODE_TOLERANCE, v0=start, ncv=min(m, MODE_KRYLOV),
                         maxiter=MODE_ITERATIONS)
            found = True
        except ArpackNoConvergence as stop:
            if not len(stop.eigenvalues):
                return Mode(float("nan"), np.zeros((n, 3)), op.applications[0], False, float("nan"), float("nan"))
            v, found = stop.eigenvectors, False
        u = op.to_displacement(v[:, 0] / np.linalg.norm(v[:, 0]))  # u^T M u = 1
        Ku = op.stiffness(u)
    area = np.repeat(film_areas(model), 3)
    # the Rayleigh quotients of the mode itself: where K is not smooth (a cable at exactly its
    # rest length, tension-only) the Ritz value of a symmetric solver need not be one
    w = float(u @ Ku)
    return Mode(w, _shape(u, n), op.applications[0] + 1, found, float(u @ Ku / (u @ u)),
                float(u @ Ku / (u @ (area * u))) if area.any() else float("nan"),
                _newton_step(model, x, K, op.free, factor) if K is not None and w > 0.0 else None)


def _matrix_free_mode(op: _Operator, u: np.ndarray, Ku: np.ndarray, factor) -> np.ndarray:
    """The lowest mode of the matrix-free K (3n,), u^T M u = 1, from ``u``, the assembled K's
    (``Ku``: the matrix-free K u):
    preconditioned steepest descent of the Rayleigh quotient (each step the best vector of the
    plane of the mode and its residual turned by ``factor``, the assembled K - s M's, definite),
    until the residual (as C sees it) stops halving: the two K differ by the differences' noise,
    so a few steps take it from the assembled K's mode down to that noise (from 2e-4 to 8e-7 in
    four steps on the octagon), where Lanczos on C took hundreds to thousands of products (1.5 s
    a check there). scipy's LOBPCG gets there too, then leaves it in its closing Rayleigh-Ritz
    step (4e-11 -> 2e-6: the differences are not exactly symmetric)."""
    f = op.free
    M = op.mass[f][:, f].tocsr()

    def K(v: np.ndarray) -> np.ndarray:
        full = np.zeros(op.mass.shape[0])
        full[f] = v
        op.applications[0] += 1
        return op.stiffness(full)[f]

    v, Kv = u[f].copy(), Ku[f]
    best, kept = np.inf, v
    for _ in range(MODE_DESCENT_STEPS):
        Mv = M @ v
        residual = Kv - (v @ Kv) * Mv
        full = np.zeros(op.mass.shape[0])
        full[f] = residual
        size = float(np.linalg.norm(op.to_scaled(full)))
        if size > 0.5 * best:
            break
        best, kept = size, v
        p = factor.solve(residual)
        p -= (Mv @ p) * v  # M-orthogonal to v, M-unit
        p /= np.sqrt(p @ (M @ p))
        Kp = K(p)
        # the lowest vector c of the plane (v, p): K's Rayleigh quotient there, M = I in it
        plane = np.array([[v @ Kv, 0.5 * (v @ Kp + p @ Kv)], [0.0, p @ Kp]])
        plane[1, 0] = plane[0, 1]
        c = np.linalg.eigh(plane)[1][:, 0]
        v, Kv = c[0] * v + c[1] * p, c[0] * Kv + c[1] * Kp
    out = np.zeros(op.mass.shape[0])
    out[f] = kept
    return out


def _newton_step(model, x: np.ndarray, K: sp.csc_matrix, free: np.ndarray, factor) -> np.ndarray | None:
    """(n, 3) mm: d = K^-1 r on the free DOFs (K their assembled stiffness, definite; r the
    residual, loads less the gradient, at ``x``), the Newton step from ``x`` to the discrete
    equilibrium: how far a relaxation stopped by its residual tolerance is from it, which along
    a soft mode (r / w) the residual does not show. Solved by conjugate gradients on K with the
    factor of K - s M the stability check made (``factor``, None: not made) as the
    preconditioner, to :data:`NEWTON_RTOL`, and by a factorisation of K where that does not
    converge. None where K cannot be factorised."""
    P = model.pack()
    X, G = np.zeros((P.n_total, 3)), np.zeros((P.n_total, 3))
    X[: P.n] = x
    gradient(X, P, G, np.zeros((0, 6)))
    r = (model.loads - G[: P.n]).reshape(-1)[free]
    info = 1
    if factor is not None:
        d, info = cg(K, r, rtol=NEWTON_RTOL, atol=0.0, maxiter=NEWTON_CG_ITERATIONS,
                     M=LinearOperator(K.shape, matvec=factor.solve, dtype=float))
    if info != 0:
        try:
            d = splu(K, permc_spec="MMD_AT_PLUS_A").solve(r)
        except RuntimeError:  # singular
            return None
    step = np.zeros(3 * P.n)
    step[free] = d
    return step.reshape(P.n, 3)


def _below(K: sp.csr_matrix, M: sp.csr_matrix, shift: float):
    """The factor of K - ``shift`` M if it is positive definite (no eigenvalue of K v = w M v
    at or below ``shift``), else None; also None where a pivot is zero. Symmetric elimination
    without pivoting gives K - s M = L D L^T, and D has as many negative entries as there are
    eigenvalues below s (Sylvester's law of inertia)."""
    try:
        lu = splu((K - shift * M).tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                  options={"SymmetricMode": True})
    except RuntimeError:  # exactly singular: an eigenvalue at the shift
        return None
    if not np.array_equal(lu.perm_r, lu.perm_c) or not np.all(lu.U.diagonal() > 0.0):
        return None
    return lu


def _by_inertia(op: _Operator, start: np.ndarray) -> tuple[bool, np.ndarray | None, sp.csc_matrix | None, object]:
    """The lowest mode on the assembled K: (converged, u (3n,) with u^T M u = 1, K on the free
    DOFs, the factor of K - s M on them), u None where it cannot be had this way (K None where
    it is not assembled: :data:`MAX_DIFFERENCES`). The shift s starts at minus :data:`NEUTRAL` (a
    stable state's, where the lowest mode is then the one nearest it) and goes down by decades
    until K - s M is definite (not below :data:`LOWEST_SHIFT`); shift-invert Lanczos at s then
    finds the eigenvalues nearest s, and the lowest found is the lowest only if K - w' M is
    definite just below it (w' = :data:`BELOW` under it). The search starts from ``start``
    alone, so that of a near pair of modes (a regular polygon's come in pairs) it finds the
    one nearest the start, as Lanczos on C does; where that misses the lowest (a start with no
    part along it: the lift is mirror-symmetric, a twist is not), it starts again from
    ``start`` plus a fixed random vector, so that the start has a part along every mode, and
    keeps the lowest of :data:`SHIFT_INVERT_MODES` found."""
    built = op.assembled()
    if built is None:
        return False, None, None, None
    K, pairs = built
    op.applications[0] += pairs
    f = op.free
    K, M = K[f][:, f].tocsc(), op.mass[f][:, f].tocsc()
    shift = -NEUTRAL
    while (lu := _below(K, M, shift)) is None:
        shift *= 10.0
        if shift < LOWEST_SHIFT:
            return False, None, K, None
    inverse = LinearOperator(K.shape, matvec=lu.solve, dtype=float)
    noise = np.random.default_rng(0).standard_normal(K.shape[0])
    for v0, modes in ((start, 1), (start / np.linalg.norm(start) + noise / np.linalg.norm(noise), SHIFT_INVERT_MODES)):
        try:
            w, v = eigsh(K, k=min(modes, K.shape[0] - 1), M=M, sigma=shift, which="LM", OPinv=inverse,
                         tol=MODE_TOLERANCE, v0=v0, maxiter=MODE_ITERATIONS)
            found = True
        except ArpackNoConvergence as stop:
            if not len(stop.eigenvalues):
                continue
            w, v, found = stop.eigenvalues, stop.eigenvectors, False
        lowest = int(np.argmin(w))
        if _below(K, M, w[lowest] - BELOW * max(abs(w[lowest]), NEUTRAL)) is not None:
            u = np.zeros(op.mass.shape[0])
            u[f] = v[:, lowest] / np.sqrt(v[:, lowest] @ (M @ v[:, lowest]))
            return found, u, K, lu
    return False, None, K, None


def film_areas(model) -> np.ndarray:
    """(n,) mm^2: a third of the flat area of each of the model's triangles on each of its nodes."""
    area = np.zeros(model.n)
    tri = np.zeros((0, 3), int) if model.triangles is None else np.asarray(model.triangles, dtype=int).reshape(-1, 3)
    if tri.size:
        x = model.nodes
        a = 0.5 * np.linalg.norm(np.cross(x[tri[:, 1]] - x[tri[:, 0]], x[tri[:, 2]] - x[tri[:, 0]]), axis=1)
        np.add.at(area, tri.ravel(), np.repeat(a / 3.0, 3))
    return area


def is_negative(mode: Mode) -> bool:
    """Whether ``mode``'s stiffness is negative beyond the differences' round-off
    (:data:`ROUND_OFF`): the test for a state known to be unstable, where a weak saddle within
    the neutral band is still left, but a null mode (a slack node) gives no direction to leave by."""
    return bool(mode.eigenvalue < -ROUND_OFF)


def is_saddle(mode: Mode, neutral: float) -> bool:
    """Whether ``mode`` makes its state a saddle: a negative stiffness below minus ``neutral``
    (N/mm^3) per unit film area (:func:`results.path.neutral_stiffness`, the FEM's measure);
    a model without film by :data:`NEUTRAL` in units of the masses."""
    if np.isfinite(mode.per_area):
        return bool(mode.eigenvalue < 0.0 and mode.per_area < -neutral)
    return bool(mode.eigenvalue < -NEUTRAL)


class Spectrum(NamedTuple):
    """The two ends of the spectrum of K v = w M v at a state: the largest w sets how far each
    step can go (w <= 1 when the masses bound the stiffness, f = 2), the smallest how far the
    slowest mode goes in one step; kinetic damping needs about sqrt(w_max / w_min) steps."""

    w_max: float
    w_min: float
    top: np.ndarray  # (n, 3) the stiffest mode's shape, largest nodal displacement 1
    bottom: np.ndarray  # (n, 3) the softest mode's shape
    found: bool  # both ends converged to the tolerance asked for

    @property
    def condition(self) -> float:
        """sqrt(w_max / w_min): the steps kinetic damping needs scale with it."""
        return float(np.sqrt(self.w_max / self.w_min)) if self.w_min > 0 else float("inf")


def spectrum(model, x: np.ndarray, *, masses: str = "frame", held: np.ndarray | None = None,
             tolerance: float = 1e-4) -> Spectrum:
    """Both ends of the spectrum of ``model`` at positions ``x`` (n, 3) mm against the masses
    :func:`dr.relax` would use there (f = 2), over the free DOFs; ``held`` (n,) bool holds
    more nodes (e.g. the frame's, for the film's own spectrum). ``tolerance``: ARPACK's relative
    accuracy of each end."""
    n = model.n
    if held is not None:
        model = copy.deepcopy(model)  # held as supports: the masses DR would build for that model
        model.support(np.flatnonzero(held))
    op = _operator(model, x, masses)
    ends, found = [], True
    m = op.free.size
    for which in ("LA", "SA"):
        try:
            # a wide Krylov space: the soft end of a stiff frame's spectrum is clustered near 0
            w, v = eigsh(op.C, k=1, which=which, tol=tolerance, v0=np.ones(m), ncv=min(m, SPECTRUM_KRYLOV),
                         maxiter=MODE_ITERATIONS)
        except ArpackNoConvergence as stop:
            found = False
            w, v = (stop.eigenvalues, stop.eigenvectors) if len(stop.eigenvalues) else ([np.nan], np.zeros((m, 1)))
        ends.append((float(w[0]), _shape(op.to_displacement(v[:, 0]), n)))
    (w_max, top), (w_min, bottom) = ends
    return Spectrum(w_max, w_min, top, bottom, found)


def _mass_halves(built, n: int):
    """u -> M^-1/2 u and u -> M^-T/2 u on all 3n DOFs, M = B B^T: the frame mass's factor L
    (fresh from :func:`dr.masses.masses_at`, so no rotation since the refresh) and each other
    node's 3x3 Cholesky factor (its held axes decoupled, as the time loop builds them); and M
    itself (3n, 3n)."""
    st, fm = built.state, built.frame
    dof = (3 * fm.nodes[:, None] + np.arange(3)).ravel()
    N = dof.size
    rows = np.repeat(np.arange(N), np.diff(fm.start[: N + 1]))
    cols = fm.first[rows] + np.arange(rows.size) - fm.start[rows]
    L = sp.csc_matrix((fm.env[: rows.size], (rows, cols)), shape=(N, N))
    factor = splu(L, permc_spec="NATURAL", diag_pivot_thresh=0.0, options={"SymmetricMode": False}) if N else None
    nodes = np.flatnonzero(fm.pos < 0)
    a, b, c, d, e, f = st.M[nodes].T
    blocks = np.stack([np.stack([a, d, e], -1), np.stack([d, b, f], -1), np.stack([e, f, c], -1)], 1)
    if blocks.size:
        blocks += FLOOR * np.median(np.stack([a, b, c])) * np.eye(3)
    # inverted once: a batched solve per application cost 0.1 ms, a fifth of a Lanczos check
    B_inv = np.linalg.inv(np.linalg.cholesky(blocks))
    node_dof = 3 * nodes[:, None] + np.arange(3)
    mass = sp.coo_matrix((blocks.ravel(), (np.repeat(node_dof, 3, axis=1).ravel(), np.tile(node_dof, 3).ravel())),
                         shape=(3 * n, 3 * n)).tocsr()
    if N:
        select = sp.csr_matrix((np.ones(N), (dof, np.arange(N))), shape=(3 * n, N))
        mass = mass + select @ (L @ L.T) @ select.T

    def half(u: np.ndarray) -> np.ndarray:
        z = np.zeros_like(u)
        if factor is not None:
            z[dof] = factor.solve(u[dof])
        z.reshape(n, 3)[nodes] = np.einsum("kij,kj->ki", B_inv, u.reshape(n, 3)[nodes])
        return z

    def half_t(u: np.ndarray) -> np.ndarray:
        z = np.zeros_like(u)
        if factor is not None:
            z[dof] = factor.solve(u[dof], trans="T")
        z.reshape(n, 3)[nodes] = np.einsum("kji,kj->ki", B_inv, u.reshape(n, 3)[nodes])
        return z

    return half, half_t, mass.tocsr()
