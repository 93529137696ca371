"""Pre-stretched membrane: hyperelastic laws on the flat reference, assembled with scikit-fem.

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
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
import scipy.sparse as sp
from skfem import BilinearForm, Functional, LinearForm
from skfem.helpers import grad

from .jet import Jet, sqrt, where

LATTICE_ANGLES_DEG = (0.0, 60.0, 120.0)
"""Directions of the DR lattice lines (the base side is the x axis)."""


# ----------------------------------------------------------------------------- laws


class Stretches:
    """Quadratic invariants (F u) . (F v) of deformation gradients F (batch, 3, 2).

    With ``order`` 0 they are plain arrays (energy only); otherwise jets in the six entries of F
    (variable 2 i + j is F_ij), whose Hessians are constant, so a law written on them gets its
    exact first and second derivatives cheaply.
    """

    def __init__(self, F: np.ndarray, order: int):
        self.F, self.order = F, order

    def pair(self, u: np.ndarray, v: np.ndarray):
        u, v = np.asarray(u, float), np.asarray(v, float)
        Fu, Fv = self.F @ u, self.F @ v  # (batch, 3)
        val = np.einsum("si,si->s", Fu, Fv)
        if self.order == 0:
            return val
        grad = (Fv[:, :, None] * u + Fu[:, :, None] * v).reshape(-1, 6)
        block = np.outer(u, v) + np.outer(v, u)  # (2, 2)
        hess = np.einsum("ik,jl->ijkl", np.eye(3), block).reshape(6, 6)
        return Jet(val, grad, np.broadcast_to(hess, (val.size, 6, 6)))


def linear_law(st: Stretches, lam: float, E: float, h: float, tension_only: bool):
    """Link-net law W (N/mm): W = E h / (2 lambda) sum_k eps_k^2, eps_k = lambda |F m_k| - 1."""
    W = 0.0
    for angle in np.radians(LATTICE_ANGLES_DEG):
        m = np.array([np.cos(angle), np.sin(angle)])
        eps = sqrt(st.pair(m, m)) * lam - 1.0
        if tension_only:
            eps = where((eps.val if isinstance(eps, Jet) else eps) > 0.0, eps, 0.0)
        W = eps * eps + W
    return W * (E * h / (2.0 * lam))


def neo_hookean_law(st: Stretches, lam: float, E: float, h: float, tension_only: bool):
    """Incompressible neo-Hookean membrane W (N/mm); ``tension_only`` does not apply."""
    e1, e2 = np.array([1.0, 0.0]), np.array([0.0, 1.0])
    g11, g22, g12 = st.pair(e1, e1), st.pair(e2, e2), st.pair(e1, e2)
    det_c = (g11 * g22 - g12 * g12) * lam**4
    mu = E / 3.0
    return ((g11 + g22) * lam**2 + 1.0 / det_c - 3.0) * (mu * h / 2.0)


LAWS: dict[str, Callable] = {"linear": linear_law, "neo-hookean": neo_hookean_law}


# ----------------------------------------------------------------------------- forms


def _field(w, name: str) -> np.ndarray:
    """A quadrature-point array passed to a form, as a plain view (no copy)."""
    return w[name].view(np.ndarray)


@Functional
def _energy_form(w):
    return _field(w, "W")


@LinearForm
def _residual_form(v, w):
    return np.einsum("ij...,ij...->...", _field(w, "P"), grad(v))


@BilinearForm
def _tangent_form(u, v, w):
    return np.einsum("ijkl...,ij...,kl...->...", _field(w, "A"), grad(v), grad(u))


@dataclass
class MembraneState:
    """Law evaluated at the quadrature points: W (nel, nqp), P (3, 2, nel, nqp), F likewise."""

    F: np.ndarray
    W: np.ndarray
    P: np.ndarray | None
    A: np.ndarray | None


class Membrane:
    """The membrane's energy, nodal forces and tangent on a scikit-fem vector basis.

    Parameters
    ----------
    basis
        ``Basis(mesh, ElementVector(ElementTriP1() or ElementTriP2(), 3))`` on the flat mesh;
        its DOF 3 i + c is component c of node i (vertices first, then edge nodes).
    law, E, h, tension_only
        ``membrane.law``, Young's modulus (MPa), mounted thickness (mm), slack links carry nothing.
    """

    def __init__(self, basis, law: str, E: float, h: float, tension_only: bool):
        if law not in LAWS:
            raise ValueError(f"membrane.law = {law!r} is not one of {', '.join(LAWS)}")
        self.basis = basis
        self.law, self.E, self.h, self.tension_only = law, E, h, tension_only
        locs = basis.doflocs[:, ::3]  # one location per node
        self.X = np.column_stack([locs[0], locs[1], np.zeros(locs.shape[1])])  # (nn, 3) mm

    @property
    def n_nodes(self) -> int:
        return self.X.shape[0]

    def deformation_gradient(self, x: np.ndarray) -> np.ndarray:
        """F (3, 2, nel, nqp) at the quadrature points for node positions x (nn, 3)."""
        u = (x - self.X).ravel()
        return np.eye(3, 2)[:, :, None, None] + self.basis.interpolate(u).grad

    def law_state(self, x: np.ndarray, lam: float, order: int = 2) -> MembraneState:
        """W, P = dW/dF and (order 2) A = d2W/dF2 at the quadrature points."""
        F = self.deformation_gradient(x)
        shape = F.shape[2:]
        flat = np.moveaxis(F, (0, 1), (-2, -1)).reshape(-1, 3, 2)
        W = LAWS[self.law](Stretches(flat, order), lam, self.E, self.h, self.tension_only)
        if order == 0:
            return MembraneState(F, np.broadcast_to(W, (flat.shape[0],)).reshape(shape), None, None)
        # contiguous (component, ..., element, point) arrays: the forms sweep them hundreds of times
        P = np.ascontiguousarray(np.moveaxis(W.grad.reshape(*shape, 3, 2), (-2, -1), (0, 1)))
        A = None
        if order >= 2:
            A = np.ascontiguousarray(
                np.moveaxis(W.hess.reshape(*shape, 3, 2, 3, 2), (-4, -3, -2, -1), (0, 1, 2, 3)))
        return MembraneState(F, W.val.reshape(shape), P, A)

    def energy(self, x: np.ndarray, lam: float) -> float:
        """Strain energy (N mm)."""
        st = self.law_state(x, lam, order=0)
        return float(_energy_form.assemble(self.basis, W=st.W))

    def evaluate(self, x: np.ndarray, lam: float, order: int = 2
                 ) -> tuple[float, np.ndarray, sp.csr_matrix | None]:
        """Energy (N mm), gradient (3 nn,) in N, and (order 2) the tangent (3 nn, 3 nn) in N/mm."""
        st = self.law_state(x, lam, order)
        e = float(_energy_form.assemble(self.basis, W=st.W))
        g = _residual_form.assemble(self.basis, P=st.P)
        K = _tangent_form.assemble(self.basis, A=st.A).tocsr() if order >= 2 else None
        return e, g, K

    def element_energy_density(self, x: np.ndarray, lam: float) -> np.ndarray:
        """Strain energy per unit flat area of each element (N/mm)."""
        st = self.law_state(x, lam, order=0)
        total = _energy_form.elemental(self.basis, W=st.W)
        area = Functional(lambda w: 1.0 + 0.0 * w.x[0]).elemental(self.basis)
        return total / area

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
