"""Is a DR equilibrium stable? The lowest mode of its stiffness, and the step off a saddle.

DR settles wherever the residual vanishes, and the flat pre-stretched DEMES is such a place:
an equilibrium whose lowest mode (the curl) has a negative stiffness once the pre-stretch
passes the buckling load. A fast relaxation (the frame mass) reaches it before that mode has
grown. The test is the generalised eigenproblem K v = w M v on the free DOFs, with K the
stiffness (central differences of the exact gradient, never assembled) and M the run's own
masses (so w <= 1 for f = 2, and the masses precondition the search): w < -:data:`NEUTRAL`
is a saddle. :func:`leave_saddle` steps from it along the mode, to lower energy, as the FEM's
continuation does.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import ArpackNoConvergence, LinearOperator, eigsh, splu

from . import dielectric
from .kernels import Packed, energy, gradient
from .masses import masses_at

NEUTRAL = 1e-6
"""Generalised eigenvalues w above minus this count as zero (slack film, round-off of the
central differences): w is dimensionless, about 1 for the stiffest mode."""

FLOOR = 1e-3
"""The node blocks get this fraction of their median diagonal added: a slack film node's mass
is a sliver of its stiffness in the slack direction, and there the central differences' noise
over the sliver would read as a large negative w. Any SPD metric gives the eigenvalues the same
signs (Sylvester's law of inertia)."""

MODE_TOLERANCE = 1e-6
"""Relative accuracy of the lowest eigenvalue (ARPACK's ``tol``)."""

MODE_ITERATIONS = 2000
"""Largest number of Lanczos restarts for the lowest mode."""


class Mode(NamedTuple):
    """The lowest eigenpair of K v = w M v at a state."""

    eigenvalue: float  # w = v^T K v / v^T M v (the masses' scale: the stiffest mode is about 1)
    shape: np.ndarray  # (n, 3), the largest nodal displacement 1; fixed DOFs 0
    iterations: int  # applications of K (two gradients each)
    found: bool  # converged to MODE_TOLERANCE
    stiffness: float  # its Rayleigh quotient v^T K v / v^T v, N/mm


def potential_energy(X: np.ndarray, P: Packed, loads: np.ndarray) -> float:
    """Strain energy plus the dielectric's (electrical) part, less the loads' work from the
    origin, N mm: the energy DR minimises. X: (n_total, 3) mm."""
    return float(sum(energy(X, P))) + float(dielectric.energy(X, P)) - float(np.sum(loads * X[: P.n]))


def lowest_mode(model, x: np.ndarray, *, masses: str = "frame", guess: np.ndarray | None = None) -> Mode:
    """The lowest mode of ``model`` at positions ``x`` (n, 3) mm, against the masses
    ``masses`` ('frame', 'tensor' or 'scalar') that :func:`dr.relax` would use there (f = 2).
    ``guess`` (n, 3): a shape to start the search from (e.g. the scene's lift).

    Lanczos (ARPACK) on the symmetric C = M^-1/2 K M^-T/2, whose spectrum lies in about
    [-1, 1] because the masses bound the stiffness."""
    P0 = model.pack()
    n = P0.n
    X = np.zeros((P0.n_total, 3))
    X[:n] = x
    built = masses_at(model, P0, X.copy(), masses, 2.0)
    free = np.flatnonzero(~model.fixed.reshape(-1))
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

    half, half_t = _mass_halves(built, n)
    movable = (~model.fixed).reshape(-1)
    applications = 0

    def C(v: np.ndarray) -> np.ndarray:
        nonlocal applications
        applications += 1
        u = np.zeros(3 * n)
        u[free] = v
        u = half_t(u) * movable
        k = stiffness(u)
        return half(k)[free]

    m = free.size
    start = np.ones(m) if guess is None else np.asarray(guess, dtype=float).reshape(-1)[free] + 1e-3
    try:
        _, v = eigsh(LinearOperator((m, m), matvec=C, dtype=float), k=1, which="SA", tol=MODE_TOLERANCE,
                     v0=start, maxiter=MODE_ITERATIONS)
        found = True
    except ArpackNoConvergence as stop:
        if not len(stop.eigenvalues):
            return Mode(float("nan"), np.zeros((n, 3)), applications, False, float("nan"))
        v, found = stop.eigenvectors, False
    y = np.zeros(3 * n)
    y[free] = v[:, 0] / np.linalg.norm(v[:, 0])
    u = half_t(y) * movable  # u^T M u = |y|^2 = 1
    Ku = stiffness(u) * movable
    # the Rayleigh quotients of the mode itself: where K is not smooth (a cable at exactly its
    # rest length, tension-only) the Ritz value of a symmetric solver need not be one
    shape = u.reshape(n, 3) / max(float(np.linalg.norm(u.reshape(n, 3), axis=1).max()), 1e-300)
    return Mode(float(u @ Ku), shape, applications, found, float(u @ Ku / (u @ u)))


def leave_saddle(model, x: np.ndarray, mode: Mode, *, sign: float, size: float) -> np.ndarray | None:
    """Positions off the saddle ``x`` along ``mode`` (times ``sign``, +1 or -1) where the
    potential energy is lower: ``size`` mm at the node that moves most, halved until the
    energy drops (at most 30 times); None if it never does."""
    P = model.pack()
    X = np.zeros((P.n_total, 3))
    X[: P.n] = x
    e0 = potential_energy(X, P, model.loads)
    step = size
    for _ in range(30):
        X[: P.n] = x + step * sign * mode.shape
        if potential_energy(X, P, model.loads) < e0 - 1e-12 * abs(e0):
            return X[: P.n].copy()
        step *= 0.5
    return None


def _mass_halves(built, n: int):
    """u -> M^-1/2 u and u -> M^-T/2 u on all 3n DOFs, M = B B^T: the frame mass's factor L
    (fresh from :func:`dr.masses.masses_at`, so no rotation since the refresh) and each other
    node's 3x3 Cholesky factor (its held axes decoupled, as the time loop builds them)."""
    st, fm = built.state, built.frame
    dof = (3 * fm.nodes[:, None] + np.arange(3)).ravel()
    N = dof.size
    rows = np.repeat(np.arange(N), np.diff(fm.start[: N + 1]))
    cols = fm.first[rows] + np.arange(rows.size) - fm.start[rows]
    factor = (splu(sp.csc_matrix((fm.env[: rows.size], (rows, cols)), shape=(N, N)), permc_spec="NATURAL",
                   diag_pivot_thresh=0.0, options={"SymmetricMode": False}) if N else None)
    nodes = np.flatnonzero(fm.pos < 0)
    a, b, c, d, e, f = st.M[nodes].T
    blocks = np.stack([np.stack([a, d, e], -1), np.stack([d, b, f], -1), np.stack([e, f, c], -1)], 1)
    if blocks.size:
        blocks += FLOOR * np.median(np.stack([a, b, c])) * np.eye(3)
    B = np.linalg.cholesky(blocks)

    def half(u: np.ndarray) -> np.ndarray:
        z = np.zeros_like(u)
        if factor is not None:
            z[dof] = factor.solve(u[dof])
        z.reshape(n, 3)[nodes] = np.linalg.solve(B, u.reshape(n, 3)[nodes][:, :, None])[:, :, 0]
        return z

    def half_t(u: np.ndarray) -> np.ndarray:
        z = np.zeros_like(u)
        if factor is not None:
            z[dof] = factor.solve(u[dof], trans="T")
        z.reshape(n, 3)[nodes] = np.linalg.solve(np.swapaxes(B, 1, 2), u.reshape(n, 3)[nodes][:, :, None])[:, :, 0]
        return z

    return half, half_t
