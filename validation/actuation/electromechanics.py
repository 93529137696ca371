"""Closed forms of the ideal dielectric elastomer film (none of them produced by a solver).

Units: V, mm, N, MPa; eps = eps0 eps_r in N/V^2 (see :mod:`scenes.electric`). The film is
incompressible with unstretched thickness H; under an equibiaxial stretch lambda its thickness is
H / lambda^2 and the electric field E = V lambda^2 / H.

Free film (no mechanical load), equibiaxial, ideal dielectric (Zhao & Suo 2007): the nominal
mechanical stress balances the Maxwell stress, sigma_mech(lambda) = eps E^2. For the neo-Hookean
law sigma_mech = mu (lambda^2 - lambda^-4), so

    V / (H sqrt(mu / eps)) = sqrt(lambda^-2 - lambda^-8),

which peaks at lambda = 4^(1/6) ~ 1.26 with V~ = 0.687: beyond that voltage no equilibrium is
stable (pull-in, electromechanical instability). The Gent law (locking stretch) changes
sigma_mech to mu (lambda^2 - lambda^-4) / (1 - (2 lambda^2 + lambda^-4 - 3) / Jm).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq, minimize_scalar

from scenes.electric import EPSILON_0


def maxwell_stress(voltage: float, thickness: float, permittivity: float) -> float:
    """Electrostatic (Maxwell) stress eps0 eps_r (V / h)^2, MPa, of a film of thickness h (mm)."""
    return EPSILON_0 * permittivity * (voltage / thickness) ** 2


def capacitor_energy(voltage: float, area: float, thickness: float, permittivity: float) -> float:
    """E_cap = A C V^2 / 2 with C = eps0 eps_r / h per unit area, N mm (area mm^2, h mm)."""
    return 0.5 * area * EPSILON_0 * permittivity / thickness * voltage**2


def gent_jm(locking_stretch: float) -> float:
    """Gent's Jm = I1_max - 3 for a uniaxial locking stretch: lambda^2 + 2 / lambda - 3."""
    return locking_stretch**2 + 2.0 / locking_stretch - 3.0


def equibiaxial_mechanical_stress(stretch, mu: float, jm: float | None = None):
    """True in-plane stress (MPa) of an incompressible film at equibiaxial ``stretch``:
    neo-Hookean mu (l^2 - l^-4), or Gent (``jm``) divided by 1 - (I1 - 3) / Jm."""
    lam = np.asarray(stretch, dtype=float)
    s = mu * (lam**2 - lam**-4)
    if jm is not None:
        s = s / (1.0 - (2 * lam**2 + lam**-4 - 3.0) / jm)
    return s


def free_film_voltage(stretch, mu: float, thickness: float, permittivity: float,
                      jm: float | None = None):
    """Voltage (V) that holds a free film at equibiaxial ``stretch`` (mu MPa, unstretched
    thickness H mm): eps (V lambda^2 / H)^2 = sigma_mech(lambda)."""
    lam = np.asarray(stretch, dtype=float)
    eps = EPSILON_0 * permittivity
    return thickness / lam**2 * np.sqrt(equibiaxial_mechanical_stress(lam, mu, jm) / eps)


def gent_lock_stretch(jm: float) -> float:
    """Equibiaxial stretch at which the Gent film locks: 2 lambda^2 + lambda^-4 - 3 = Jm."""
    return float(brentq(lambda l: 2 * l**2 + l**-4 - 3.0 - jm, 1.0, np.sqrt(jm + 3.0), xtol=1e-14))


def free_film_pull_in(mu: float, thickness: float, permittivity: float,
                      jm: float | None = None) -> tuple[float, float] | None:
    """(stretch, voltage V) at the first peak of the free film's voltage-stretch curve: the
    pull-in; None if the curve rises all the way to the lock (no pull-in).

    Neo-Hookean: lambda = 4^(1/6), V = 0.687 H sqrt(mu / eps). A Gent film re-stiffens near its
    locking stretch: for large Jm the curve peaks (later and higher than neo-Hookean), falls to a
    valley and rises again (the snap-through of Zhao, Hong & Suo 2007); for Jm below about 7.3
    the peak and the valley merge and the curve rises monotonically: no pull-in.
    """
    if jm is None:
        lam = 4.0 ** (1.0 / 6.0)
        return lam, float(free_film_voltage(lam, mu, thickness, permittivity))
    lock = gent_lock_stretch(jm)
    lam = np.linspace(1.0, lock, 20001)[1:-1]
    v = free_film_voltage(lam, mu, thickness, permittivity, jm)
    falls = np.flatnonzero(np.diff(v) <= 0.0)
    if falls.size == 0:
        return None
    k = falls[0]  # the first peak lies within one grid step either side of lam[k]
    opt = minimize_scalar(lambda l: -free_film_voltage(l, mu, thickness, permittivity, jm),
                          bounds=(lam[max(k - 1, 0)], lam[k + 1]), method="bounded",
                          options={"xatol": 1e-12})
    return float(opt.x), float(-opt.fun)


def free_film_stretch(voltage: float, mu: float, thickness: float, permittivity: float,
                      jm: float | None = None) -> float:
    """Equibiaxial stretch of a free film at ``voltage`` on the stable branch (below pull-in;
    a Gent film without pull-in has one branch up to its lock).

    Raises
    ------
    ValueError
        If ``voltage`` is above the pull-in voltage (no stable equilibrium).
    """
    peak = free_film_pull_in(mu, thickness, permittivity, jm)
    if peak is not None and voltage > peak[1]:
        raise ValueError(f"voltage {voltage:g} V is above the pull-in voltage {peak[1]:.6g} V")
    if voltage == 0:
        return 1.0
    top = peak[0] if peak is not None else gent_lock_stretch(jm) * (1 - 1e-12)
    return float(brentq(lambda l: free_film_voltage(l, mu, thickness, permittivity, jm) - voltage,
                        1.0, top, xtol=1e-14, rtol=1e-14))


def flat_film_tension(law: str, E: float, thickness: float, prestretch: float,
                      jm: float | None = None) -> float:
    """Isotropic tension (N/mm) of the flat film mounted at ``prestretch`` (mounted thickness
    h mm, E MPa): the link-net law 3/2 E h (lambda - 1); neo-Hookean E/3 h (lambda^2 - lambda^-4);
    Gent (``jm``) that divided by 1 - (I1 - 3) / Jm."""
    if law == "linear":
        return 1.5 * E * thickness * (prestretch - 1.0)
    if law == "neo-hookean":
        return thickness * float(equibiaxial_mechanical_stress(prestretch, E / 3.0))
    if law == "gent":
        return thickness * float(equibiaxial_mechanical_stress(prestretch, E / 3.0, jm))
    raise ValueError(f"membrane law {law!r} has no closed-form flat tension here")


def zero_tension_voltage(tension: float, thickness: float, permittivity: float) -> float:
    """Voltage (V) at which the Maxwell stress cancels a flat film's ``tension`` (N/mm):
    eps0 eps_r V^2 / h = T, with h the film's (electrical) thickness, mm.

    A DEMES frame is flat-stable only once its film has (almost) no tension left, so this is
    the flattening voltage up to the frame's small buckling tension (docs/actuation.md).
    """
    return float(np.sqrt(tension * thickness / (EPSILON_0 * permittivity)))
