"""Pre-stretched membrane: hyperelastic laws on the flat reference, on a scikit-fem basis.

The laws and the element loop are compiled (:mod:`fem_reference.laws`); scikit-fem gives the
mesh, the shape-function gradients and the quadrature.

Total-Lagrangian: the unknowns are the positions x of the mesh's DOF nodes, the reference is the
flat mesh (z = 0) and F = dx/dX is the 3x2 deformation gradient. The rest state is the flat state
shrunk by 1/lambda, so the deformation from the rest state is lambda F. Energies are per unit
*flat* area, in N/mm (N mm per mm^2); h is the mounted (stretched) film thickness.

Laws (``membrane.law``):

* ``"linear"``: the continuum limit of the DR link net (three families of Hookean links parallel
  to the lattice directions m_k at 0, 60 and 120 deg):
  W = E h / (2 lambda) sum_k eps_k^2, eps_k = lambda |F m_k| - 1 (isotropic, Poisson 1/3 at small
  strain); with ``tension_only`` a link family in compression carries nothing (eps_k -> max(eps_k, 0)).
* ``"neo-hookean"``: incompressible, mu = E / 3, W = mu h / 2 (tr C + 1 / det C - 3) with
  C = lambda^2 F^T F; the unstretched thickness is h lambda^2, so the mounted thickness is h.
  It has no tension-field relaxation: compressed regions are measured and reported.
* ``"gent"``: W = -mu h Jm / 2 ln(1 - (I1 - 3) / Jm), I1 = tr C + 1 / det C: the neo-Hookean
  film stiffening near its locking stretch (Jm = ``membrane.gent_jm``); as the neo-Hookean
  law otherwise.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from skfem import CellBasis

from scenes.prestretch import PrestretchPath

from .laws import LAW_IDS, LATTICE_ANGLES_DEG, element_terms, point_stress, prestretch_row

__all__ = ["Membrane", "MembraneState", "LATTICE_ANGLES_DEG"]


@dataclass
class MembraneState:
    """Law evaluated at the quadrature points: F (3, 2, nel, nqp), W (nel, nqp), P like F."""

    F: np.ndarray
    W: np.ndarray
    P: np.ndarray | None


class Pattern:
    """Where element matrices (nel, n, n) go in a CSR matrix of fixed sparsity: the symbolic
    assembly done once per mesh, so that each tangent is one weighted bincount."""

    def __init__(self, element_dofs: np.ndarray, n_dofs: int):
        nel, n = element_dofs.shape
        rows = np.repeat(element_dofs, n, axis=1).ravel()
        cols = np.tile(element_dofs, (1, n)).ravel()
        keys, self.slot = np.unique(rows.astype(np.int64) * n_dofs + cols, return_inverse=True)
        self.indices = (keys % n_dofs).astype(np.int32)
        self.indptr = np.searchsorted(keys // n_dofs, np.arange(n_dofs + 1)).astype(np.int32)
        self.shape = (n_dofs, n_dofs)

    def matrix(self, blocks: np.ndarray) -> sp.csr_matrix:
        data = np.bincount(self.slot, weights=blocks.ravel(), minlength=self.indices.size)
        return sp.csr_matrix((data, self.indices, self.indptr), shape=self.shape)


class Membrane:
    """The membrane's energy, nodal forces and tangent on a scikit-fem vector basis.

    Parameters
    ----------
    basis
        ``Basis(mesh, ElementVector(ElementTriP1() or ElementTriP2(), 3))`` on the flat mesh, or
        on some of its elements (``elements=``); its DOF 3 i + c is component c of node i
        (vertices first, then edge nodes).
    law, E, h, tension_only
        ``membrane.law``, Young's modulus (MPa), mounted thickness (mm), slack links carry nothing.
    jm
        Gent's Jm (``membrane.gent_jm``), read by the Gent law only.
    path
        How the pre-stretch is applied (:mod:`scenes.prestretch`): the methods' ``lam`` is the
        path value (the pre-stretch itself where isotropic).
    """

    def __init__(self, basis, law: str, E: float, h: float, tension_only: bool, jm: float = np.inf,
                 path: PrestretchPath = PrestretchPath()):
        if law not in LAW_IDS:
            raise ValueError(f"membrane.law = {law!r} is not one of {', '.join(LAW_IDS)}")
        self.basis = basis
        self.law, self.E, self.h, self.tension_only, self.jm, self.path = law, E, h, tension_only, jm, path
        locs = basis.doflocs[:, ::3]  # one location per node
        self.X = np.column_stack([locs[0], locs[1], np.zeros(locs.shape[1])])  # (nn, 3) mm
        # the scalar element on the same quadrature: its node numbering is the vector DOF / 3
        scalar = CellBasis(basis.mesh, basis.elem.elem, quadrature=(basis.X, basis.W), elements=basis.tind)
        self._dofs = np.ascontiguousarray(scalar.element_dofs.T)  # (nel, nb)
        self._grads = np.ascontiguousarray(
            np.stack([phi[0].grad for phi in scalar.basis]).transpose(2, 3, 0, 1))  # (nel, nq, nb, 2)
        self._dx = np.ascontiguousarray(scalar.dx)
        vector_dofs = (3 * self._dofs[:, :, None] + np.arange(3)).reshape(self._dofs.shape[0], -1)
        self._vector_dofs = vector_dofs
        self._pattern = Pattern(vector_dofs, 3 * self.n_nodes)

    @property
    def n_nodes(self) -> int:
        return self.X.shape[0]

    def _terms(self, x: np.ndarray, lam: float, order: int):
        return element_terms(np.ascontiguousarray(x - self.X, dtype=float), self._dofs, self._grads,
                             self._dx, LAW_IDS[self.law], prestretch_row(self.path, float(lam)), float(self.E), float(self.h),
                             bool(self.tension_only), float(self.jm), order)

    def deformation_gradient(self, x: np.ndarray) -> np.ndarray:
        """F (3, 2, nel, nqp) at the quadrature points for node positions x (nn, 3)."""
        u = x - self.X
        return np.eye(3, 2)[:, :, None, None] + np.einsum("eai,eqaj->ijeq", u[self._dofs], self._grads)

    def centroid_gradient(self, x: np.ndarray) -> np.ndarray:
        """F (nel, 3, 2) at each element's centroid (reference coordinates (1/3, 1/3)) for node
        positions x (nn, 3): one value per element for the film's output fields."""
        centre = CellBasis(self.basis.mesh, self.basis.elem.elem, quadrature=(np.full((2, 1), 1.0 / 3.0), np.ones(1)),
                           elements=self.basis.tind)
        grads = np.stack([phi[0].grad[:, :, 0] for phi in centre.basis])  # (nb, 2, nel)
        u = x - self.X
        return np.eye(3, 2) + np.einsum("eai,aje->eij", u[centre.element_dofs.T], grads)

    def law_state(self, x: np.ndarray, lam: float, order: int = 1) -> MembraneState:
        """F, W and (order 1) P = dW/dF at the quadrature points."""
        F = self.deformation_gradient(x)
        W = self._terms(x, lam, 0)[0]
        if order == 0:
            return MembraneState(F, W, None)
        flat = np.ascontiguousarray(np.moveaxis(F, (0, 1), (-2, -1)).reshape(-1, 3, 2))
        P = point_stress(flat, LAW_IDS[self.law], prestretch_row(self.path, float(lam)), float(self.E), float(self.h),
                         bool(self.tension_only), float(self.jm))
        return MembraneState(F, W, np.moveaxis(P.reshape(*F.shape[2:], 3, 2), (-2, -1), (0, 1)))

    def energy(self, x: np.ndarray, lam: float) -> float:
        """Strain energy (N mm)."""
        return float(self._terms(x, lam, 0)[1].sum())

    def evaluate(self, x: np.ndarray, lam: float, order: int = 2
                 ) -> tuple[float, np.ndarray, sp.csr_matrix | None]:
        """Energy (N mm), gradient (3 nn,) in N, and (order 2) the tangent (3 nn, 3 nn) in N/mm."""
        _, We, fe, Ke = self._terms(x, lam, max(order, 1))
        g = np.bincount(self._vector_dofs.ravel(), weights=fe.ravel(), minlength=3 * self.n_nodes)
        K = self._pattern.matrix(Ke) if order >= 2 else None
        return float(We.sum()), g, K

    def element_energy_density(self, x: np.ndarray, lam: float) -> np.ndarray:
        """Strain energy per unit flat area of each element (N/mm)."""
        return self._terms(x, lam, 0)[1] / self._dx.sum(axis=1)

    def principal_tensions(self, x: np.ndarray, lam: float) -> tuple[np.ndarray, np.ndarray]:
        """Principal membrane tensions (N/mm, current length; descending) and the area ratio J
        (current / flat), both (nel, nqp)."""
        st = self.law_state(x, lam, order=1)
        a1, a2 = st.F[:, 0], st.F[:, 1]
        normal = np.cross(a1, a2, axis=0)
        J = np.linalg.norm(normal, axis=0)
        # Cauchy membrane tension sigma = P F^T / J, in an orthonormal tangent basis (e1, e2)
        e1 = a1 / np.linalg.norm(a1, axis=0)
        e2 = np.cross(normal / J, e1, axis=0)
        sigma = np.einsum("ij...,kj...->ik...", st.P, st.F) / J
        s11 = np.einsum("i...,ik...,k...->...", e1, sigma, e1)
        s22 = np.einsum("i...,ik...,k...->...", e2, sigma, e2)
        s12 = np.einsum("i...,ik...,k...->...", e1, sigma, e2)
        mean, rad = 0.5 * (s11 + s22), np.sqrt(0.25 * (s11 - s22) ** 2 + s12**2)
        return np.stack([mean + rad, mean - rad]), J
