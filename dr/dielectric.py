"""DR element: the ideal dielectric film's electrostatic energy over flat-reference triangles.

At a fixed voltage a triangle of flat (mounted) area A and current area a has the energy
-c a^2 / A (N mm), c = eps0 eps_r V^2 / (2 h_m) (:func:`scenes.electric.dielectric_coefficient`):
the integral of -eps V^2 / (2 h) over its current area with h = h_m A / a (incompressible). With
n = (x1 - x0) x (x2 - x0), a^2 = |n|^2 / 4, so the energy is a quartic polynomial in the
positions and its gradient is exact: d|n|^2/dx1 = 2 e2 x n, d|n|^2/dx2 = 2 n x e1 (e1 = x1 - x0,
e2 = x2 - x0), d/dx0 = minus their sum. The same triangle in the FEM (P1) has the same energy.

Stiffness bound for the masses: the Gershgorin row sums of the exact 9x9 Hessian. The term
softens the film (its Hessian is mostly negative); the time step's stability needs the size of
the stiffness, not its sign, so the absolute row sums bound it.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from .blocks import gershgorin
from .errors import DRError
from .triangles import shape_gradients
from .vec import add_to, cross, dot, get, sub

AREA, COEFF = range(2)
"""Columns of Packed.diel_par: flat area (mm^2) and c (N/mm)."""


class Fields(NamedTuple):
    """The dielectric film's arrays in :class:`dr.kernels.Packed`."""

    diel_idx: np.ndarray  # (d, 3) triangles of the dielectric film
    diel_par: np.ndarray  # (d, 2) flat area (mm^2), coefficient c (N/mm)


class Methods:
    """The :class:`dr.Model` methods of the dielectric film; ``dielectric_coefficient`` is its
    c (N/mm): one number for the whole film or one per triangle, set by :meth:`add_dielectric`
    and changed with the voltage."""

    dielectric_coefficient: float | np.ndarray = 0.0

    def add_dielectric(self, triangles: np.ndarray, coefficient: float | np.ndarray) -> None:
        """Make the film over node triples ``triangles`` an ideal dielectric (:mod:`dr.dielectric`).

        Its energy is -c a^2 / A per triangle (current area a, flat area A in the reference),
        c = ``coefficient`` (N/mm, >= 0; one for all or one per triangle, 0 where no electrode
        covers it) from :func:`scenes.electric.film_coefficients`; change the voltage by setting
        ``dielectric_coefficient``. The reference must be flat.
        """
        t = np.asarray(triangles)
        if t.ndim != 2 or t.shape[1] != 3 or t.shape[0] == 0:
            raise DRError("dielectric triangles must be a non-empty (t, 3) array of node indices")
        t = self.node_indices("dielectric triangle nodes", t.ravel()).reshape(-1, 3)
        _, area = shape_gradients(self.nodes[t][:, :, :2])
        if np.any(area <= 1e-12 * np.ptp(self.nodes[:, :2]) ** 2):
            raise DRError("a dielectric triangle has no area: its three nodes lie on one line")
        _coefficients(coefficient, len(t))
        self.stored[Fields][:] = [(t, area)]
        self.dielectric_coefficient = coefficient

    @property
    def dielectric_triangles(self) -> np.ndarray:
        """The dielectric film's triangles (t, 3) (node indices); none without a dielectric."""
        return self.stored[Fields][0][0] if self.stored[Fields] else np.zeros((0, 3), np.int64)

    def dielectric_energy(self, x: np.ndarray) -> tuple[float, float]:
        """(electrostatic energy N mm, current film area mm^2) at positions x (n, 3); (0, 0)
        without a dielectric."""
        if not self.stored[Fields]:
            return 0.0, 0.0
        t, area = self.stored[Fields][0]
        return energies(x, t, area, _coefficients(self.dielectric_coefficient, len(t)))


def _coefficients(coefficient: float | np.ndarray, n: int) -> np.ndarray:
    """c (N/mm) per triangle from one number or n; a clear DRError if they are not n numbers >= 0."""
    c = np.asarray(coefficient, float)
    if c.ndim > 1 or (c.ndim == 1 and len(c) != n):
        raise DRError(f"dielectric coefficient: give one number or one per triangle ({n}), not shape {c.shape}")
    if not np.all(np.isfinite(c)) or np.any(c < 0):
        raise DRError("dielectric coefficient must be numbers >= 0 (N/mm)")
    return np.broadcast_to(c, (n,))


def pack(model, rest) -> Fields:
    """The dielectric triangles of ``model`` (:meth:`dr.Model.add_dielectric`) with c > 0 at
    their coefficient; ``rest`` is unused. At zero voltage it has no rows: V = 0 is the
    mechanical model bit for bit, and film under no electrode costs nothing."""
    if not model.stored[Fields]:
        return Fields(np.zeros((0, 3), np.int64), np.zeros((0, 2)))
    t, area = model.stored[Fields][0]
    c = _coefficients(model.dielectric_coefficient, len(t))
    on = c > 0.0
    return Fields(t[on], np.column_stack([area[on], c[on]]))


def forces(X: np.ndarray, P, moment: np.ndarray) -> dict[str, np.ndarray]:
    """Nothing: the dielectric reports no forces (``moment`` is left alone)."""
    return {}


def stencils(P) -> np.ndarray:
    """The rows of X each dielectric triangle's energy depends on (d, 3): its corners."""
    return P.diel_idx


def edges(P) -> np.ndarray:
    """None: the dielectric's triangles are the membrane's (the drift scale of dr.relax takes
    their sides there)."""
    return np.zeros((0, 2), np.int64)


@njit(cache=True, error_model="numpy")
def dielectric_local(xl, par, gl, want_grad):
    """Energy (N mm) of one triangle from its rows xl (3, 3); with ``want_grad`` its gradient
    is added to gl (3, 3)."""
    e1 = sub(get(xl, 1), get(xl, 0))
    e2 = sub(get(xl, 2), get(xl, 0))
    n = cross(e1, e2)
    k = par[COEFF] / (4.0 * par[AREA])
    if want_grad:
        g1 = cross(e2, n)
        g2 = cross(n, e1)
        add_to(gl, 1, g1, -2.0 * k)
        add_to(gl, 2, g2, -2.0 * k)
        add_to(gl, 0, g1, 2.0 * k)
        add_to(gl, 0, g2, 2.0 * k)
    return -k * dot(n, n)


@njit(cache=True, error_model="numpy")
def dielectric_hessian(xl, par, H):
    """The exact Hessian H (9, 9) of one triangle's energy (N/mm)."""
    e1 = sub(get(xl, 1), get(xl, 0))
    e2 = sub(get(xl, 2), get(xl, 0))
    g11, g22, g12 = dot(e1, e1), dot(e2, e2), dot(e1, e2)
    k = -par[COEFF] / (4.0 * par[AREA])
    # |n|^2 = g11 g22 - g12^2: its Hessian in (e1, e2), then mapped to the nodes
    He = np.zeros((6, 6))
    for i in range(3):
        He[i, i] += 2.0 * g22
        He[3 + i, 3 + i] += 2.0 * g11
        He[i, 3 + i] -= 2.0 * g12
        He[3 + i, i] -= 2.0 * g12
        for j in range(3):
            He[i, j] -= 2.0 * e2[i] * e2[j]
            He[3 + i, 3 + j] -= 2.0 * e1[i] * e1[j]
            He[i, 3 + j] += 4.0 * e1[i] * e2[j] - 2.0 * e2[i] * e1[j]
            He[3 + j, i] += 4.0 * e1[i] * e2[j] - 2.0 * e2[i] * e1[j]
    T = np.zeros((6, 9))  # (e1, e2) = T (x0, x1, x2)
    for i in range(3):
        T[i, i], T[i, 3 + i] = -1.0, 1.0
        T[3 + i, i], T[3 + i, 6 + i] = -1.0, 1.0
    H[:, :] = k * (T.T @ He @ T)


@njit(cache=True, error_model="numpy")
def dielectric_gradient(X, idx, par, G, xl, gl):
    """Add one triangle's energy gradient to G (N); xl, gl (3, 3) scratch. Returns the largest
    nodal force, N."""
    for a in range(3):
        for i in range(3):
            xl[a, i] = X[idx[a], i]
    gl[:] = 0.0
    dielectric_local(xl, par, gl, True)
    fmax = 0.0
    for a in range(3):
        add_to(G, idx[a], get(gl, a), 1.0)
        fmax = max(fmax, np.sqrt(gl[a, 0] ** 2 + gl[a, 1] ** 2 + gl[a, 2] ** 2))
    return fmax


@njit(cache=True, error_model="numpy")
def gradient(X, P, G, D):
    """Add the dielectric's gradient of every film triangle to G; returns its largest force (N)."""
    xt = np.zeros((3, 3))
    gt = np.zeros((3, 3))
    fmax = 0.0
    for k in range(P.diel_idx.shape[0]):
        fmax = max(fmax, dielectric_gradient(X, P.diel_idx[k], P.diel_par[k], G, xt, gt))
    return fmax


@njit(cache=True, error_model="numpy")
def energy(X, P):
    """The dielectric's energy -(eps0 eps_r V^2 / 2) integral of 1/h da over every film triangle, N mm."""
    if P.diel_idx.shape[0] == 0:
        return 0.0
    xt = np.zeros((3, 3))
    gt = np.zeros((3, 3))
    total = 0.0
    for k in range(P.diel_idx.shape[0]):
        idx = P.diel_idx[k]
        for a in range(3):
            for c in range(3):
                xt[a, c] = X[idx[a], c]
        total += dielectric_local(xt, P.diel_par[k], gt, False)
    return total


@njit(cache=True, error_model="numpy")
def strain_energy(X, P):
    """Strain energy (membrane, frame bending, frame torsion, frame axial): none. The film's
    electrostatic energy is no strain energy; :func:`energy` gives it (dr.stability adds it)."""
    return 0.0, 0.0, 0.0, 0.0


@njit(cache=True, error_model="numpy")
def stiffness(X, P, S, with_links):
    """Add the Gershgorin bound of each triangle's dielectric Hessian (it softens the film: its
    size, not its sign, bounds the time step) to S."""
    xt = np.zeros((3, 3))
    H = np.zeros((9, 9))
    for k in range(P.diel_idx.shape[0]):
        idx = P.diel_idx[k]
        for a in range(3):
            for c in range(3):
                xt[a, c] = X[idx[a], c]
        dielectric_hessian(xt, P.diel_par[k], H)
        gershgorin(H, idx, S)


def energies(x: np.ndarray, triangles: np.ndarray, flat_area: np.ndarray, coefficient: np.ndarray
             ) -> tuple[float, float]:
    """(electrostatic energy -sum c a^2 / A, current area sum a) of triangles at positions x
    (n, 3), c per triangle: N mm and mm^2."""
    p = x[triangles]
    a = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    return float(-np.sum(coefficient * a * a / flat_area)), float(a.sum())
