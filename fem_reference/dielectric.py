"""The ideal dielectric film's electrostatic energy on the FEM membrane mesh.

Per unit flat (mounted) area the energy is -c J^2 (N/mm), J the area ratio current/flat and
c = eps0 eps_r V^2 / (2 h_m) (:func:`scenes.electric.dielectric_coefficient`). With a1, a2 the
columns of the 3x2 deformation gradient F, J^2 = |a1|^2 |a2|^2 - (a1 . a2)^2 is a quartic
polynomial in F, so its derivatives below are exact (the tests check them by finite differences).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from skfem import BilinearForm, Functional, LinearForm
from skfem.helpers import grad


@Functional
def _energy_form(w):
    return w["W"].view(np.ndarray)


@LinearForm
def _residual_form(v, w):
    return np.einsum("ij...,ij...->...", w["P"].view(np.ndarray), grad(v))


@BilinearForm
def _tangent_form(u, v, w):
    return np.einsum("ijkl...,ij...,kl...->...", w["A"].view(np.ndarray), grad(v), grad(u))


def area_ratio_squared(F: np.ndarray, order: int = 2):
    """J^2 (...), its derivative dJ^2/dF (3, 2, ...) and (order 2) d2J^2/dF2 (3, 2, 3, 2, ...)
    for deformation gradients F (3, 2, ...)."""
    a1, a2 = F[:, 0], F[:, 1]
    g11, g22 = np.einsum("i...,i...->...", a1, a1), np.einsum("i...,i...->...", a2, a2)
    g12 = np.einsum("i...,i...->...", a1, a2)
    j2 = g11 * g22 - g12 * g12
    if order == 0:
        return j2, None, None
    d = np.stack([2 * (g22 * a1 - g12 * a2), 2 * (g11 * a2 - g12 * a1)], axis=1)
    if order == 1:
        return j2, d, None
    eye = np.eye(3).reshape(3, 3, *([1] * g11.ndim))
    outer = lambda p, q: np.einsum("i...,j...->ij...", p, q)  # noqa: E731
    h = np.empty((3, 2, 3, 2, *g11.shape))
    h[:, 0, :, 0] = 2 * (g22 * eye - outer(a2, a2))
    h[:, 1, :, 1] = 2 * (g11 * eye - outer(a1, a1))
    h[:, 0, :, 1] = 4 * outer(a1, a2) - 2 * outer(a2, a1) - 2 * g12 * eye
    h[:, 1, :, 0] = np.swapaxes(h[:, 0, :, 1], 0, 1)
    return j2, d, h


class Dielectric:
    """Electrostatic energy -c J^2 per unit flat area, assembled on a membrane's vector basis.

    Parameters
    ----------
    basis
        The membrane's ``Basis(mesh, ElementVector(..., 3))`` on the flat mesh.
    coefficient
        c = eps0 eps_r V^2 / (2 h_m), N/mm: one for the whole film or one per element (0 where
        no electrode covers it, :func:`scenes.electric.film_coefficients`); set the attribute to
        change the voltage.
    """

    def __init__(self, basis, coefficient: float | np.ndarray = 0.0):
        self.basis = basis
        self.coefficient = coefficient
        locs = basis.doflocs[:, ::3]
        self.X = np.column_stack([locs[0], locs[1], np.zeros(locs.shape[1])])

    @property
    def _c(self) -> np.ndarray:
        """c per element as (nel, 1), to scale the (nel, nqp) quadrature values."""
        return np.broadcast_to(np.asarray(self.coefficient, float), (self.basis.nelems,))[:, None]

    def _gradient(self, x: np.ndarray) -> np.ndarray:
        u = (x - self.X).ravel()
        return np.eye(3, 2)[:, :, None, None] + self.basis.interpolate(u).grad

    def energy(self, x: np.ndarray) -> float:
        """Electrostatic free energy (N mm, <= 0) at node positions x (nn, 3)."""
        if not np.any(self.coefficient):
            return 0.0
        j2, _, _ = area_ratio_squared(self._gradient(x), 0)
        return float(_energy_form.assemble(self.basis, W=-self._c * j2))

    def evaluate(self, x: np.ndarray, order: int = 2
                 ) -> tuple[float, np.ndarray, sp.csr_matrix | None]:
        """Energy (N mm), gradient (3 nn,) N and (order 2) tangent (3 nn, 3 nn) N/mm."""
        c = self._c
        j2, d, h = area_ratio_squared(self._gradient(x), order)
        e = float(_energy_form.assemble(self.basis, W=-c * j2))
        g = _residual_form.assemble(self.basis, P=np.ascontiguousarray(-c * d))
        K = None
        if order >= 2:
            K = _tangent_form.assemble(self.basis, A=np.ascontiguousarray(-c * h)).tocsr()
        return e, g, K

    def current_area(self, x: np.ndarray) -> float:
        """Current area of the film (mm^2)."""
        j2, _, _ = area_ratio_squared(self._gradient(x), 0)
        return float(_energy_form.assemble(self.basis, W=np.sqrt(j2)))

    def capacitor_energy(self, x: np.ndarray) -> float:
        """E_cap = integral of eps V^2 / (2 h) over the current area = c * integral of J^2 dA_flat
        (N mm): minus the electrostatic free energy at fixed voltage."""
        j2, _, _ = area_ratio_squared(self._gradient(x), 0)
        return float(_energy_form.assemble(self.basis, W=self._c * j2))
