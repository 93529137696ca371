"""Closed-form answers that the solvers are checked against (none of them is produced by a solver).

Lengths in mm, forces in N, EI in N mm^2.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq
from scipy.special import ellipe, ellipeinc, ellipk, ellipkinc


def elastica_cantilever(alpha: float) -> tuple[float, float, float]:
    """Tip of an inextensible cantilever under a fixed vertical tip load (Bisshopp & Drucker 1945).

    Clamped horizontally, load P at the free end, alpha = P L^2 / EI. With the tip angle
    theta_0, k^2 = (1 + sin theta_0) / 2 and sin phi_1 = 1 / (k sqrt 2), the elliptic integrals
    give sqrt(alpha) = K(k) - F(phi_1, k), the deflection z/L = 1 - 2/sqrt(alpha) (E(k) - E(phi_1, k))
    and the horizontal reach x/L = sqrt(2 sin(theta_0) / alpha).

    Returns (x_L / L, deflection z_L / L, theta_0 in rad).
    """
    if not alpha > 0:
        raise ValueError("alpha = P L^2 / EI must be positive")

    def parts(theta0: float) -> tuple[float, float, float]:
        m = (1 + np.sin(theta0)) / 2
        phi1 = np.arcsin(min(1.0, 1 / np.sqrt(2 * m)))
        return m, phi1, ellipk(m) - ellipkinc(phi1, m)

    theta0 = brentq(lambda t: parts(t)[2] - np.sqrt(alpha), 1e-12, np.pi / 2 - 1e-12, xtol=1e-15, rtol=1e-15)
    m, phi1, _ = parts(theta0)
    z = 1 - 2 / np.sqrt(alpha) * (ellipe(m) - ellipeinc(phi1, m))
    x = np.sqrt(2 * np.sin(theta0) / alpha)
    return float(x), float(z), float(theta0)


def arc_under_end_moment(length: float, EI: float, moment: float) -> tuple[np.ndarray, float]:
    """A straight cantilever under an end moment bends into a circular arc of radius EI/M.

    Returns the tip position (x, z) for a beam along +x clamped at the origin, bending towards
    +z, and the radius (mm).
    """
    radius = EI / moment
    phi = length / radius
    return np.array([radius * np.sin(phi), radius * (1 - np.cos(phi))]), radius


def catenary_sag(span: float, length: float) -> float:
    """Mid-span sag of an inextensible chain of ``length`` hung between two points ``span``
    apart at equal height (the catenary y = a cosh(x/a): length = 2 a sinh(span / 2a))."""
    if length <= span:
        raise ValueError("a hanging chain must be longer than its span")
    a = brentq(lambda a: 2 * a * np.sinh(span / (2 * a)) - length, span * 1e-3, span * 1e6)
    return float(a * (np.cosh(span / (2 * a)) - 1))


def sliding_cable(span: float, rest_length: float, EA: float, load: float) -> tuple[float, float]:
    """A cable over a frictionless pulley (the loaded node) between two supports at equal height.

    The pulley settles at mid-span (equal tension both sides). Solves for the sag d and the
    tension T: T = EA/L0 (L - L0), L = 2 sqrt((span/2)^2 + d^2), 2 T d / (L/2) = load.
    Returns (sag mm, tension N).
    """
    half = span / 2

    def balance(d: float) -> float:
        L = 2 * np.hypot(half, d)
        t = EA / rest_length * (L - rest_length)
        return 2 * t * d / (L / 2) - load

    d = brentq(balance, 1e-12, 10 * span)
    L = 2 * np.hypot(half, d)
    return float(d), float(EA / rest_length * (L - rest_length))
