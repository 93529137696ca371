"""Is a DR equilibrium stable? The lowest mode of its stiffness, and the step off a saddle.

DR settles wherever the residual vanishes, and the flat pre-stretched DEMES is such a place:
an equilibrium whose lowest mode (the curl) has a negative stiffness once the pre-stretch
passes the buckling load. A fast relaxation (the frame mass) reaches it before that mode has
grown. The test is the generalised eigenproblem K v = w M v on the free DOFs, with K the
stiffness (central differences of the exact gradient, never assembled) and M the run's own
masses (so w <= 1 for f = 2, and the masses precondition the solve): w < -:data:`NEUTRAL`
is a saddle. :func:`leave_saddle` steps from it along the mode, to lower energy, as the FEM's
continuation does.
"""

from __future__ import annotations

import warnings
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import LinearOperator, lobpcg

from . import dielectric
from . import integrator as itg
from .kernels import Packed, energy, gradient
from .masses import masses_at

NEUTRAL = 1e-6
"""Generalised eigenvalues w above minus this count as zero (slack film, round-off of the
central differences): w is dimensionless, about 1 for the stiffest mode."""

MODE_TOLERANCE = 1e-4
"""Relative residual |K v - w M v| / |M v| at which the lowest mode counts as found."""

MODE_ITERATIONS = 200
"""Largest number of LOBPCG iterations for the lowest mode."""


class Mode(NamedTuple):
    """The lowest eigenpair of K v = w M v at a state."""

    eigenvalue: float  # w (dimensionless, the masses' scale: the stiffest mode is about 1)
    shape: np.ndarray  # (n, 3), the largest nodal displacement 1; fixed DOFs 0
    iterations: int  # LOBPCG iterations
    found: bool  # converged to MODE_TOLERANCE


def potential_energy(X: np.ndarray, P: Packed, loads: np.ndarray) -> float:
    """Strain energy plus the dielectric's (electrical) part, less the loads' work from the
    origin, N mm: the energy DR minimises. X: (n_total, 3) mm."""
    return float(sum(energy(X, P))) + float(dielectric.energy(X, P)) - float(np.sum(loads * X[: P.n]))


def lowest_mode(model, x: np.ndarray, *, masses: str = "frame", guess: np.ndarray | None = None) -> Mode:
    """The lowest mode of ``model`` at positions ``x`` (n, 3) mm, against the masses
    ``masses`` ('frame', 'tensor' or 'scalar') that :func:`dr.relax` would use there (f = 2).
    ``guess`` (n, 3): a shape to start the search from (e.g. the scene's lift)."""
    P0 = model.pack()
    n = P0.n
    X = np.zeros((P0.n_total, 3))
    X[:n] = x
    built = masses_at(model, P0, X.copy(), masses, 2.0)
    free = np.flatnonzero(~model.fixed.reshape(-1))
    h = 1e-6 * max(float(np.ptp(x, axis=0).max()), 1e-9)
    G, no_blocks = np.zeros_like(X), np.zeros((0, 6))

    def grad(d: np.ndarray) -> np.ndarray:
        X[:n] = x + d
        gradient(X, P0, G, no_blocks)
        return G[:n].reshape(-1)[free].copy()

    def stiffness(V: np.ndarray) -> np.ndarray:
        out = np.empty_like(V)
        for j in range(V.shape[1]):
            d = _on_nodes(V[:, j], free, n)
            out[:, j] = (grad(h * d) - grad(-h * d)) / (2.0 * h)
        return out

    mass, inverse = _mass_operators(built, free, n)
    m = free.size
    rng = np.random.default_rng(0)
    start = rng.standard_normal((m, 3))
    if guess is not None:
        start[:, 0] = np.asarray(guess, dtype=float).reshape(-1)[free]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # not converging is reported in Mode.found
        w, V, history = lobpcg(_operator(stiffness, m), start, B=_operator(mass, m), M=_operator(inverse, m),
                               largest=False, tol=MODE_TOLERANCE, maxiter=MODE_ITERATIONS,
                               retResidualNormsHistory=True)
    k = int(np.argmin(w))
    v = V[:, [k]]
    Mv = mass(v)
    found = bool(np.linalg.norm(stiffness(v) - w[k] * Mv) <= 10 * MODE_TOLERANCE * np.linalg.norm(Mv))
    shape = _on_nodes(v[:, 0], free, n)
    shape /= max(float(np.linalg.norm(shape, axis=1).max()), 1e-300)
    return Mode(float(w[k]), shape, len(history), found)


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


def _on_nodes(v: np.ndarray, free: np.ndarray, n: int) -> np.ndarray:
    d = np.zeros(3 * n)
    d[free] = v
    return d.reshape(n, 3)


def _operator(apply, m: int) -> LinearOperator:
    def on_block(V):
        return apply(np.asarray(V).reshape(m, -1))
    return LinearOperator((m, m), matvec=on_block, matmat=on_block, dtype=float)


def _mass_operators(built, free: np.ndarray, n: int):
    """M v and M^-1 v on the free DOFs: node blocks, and the frame mass as L L^T (its factor
    fresh from :func:`dr.masses.masses_at`, so no rotation since the refresh)."""
    st, fm = built.state, built.frame
    tensor_node = fm.pos < 0
    a, b, c, d, e, f = st.M.T
    dof = (3 * fm.nodes[:, None] + np.arange(3)).ravel()
    N = dof.size
    rows = np.repeat(np.arange(N), np.diff(fm.start[: N + 1]))
    cols = fm.first[rows] + np.arange(rows.size) - fm.start[rows]
    L = sp.csr_matrix((fm.env[: rows.size], (rows, cols)), shape=(N, N))

    def mass(V: np.ndarray) -> np.ndarray:
        out = np.empty_like(V)
        for j in range(V.shape[1]):
            u = _on_nodes(V[:, j], free, n)
            r = np.stack([a * u[:, 0] + d * u[:, 1] + e * u[:, 2], d * u[:, 0] + b * u[:, 1] + f * u[:, 2],
                          e * u[:, 0] + f * u[:, 1] + c * u[:, 2]], axis=1) * tensor_node[:, None]
            r.reshape(-1)[dof] = L @ (L.T @ u.reshape(-1)[dof])
            out[:, j] = r.reshape(-1)[free]
        return out

    def inverse(V: np.ndarray) -> np.ndarray:
        out = np.empty_like(V)
        for j in range(V.shape[1]):
            st.R[:] = _on_nodes(V[:, j], free, n)
            itg.accelerations(st, fm, n)
            out[:, j] = st.A.reshape(-1)[free]
        return out

    return mass, inverse
