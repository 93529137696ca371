"""The rod's stencil energies with exact first and second derivatives, compiled with numba.

Each stencil (a vertex with its two edges and their director points, or an edge) is evaluated
with second-order forward-mode differentiation in its own n = 3 m coordinates (m points): a
quantity is a flat array [value, gradient (n), Hessian (n x n)], so that sums and constant
multiples are plain array operations and products and functions apply the chain rule. With
n = 0 the same code gives values only. The geometry is described in :mod:`fem_reference.frame`.
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np

PAPER, STRIP = 0, 1
"""Model ids of the bending energy."""


@numba.njit(cache=True, inline="always")
def _size(a: np.ndarray) -> int:
    """n of a jet of length 1 + n + n^2."""
    return (int(np.sqrt(4.0 * a.size - 3.0) + 0.5) - 1) // 2


@numba.njit(cache=True)
def _variable(value: float, index: int, n: int) -> np.ndarray:
    a = np.zeros(1 + n + n * n)
    a[0] = value
    if n > 0:
        a[1 + index] = 1.0
    return a


@numba.njit(cache=True)
def _constant(value: float, n: int) -> np.ndarray:
    a = np.zeros(1 + n + n * n)
    a[0] = value
    return a


@numba.njit(cache=True)
def _mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    n = _size(a)
    r = np.empty_like(a)
    a0, b0 = a[0], b[0]
    r[0] = a0 * b0
    for i in range(1, 1 + n):
        r[i] = a0 * b[i] + b0 * a[i]
    for i in range(n):
        ai, bi = a[1 + i], b[1 + i]
        row = 1 + n + i * n
        for j in range(n):
            r[row + j] = a0 * b[row + j] + b0 * a[row + j] + ai * b[1 + j] + bi * a[1 + j]
    return r


@numba.njit(cache=True)
def _apply(a: np.ndarray, f: float, df: float, d2f: float) -> np.ndarray:
    """Chain rule for a scalar function with value f and derivatives df, d2f at a's value."""
    n = _size(a)
    r = np.empty_like(a)
    r[0] = f
    for i in range(1, 1 + n):
        r[i] = df * a[i]
    for i in range(n):
        ai = d2f * a[1 + i]
        row = 1 + n + i * n
        for j in range(n):
            r[row + j] = df * a[row + j] + ai * a[1 + j]
    return r


@numba.njit(cache=True)
def _sqrt(a: np.ndarray) -> np.ndarray:
    s = np.sqrt(a[0])
    return _apply(a, s, 0.5 / s, -0.25 / (s * a[0]))


@numba.njit(cache=True)
def _put(out: np.ndarray, s: int, jet: np.ndarray) -> None:
    """Row s of ``out`` = ``jet``, element by element: a row assignment compiles numpy's shape
    checks with their error messages, about 3 s of CPU on a fresh cache."""
    for i in range(jet.size):
        out[s, i] = jet[i]


@numba.njit(cache=True)
def _reciprocal(a: np.ndarray) -> np.ndarray:
    r = 1.0 / a[0]
    return _apply(a, r, -r * r, 2.0 * r * r * r)


@numba.njit(cache=True)
def _dot(u, v) -> np.ndarray:
    return _mul(u[0], v[0]) + _mul(u[1], v[1]) + _mul(u[2], v[2])


@numba.njit(cache=True)
def _cross(u, v):
    return (_mul(u[1], v[2]) - _mul(u[2], v[1]),
            _mul(u[2], v[0]) - _mul(u[0], v[2]),
            _mul(u[0], v[1]) - _mul(u[1], v[0]))


@numba.njit(cache=True)
def _scaled(u, s: np.ndarray):
    return (_mul(u[0], s), _mul(u[1], s), _mul(u[2], s))


@numba.njit(cache=True)
def _unit(u):
    return _scaled(u, _reciprocal(_sqrt(_dot(u, u))))


@numba.njit(cache=True)
def _point(P: np.ndarray, j: int, n: int):
    """Point j of a stencil as three jets (its coordinates are variables 3 j + c)."""
    return (_variable(P[j, 0], 3 * j, n), _variable(P[j, 1], 3 * j + 1, n),
            _variable(P[j, 2], 3 * j + 2, n))


@numba.njit(cache=True)
def _frame(x0, x1, p, held: bool, rest: np.ndarray, with_directors: bool, n: int):
    """(t, d2, n) of an edge x0-x1 with director point p; a held edge keeps its rest frame."""
    if held and with_directors:
        return ((_constant(rest[0, 0], n), _constant(rest[0, 1], n), _constant(rest[0, 2], n)),
                (_constant(rest[1, 0], n), _constant(rest[1, 1], n), _constant(rest[1, 2], n)),
                (_constant(rest[2, 0], n), _constant(rest[2, 1], n), _constant(rest[2, 2], n)))
    t = _unit((x1[0] - x0[0], x1[1] - x0[1], x1[2] - x0[2]))
    if not with_directors:
        return t, t, t
    q = (p[0] - 0.5 * (x0[0] + x1[0]), p[1] - 0.5 * (x0[1] + x1[1]), p[2] - 0.5 * (x0[2] + x1[2]))
    qt = _dot(q, t)
    d2 = _unit((q[0] - _mul(t[0], qt), q[1] - _mul(t[1], qt), q[2] - _mul(t[2], qt)))
    return t, d2, _cross(t, d2)


@numba.njit(cache=True)
def _vertex_frames(P: np.ndarray, held_a: bool, held_b: bool, rest_a: np.ndarray,
                   rest_b: np.ndarray, with_directors: bool, n: int):
    xa, xm, xb = _point(P, 0, n), _point(P, 1, n), _point(P, 2, n)
    pa, pb = xa, xb  # placeholders without director points
    if with_directors:
        pa, pb = _point(P, 3, n), _point(P, 4, n)
    Ra = _frame(xa, xm, pa, held_a, rest_a, with_directors, n)
    Rb = _frame(xm, xb, pb, held_b, rest_b, with_directors, n)
    return Ra, Rb


@numba.njit(cache=True)
def _curvature(Ra, Rb, model: int):
    """Curvature-twist vector in (t, d2, n) axes ('strip') or the binormal kb ('paper')."""
    if model == PAPER:
        ta, tb = Ra[0], Rb[0]
        c = _dot(ta, tb)
        s = _apply(c, 2.0 / (1.0 + c[0]), -2.0 / (1.0 + c[0]) ** 2, 4.0 / (1.0 + c[0]) ** 3)
        return _scaled(_cross(ta, tb), s)
    q00, q11, q22 = _dot(Ra[0], Rb[0]), _dot(Ra[1], Rb[1]), _dot(Ra[2], Rb[2])
    tr = q00 + q11 + q22
    s = _apply(tr, 2.0 / (1.0 + tr[0]), -2.0 / (1.0 + tr[0]) ** 2, 4.0 / (1.0 + tr[0]) ** 3)
    k0 = _mul(_dot(Ra[2], Rb[1]) - _dot(Ra[1], Rb[2]), s)
    k1 = _mul(_dot(Ra[0], Rb[2]) - _dot(Ra[2], Rb[0]), s)
    k2 = _mul(_dot(Ra[1], Rb[0]) - _dot(Ra[0], Rb[1]), s)
    return k0, k1, k2


@numba.njit(cache=True)
def vertex_terms(P: np.ndarray, held_a: np.ndarray, held_b: np.ndarray, rest_a: np.ndarray,
                 rest_b: np.ndarray, rest_kappa: np.ndarray, weight: np.ndarray, model: int,
                 EI: float, EI_strong: float, GJ: float, with_directors: bool, order: int):
    """Bending and torsion energies (N mm) of vertex stencils, as jets.

    Parameters
    ----------
    P
        (S, m, 3) stencil points: previous, own and next node (+ the two edges' director points).
    held_a, held_b
        (S,) whether the edge before / after the vertex keeps its rest frame.
    rest_a, rest_b
        (S, 3, 3) rest frames (rows t, d2, n) of those edges.
    rest_kappa
        (S, 3) rest curvature vectors (the paper model uses their length).
    weight
        (S,) 1 / (2 l_v), 1/mm.
    order
        0: values only; otherwise values, gradients and Hessians in the 3 m coordinates.

    Returns
    -------
    kappa (S, 3) 1/mm; bending and torsion (S, 1 + n + n^2) jets, n = 3 m (0 with order 0).
    """
    S, m = P.shape[0], P.shape[1]
    n = 3 * m if order > 0 else 0
    kappa = np.zeros((S, 3))
    bending = np.zeros((S, 1 + n + n * n))
    torsion = np.zeros((S, 1 + n + n * n))
    for s in range(S):
        Ra, Rb = _vertex_frames(P[s], held_a[s], held_b[s], rest_a[s], rest_b[s], with_directors, n)
        k = _curvature(Ra, Rb, model)
        for c in range(3):
            kappa[s, c] = k[c][0]
        w = weight[s]
        if model == PAPER:
            k0 = np.sqrt(rest_kappa[s, 0] ** 2 + rest_kappa[s, 1] ** 2 + rest_kappa[s, 2] ** 2)
            e = _dot(k, k)
            b = e + 0.0
            if k0 > 0.0:
                b = b - 2.0 * k0 * _sqrt(e)
                b[0] += k0 * k0
            _put(bending, s, EI * w * b)
        else:
            d0, d1, d2 = k[0] + 0.0, k[1] + 0.0, k[2] + 0.0
            d0[0] -= rest_kappa[s, 0]
            d1[0] -= rest_kappa[s, 1]
            d2[0] -= rest_kappa[s, 2]
            _put(torsion, s, GJ * w * _mul(d0, d0))
            _put(bending, s, EI * w * _mul(d1, d1) + EI_strong * w * _mul(d2, d2))
    return kappa, bending, torsion


@numba.njit(cache=True)
def edge_terms(P: np.ndarray, rest_length: np.ndarray, EA: float, order: int) -> np.ndarray:
    """Axial energies EA / (2 l0) (|x1 - x0| - l0)^2 (N mm) of edges P (S, 2, 3), as jets."""
    S = P.shape[0]
    n = 6 if order > 0 else 0
    out = np.zeros((S, 1 + n + n * n))
    for s in range(S):
        x0, x1 = _point(P[s], 0, n), _point(P[s], 1, n)
        d = (x1[0] - x0[0], x1[1] - x0[1], x1[2] - x0[2])
        r = _sqrt(_dot(d, d))
        r[0] -= rest_length[s]
        _put(out, s, EA / (2.0 * rest_length[s]) * _mul(r, r))
    return out


@numba.njit(cache=True)
def vertex_normals(P: np.ndarray, held_a: np.ndarray, held_b: np.ndarray, rest_a: np.ndarray,
                   rest_b: np.ndarray, order: int) -> np.ndarray:
    """Unit strip normals (mean of the two edge normals) at vertex stencils P (S, 5, 3), as
    jets (S, 3, 1 + n + n^2)."""
    S = P.shape[0]
    n = 15 if order > 0 else 0
    out = np.zeros((S, 3, 1 + n + n * n))
    for s in range(S):
        Ra, Rb = _vertex_frames(P[s], held_a[s], held_b[s], rest_a[s], rest_b[s], True, n)
        nrm = _unit((Ra[2][0] + Rb[2][0], Ra[2][1] + Rb[2][1], Ra[2][2] + Rb[2][2]))
        for c in range(3):
            out[s, c] = nrm[c]
    return out


class Jets(NamedTuple):
    """Values (...), gradients (..., n) and Hessians (..., n, n) of stencil quantities."""

    val: np.ndarray
    grad: np.ndarray
    hess: np.ndarray


def split(jets: np.ndarray) -> Jets:
    """Views of jets (..., 1 + n + n^2) as values, gradients and Hessians."""
    n = (int(round(np.sqrt(4 * jets.shape[-1] - 3))) - 1) // 2
    lead = jets.shape[:-1]
    return Jets(jets[..., 0], jets[..., 1:1 + n], jets[..., 1 + n:].reshape(*lead, n, n))
