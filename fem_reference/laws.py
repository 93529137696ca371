"""Membrane laws and their element assembly, compiled with numba.

Both laws are functions of the metric g = F^T F of the 3x2 deformation gradient, through its
three entries (g11, g22, g12). A law gives W and its first and second derivatives in them in
closed form; the chain rule to F and the sums over an element's quadrature points are one
compiled loop, which fills element vectors and matrices for a fixed sparsity pattern.

Laws (``membrane.law``), energies per unit flat area (N/mm), h the mounted thickness, lambda the
isotropic pre-stretch (an unequal one: :func:`prestretch_row`):

* ``"linear"``: W = E h / (2 lambda) sum_k eps_k^2, eps_k = lambda sqrt(m_k^T g m_k) - 1 over the
  lattice directions m_k at 0, 60 and 120 deg (the DR link net's continuum limit); with
  ``tension_only`` a family in compression (eps_k <= 0) carries nothing.
* ``"neo-hookean"``: W = mu h / 2 (I1 - 3), mu = E / 3, with the incompressible film's first
  invariant I1 = lambda^2 tr g + 1 / (lambda^4 det g) (the thickness stretch from det = 1);
* ``"gent"``: W = -mu h Jm / 2 ln(1 - (I1 - 3) / Jm), Jm = ``membrane.gent_jm``: neo-Hookean at
  small I1 - 3, stiffening without bound as I1 - 3 approaches Jm (the chains' locking). Past the
  lock the energy is infinite (W = inf, its derivatives inf: the solvers' checks stop there).

The two incompressible laws share one code path: W = mu h / 2 f(I1 - 3) with f(x) = x or
-Jm ln(1 - x / Jm), the chain rule through I1's closed-form derivatives in g.

An unequal pre-stretch P (2, 2) (:mod:`scenes.prestretch`): the linear law takes each lattice
direction's own pre-stretch lambda_k = 1 / |P^-1 m_k| in place of lambda (a fibre of flat
direction m_k rests at |P^-1 m_k| per unit flat length); the incompressible laws are evaluated
at lambda = 1 on the metric from the rest state, C = P g P.
"""

from __future__ import annotations

import numba
import numpy as np

LATTICE_ANGLES_DEG = (0.0, 60.0, 120.0)
"""Directions of the DR lattice lines (the base side is the x axis)."""

LAW_IDS = {"linear": 0, "neo-hookean": 1, "gent": 2}

_ANGLES = np.radians(LATTICE_ANGLES_DEG)
_DIRECTIONS = np.column_stack([np.cos(_ANGLES) ** 2, np.sin(_ANGLES) ** 2,
                               2.0 * np.cos(_ANGLES) * np.sin(_ANGLES)])
"""d(m^T g m)/d(g11, g22, g12) of each lattice direction m."""


def prestretch_row(path, lam: float) -> np.ndarray:
    """The laws' pre-stretch at path value ``lam`` of a :class:`scenes.prestretch.PrestretchPath`:
    (lambda_0, lambda_1, lambda_2, P11, P22, P12), the linear law's pre-stretch along each lattice
    direction and the tensor P's entries; (lam, lam, lam, lam, lam, 0) where isotropic."""
    if path.isotropic:
        return np.array([lam, lam, lam, lam, lam, 0.0])
    P = path.tensor(lam)
    directions = np.column_stack([np.cos(_ANGLES), np.sin(_ANGLES)])
    return np.concatenate([path.fibre_stretches(lam, directions), [P[0, 0], P[1, 1], P[0, 1]]])


@numba.njit(cache=True)
def _law(law: int, g: np.ndarray, pre: np.ndarray, E: float, h: float, tension_only: bool, jm: float,
         dW: np.ndarray, d2W: np.ndarray, order: int) -> float:
    """W (N/mm) at metric entries g = (g11, g22, g12); fills dW (3,) and d2W (3, 3) for order >= 1.
    ``pre``: :func:`prestretch_row`; ``jm``: Gent's Jm (only read by the Gent law)."""
    for a in range(3):
        dW[a] = 0.0
        for b in range(3):
            d2W[a, b] = 0.0
    if law == 0:
        W = 0.0
        for k in range(3):
            lam = pre[k]
            c = E * h / (2.0 * lam)
            v = _DIRECTIONS[k]
            s = v[0] * g[0] + v[1] * g[1] + v[2] * g[2]
            r = np.sqrt(s)
            eps = lam * r - 1.0
            if tension_only and eps <= 0.0:
                continue
            W += c * eps * eps
            if order >= 1:
                d1 = c * (lam * lam - lam / r)  # c d(eps^2)/ds
                d2 = 0.5 * c * lam / (s * r)
                for a in range(3):
                    dW[a] += d1 * v[a]
                    for b in range(3):
                        d2W[a, b] += d2 * v[a] * v[b]
        return W
    if pre[5] == 0.0 and pre[3] == pre[4]:
        return _incompressible(law, g, pre[3], E, h, jm, dW, d2W, order)
    # unequal: the law of C = P g P at lambda = 1, C = T g linear in g's entries, so
    # dW/dg = T^T dW/dC and d2W/dg2 = T^T d2W/dC2 T
    p11, p22, p12 = pre[3], pre[4], pre[5]
    T = np.array([[p11 * p11, p12 * p12, 2.0 * p11 * p12],
                  [p12 * p12, p22 * p22, 2.0 * p12 * p22],
                  [p11 * p12, p12 * p22, p11 * p22 + p12 * p12]])
    C = np.zeros(3)
    for i in range(3):
        C[i] = T[i, 0] * g[0] + T[i, 1] * g[1] + T[i, 2] * g[2]
    dC = np.zeros(3)
    d2C = np.zeros((3, 3))
    W = _incompressible(law, C, 1.0, E, h, jm, dC, d2C, order)
    if order >= 1:
        for a in range(3):
            for i in range(3):
                dW[a] += T[i, a] * dC[i]
                for b in range(3):
                    for j in range(3):
                        d2W[a, b] += T[i, a] * d2C[i, j] * T[j, b]
    return W


@numba.njit(cache=True)
def _incompressible(law: int, g: np.ndarray, lam: float, E: float, h: float, jm: float,
                    dW: np.ndarray, d2W: np.ndarray, order: int) -> float:
    """The neo-Hookean (law 1) and Gent (law 2) W at metric entries g and isotropic pre-stretch
    ``lam``, with dW and d2W (zeroed by the caller) for order >= 1."""
    c = E * h / 6.0  # mu h / 2
    q = lam ** -4
    D = g[0] * g[1] - g[2] * g[2]
    x = lam * lam * (g[0] + g[1]) + q / D - 3.0  # I1 - 3
    if law == 1:
        W, f1, f2 = c * x, c, 0.0  # c f, c f', c f''
    else:
        r = 1.0 - x / jm
        if r <= 0.0:  # past the lock: no finite energy
            W, f1, f2 = np.inf, np.inf, np.inf
        else:
            W, f1, f2 = -c * jm * np.log(r), c / r, c / (jm * r * r)
    if order >= 1:
        dD = (g[1], g[0], -2.0 * g[2])
        iD, iDD = -q / (D * D), 2.0 * q / (D * D * D)  # d(q / D)/dD, d2(q / D)/dD2
        dI = (iD * dD[0] + lam * lam, iD * dD[1] + lam * lam, iD * dD[2])  # dI1 / dg
        for a in range(3):
            dW[a] = f1 * dI[a]
            for b in range(3):
                d2W[a, b] = f1 * iDD * dD[a] * dD[b] + f2 * dI[a] * dI[b]
        d2W[0, 1] += f1 * iD
        d2W[1, 0] += f1 * iD
        d2W[2, 2] += -2.0 * f1 * iD
    return W


@numba.njit(cache=True)
def _metric_gradient(F: np.ndarray, Dg: np.ndarray) -> None:
    """Dg[c, i, j] = d g_c / d F_ij for c = g11, g22, g12."""
    for i in range(3):
        Dg[0, i, 0] = 2.0 * F[i, 0]
        Dg[0, i, 1] = 0.0
        Dg[1, i, 0] = 0.0
        Dg[1, i, 1] = 2.0 * F[i, 1]
        Dg[2, i, 0] = F[i, 1]
        Dg[2, i, 1] = F[i, 0]


@numba.njit(cache=True)
def element_terms(u: np.ndarray, dofs: np.ndarray, G: np.ndarray, dx: np.ndarray, law: int,
                  pre: np.ndarray, E: float, h: float, tension_only: bool, jm: float, order: int):
    """Energies, forces and tangents of all elements.

    Parameters
    ----------
    u
        Node displacements from the flat reference (nn, 3), mm (F = I + grad u: the flat
        state is exact).
    dofs
        (nel, nb) node ids of each element's basis functions.
    G
        (nel, nq, nb, 2) reference gradients of the scalar basis functions at the quadrature points.
    dx
        (nel, nq) quadrature weights times the Jacobian (mm^2).

    Returns
    -------
    W (nel, nq) energy densities, We (nel,) element energies (N mm), fe (nel, 3 nb) element forces
    (N, local DOF 3 a + i), Ke (nel, 3 nb, 3 nb) element tangents (N/mm); fe, Ke empty below
    the order that needs them.
    """
    nel, nq, nb = G.shape[0], G.shape[1], G.shape[2]
    n = 3 * nb
    W = np.zeros((nel, nq))
    We = np.zeros(nel)
    fe = np.zeros((nel if order >= 1 else 0, n))
    Ke = np.zeros((nel if order >= 2 else 0, n, n))
    F = np.zeros((3, 2))
    g = np.zeros(3)
    dW = np.zeros(3)
    d2W = np.zeros((3, 3))
    Dg = np.zeros((3, 3, 2))
    V = np.zeros((3, n))  # d g_c / d x_(a, i)
    for e in range(nel):
        for q in range(nq):
            for i in range(3):
                for j in range(2):
                    s = 1.0 if i == j else 0.0
                    for a in range(nb):
                        s += u[dofs[e, a], i] * G[e, q, a, j]
                    F[i, j] = s
            g[0] = F[0, 0] ** 2 + F[1, 0] ** 2 + F[2, 0] ** 2
            g[1] = F[0, 1] ** 2 + F[1, 1] ** 2 + F[2, 1] ** 2
            g[2] = F[0, 0] * F[0, 1] + F[1, 0] * F[1, 1] + F[2, 0] * F[2, 1]
            w = _law(law, g, pre, E, h, tension_only, jm, dW, d2W, order)
            W[e, q] = w
            We[e] += w * dx[e, q]
            if order < 1:
                continue
            _metric_gradient(F, Dg)
            for c in range(3):
                for a in range(nb):
                    for i in range(3):
                        V[c, 3 * a + i] = Dg[c, i, 0] * G[e, q, a, 0] + Dg[c, i, 1] * G[e, q, a, 1]
            for r in range(n):
                fe[e, r] += dx[e, q] * (dW[0] * V[0, r] + dW[1] * V[1, r] + dW[2] * V[2, r])
            if order < 2:
                continue
            for r in range(n):
                for c in range(3):
                    t = 0.0
                    for d in range(3):
                        t += d2W[c, d] * V[d, r]
                    t *= dx[e, q]
                    if t != 0.0:
                        for s in range(n):
                            Ke[e, r, s] += t * V[c, s]
            # d2 g / dx2: the metric is quadratic in x, the same 3x3 identity in (i, k) per pair
            for a in range(nb):
                ga0, ga1 = G[e, q, a, 0], G[e, q, a, 1]
                for b in range(nb):
                    gb0, gb1 = G[e, q, b, 0], G[e, q, b, 1]
                    geo = dx[e, q] * (2.0 * dW[0] * ga0 * gb0 + 2.0 * dW[1] * ga1 * gb1
                                      + dW[2] * (ga0 * gb1 + ga1 * gb0))
                    for i in range(3):
                        Ke[e, 3 * a + i, 3 * b + i] += geo
    return W, We, fe, Ke


@numba.njit(cache=True)
def point_stress(F: np.ndarray, law: int, pre: np.ndarray, E: float, h: float, tension_only: bool,
                 jm: float) -> np.ndarray:
    """First Piola-Kirchhoff membrane stress P = dW/dF (npts, 3, 2), N/mm, at gradients F (npts, 3, 2)."""
    P = np.zeros(F.shape)
    g = np.zeros(3)
    dW = np.zeros(3)
    d2W = np.zeros((3, 3))
    Dg = np.zeros((3, 3, 2))
    for p in range(F.shape[0]):
        Fp = F[p]
        g[0] = Fp[0, 0] ** 2 + Fp[1, 0] ** 2 + Fp[2, 0] ** 2
        g[1] = Fp[0, 1] ** 2 + Fp[1, 1] ** 2 + Fp[2, 1] ** 2
        g[2] = Fp[0, 0] * Fp[0, 1] + Fp[1, 0] * Fp[1, 1] + Fp[2, 0] * Fp[2, 1]
        _law(law, g, pre, E, h, tension_only, jm, dW, d2W, 1)
        _metric_gradient(Fp, Dg)
        for i in range(3):
            for j in range(2):
                P[p, i, j] = dW[0] * Dg[0, i, j] + dW[1] * Dg[1, i, j] + dW[2] * Dg[2, i, j]
    return P
