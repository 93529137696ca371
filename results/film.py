"""The film's own fields, per triangle, for ParaView: principal stretches, Cauchy stress, current
thickness, slack state and Maxwell pressure, from each triangle's deformation gradient.

Both solvers give F (3x2, from the flat mounted state; the rest state is that state shrunk by
1/lambda) per membrane triangle: DR of its constant-strain triangles, the FEM at each element's
centroid. The laws are those of ``fem_reference.laws`` and ``dr.triangles`` (W per unit flat
area, h the mounted thickness), written here in the form that gives the stress directly: with
C = F^T F, the Cauchy stress is sigma = F S F^T, S the 2x2 tensor below, and its principal
values are the eigenvalues of S C.

* linear (the link net's continuum law): S = E sum_k eps_k / |F m_k| m_k m_k^T over the lattice
  directions m_k at 0, 60, 120 deg, eps_k = lambda |F m_k| - 1 (not below 0 with
  ``tension_only``); sigma = E sum_k eps_k |F m_k| e_k e_k^T;
* neo-Hookean and Gent: S = mu f'(I1 - 3) (lambda^2 I - lambda^-4 C^-1 / det C), mu = E / 3,
  f' = 1 (neo-Hookean) or 1 / (1 - (I1 - 3) / Jm) (Gent); principal values
  mu f' (l_i^2 - 1 / (l_1 l_2)^2) in the principal stretches l_i.

The thickness is the film's volume kept: h = h_m / J = h_0 / (l_1 l_2), J = sqrt(det C) the area
ratio current / flat and h_0 = h_m lambda^2 the unstretched thickness; for the linear law too
(the elastomer is incompressible; the net's law sets no thickness of its own). Stress is force
per current cross-section, tension / h. See docs/metrics.md, "Film fields".
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

TAUT, PARTLY_SLACK, SLACK = 0, 1, 2
"""``slack_state`` codes: every family in tension; some family slack (a tension field, where
the real film wrinkles); every family slack."""

SLACK_FRACTION = 1e-9
"""A principal direction of an incompressible film is slack where its stress is not above this
fraction of the largest principal stress of the film (as the FEM's slack fractions)."""

LATTICE_ANGLES_DEG = (0.0, 60.0, 120.0)
"""The link families of the linear law (the base side is the x axis)."""

_M = np.column_stack([np.cos(np.radians(LATTICE_ANGLES_DEG)), np.sin(np.radians(LATTICE_ANGLES_DEG))])

@dataclass(frozen=True)
class FilmLaw:
    """What the film fields need of the scene.

    Attributes
    ----------
    law
        'linear', 'neo-hookean' or 'gent'.
    E
        Young's modulus, MPa.
    thickness
        Mounted (flat, pre-stretched) thickness h_m, mm.
    prestretch
        lambda, -: the pre-stretch's path value (the pre-stretch itself where isotropic).
    tension_only
        A compressed link family carries nothing (linear law).
    gent_jm
        Gent's Jm, -.
    permittivity
        Absolute permittivity eps0 eps_r, N/V^2 (with V in volts and h in mm, eps (V/h)^2 is in MPa).
    voltage
        Voltage across the film, V: one for the whole film or one per triangle (0 where no
        electrode covers it; ``scenes.electric.effective_voltage`` where one covers part).
    electric_thickness
        Mounted thickness for the electric field, mm (``scenes.electric.mounted_thickness``).
    prestretch_tensor
        An unequal pre-stretch's tensor P (2, 2) in the flat x, y (``scenes.prestretch``); None
        where isotropic.
    """

    law: str
    E: float
    thickness: float
    prestretch: float
    tension_only: bool = True
    gent_jm: float = np.inf
    permittivity: float = 0.0
    voltage: float | np.ndarray = 0.0
    electric_thickness: float | None = None
    prestretch_tensor: np.ndarray | None = None

    @classmethod
    def of_scene(cls, scene: Any, cover: np.ndarray) -> "FilmLaw":
        """The film of a ``scenes.Scene`` at its pre-stretch and voltage, over triangles whose
        shares under the scene's electrodes are ``cover`` (t, e) (``scenes.electric.electrode_coverage``)."""
        # results must not need scenes for plain use
        from scenes.electric import EPSILON_0, effective_voltage, mounted_thickness

        m = scene.membrane
        path = scene.prestretch_path
        return cls(m.law, m.E, m.thickness, scene.prestretch, m.tension_only, m.gent_jm,
                   EPSILON_0 * m.permittivity, effective_voltage(scene, cover),
                   mounted_thickness(scene),
                   None if path.isotropic else path.tensor(scene.prestretch))


def triangle_gradients(flat: np.ndarray, x: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Deformation gradients (t, 3, 2) of straight triangles from flat positions (n, 2+) mm to
    current positions x (n, 3) mm."""
    X = np.asarray(flat, float)[:, :2][triangles]
    p = np.asarray(x, float)[triangles]
    dX = np.stack([X[:, 1] - X[:, 0], X[:, 2] - X[:, 0]], axis=2)  # (t, 2, 2) columns: edges
    dx = np.stack([p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]], axis=2)  # (t, 3, 2)
    return dx @ np.linalg.inv(dX)


def family_strains(F: np.ndarray, prestretch: float, tensor: np.ndarray | None = None) -> np.ndarray:
    """Strains (t, 3) from the rest state of the linear law's link families, lambda_k |F m_k| - 1:
    lambda_k = ``prestretch``, or 1 / |P^-1 m_k| for a pre-stretch ``tensor`` P (2, 2)."""
    if tensor is None:
        return prestretch * np.linalg.norm(F @ _M.T, axis=1) - 1.0
    lams = 1.0 / np.linalg.norm(np.linalg.solve(tensor, _M.T), axis=0)
    return lams * np.linalg.norm(F @ _M.T, axis=1) - 1.0


# a triangle collapsed in a fold has J = 0 (or a round-off below): its thickness and stresses
# are inf or NaN in the fields a viewer shows, not warnings on the user's console
@np.errstate(divide="ignore", invalid="ignore")
def film_fields(F: np.ndarray, film: FilmLaw, strains: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Per-triangle film fields (names carry the units) at deformation gradients F (t, 3, 2).

    ``strains`` (t, 3) replace the linear law's family strains where the solver's elements have
    their own (the clustered net: one strain per cable); NaN entries keep the triangle's.
    Principal values are in descending order.
    """
    F = np.asarray(F, float)
    C = np.swapaxes(F, 1, 2) @ F
    det = C[:, 0, 0] * C[:, 1, 1] - C[:, 0, 1] ** 2
    J = np.sqrt(np.maximum(det, 0.0))
    lam, P = film.prestretch, film.prestretch_tensor
    if film.law == "linear":
        eps = family_strains(F, lam, P)
        if strains is not None:
            eps = np.where(np.isnan(strains), eps, strains)
        carried = np.maximum(eps, 0.0) if film.tension_only else eps
        length = np.linalg.norm(F @ _M.T, axis=1)
        S = film.E * np.einsum("tk,ki,kj->tij", carried / length, _M, _M)
        n_slack = np.sum(eps <= 0.0, axis=1)
        n_families = 3
    elif film.law in ("neo-hookean", "gent") and P is not None:
        # from the rest state: C_r = P C P, S = E / 3 f'(I1 - 3) P (I - C_r^-1 / det C_r) P
        Cr = P @ C @ P
        det_r = Cr[:, 0, 0] * Cr[:, 1, 1] - Cr[:, 0, 1] ** 2
        x = Cr[:, 0, 0] + Cr[:, 1, 1] + 1.0 / det_r - 3.0  # I1 - 3
        df = _law_slope(film, x)
        S = (film.E / 3.0 * df)[:, None, None] * (P @ (np.eye(2) - np.linalg.inv(Cr) / det_r[:, None, None]) @ P)
        n_slack, n_families = None, 2
    elif film.law in ("neo-hookean", "gent"):
        x = lam**2 * (C[:, 0, 0] + C[:, 1, 1]) + 1.0 / (lam**4 * det) - 3.0  # I1 - 3
        df = _law_slope(film, x)
        C_inv = np.linalg.inv(C)
        S = (film.E / 3.0 * df)[:, None, None] * (lam**2 * np.eye(2) - C_inv / (lam**4 * det)[:, None, None])
        n_slack, n_families = None, 2
    else:
        raise ValueError(f"membrane law {film.law!r} is not one of linear, neo-hookean, gent")
    stress = _eigenvalues(S @ C)
    if n_slack is None:
        floor = SLACK_FRACTION * max(float(np.nanmax(np.abs(stress), initial=0.0)), 1e-300)
        n_slack = np.sum(stress <= floor, axis=1)
    state = np.where(n_slack == 0, TAUT, np.where(n_slack == n_families, SLACK, PARTLY_SLACK))
    stretch = (lam * np.sqrt(np.maximum(_eigenvalues(C), 0.0)) if P is None
               else np.sqrt(np.maximum(_eigenvalues(P @ C @ P), 0.0)))
    electric = film.thickness if film.electric_thickness is None else film.electric_thickness
    return {
        "stretch_1": stretch[:, 0],
        "stretch_2": stretch[:, 1],
        "cauchy_stress_1_MPa": stress[:, 0],
        "cauchy_stress_2_MPa": stress[:, 1],
        "thickness_mm": film.thickness / J,
        "slack_state": state.astype(float),
        "maxwell_pressure_MPa": film.permittivity * (film.voltage * J / electric) ** 2,
    }


def _law_slope(film: FilmLaw, x: np.ndarray) -> np.ndarray:
    """f'(I1 - 3) of the incompressible laws: 1 (neo-Hookean), 1 / (1 - x / Jm) (Gent; inf past the lock)."""
    if film.law == "gent":
        with np.errstate(divide="ignore"):
            return np.where(x < film.gent_jm, 1.0 / (1.0 - x / film.gent_jm), np.inf)
    return np.ones_like(x)


def _eigenvalues(A: np.ndarray) -> np.ndarray:
    """Eigenvalues (t, 2), descending, of 2x2 matrices (t, 2, 2) with real eigenvalues (a
    symmetric matrix, or the product of a symmetric and a positive definite one)."""
    half_trace = 0.5 * (A[:, 0, 0] + A[:, 1, 1])
    # the discriminant from the half difference, not trace^2 / 4 - det: no cancellation at
    # equal eigenvalues (an equibiaxial film)
    r = np.sqrt(np.maximum((0.5 * (A[:, 0, 0] - A[:, 1, 1])) ** 2 + A[:, 0, 1] * A[:, 1, 0], 0.0))
    return np.column_stack([half_trace + r, half_trace - r])
