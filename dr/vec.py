"""3-vector algebra on tuples for numba kernels: no allocation, values stay in registers."""

from __future__ import annotations

import math

from numba import njit


@njit(cache=True, error_model="numpy", inline="always")
def get(x, i):
    return (x[i, 0], x[i, 1], x[i, 2])


@njit(cache=True, error_model="numpy", inline="always")
def add_to(f, i, v, scale):
    f[i, 0] += scale * v[0]
    f[i, 1] += scale * v[1]
    f[i, 2] += scale * v[2]


@njit(cache=True, error_model="numpy", inline="always")
def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


@njit(cache=True, error_model="numpy", inline="always")
def add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@njit(cache=True, error_model="numpy", inline="always")
def scale(a, s):
    return (a[0] * s, a[1] * s, a[2] * s)


@njit(cache=True, error_model="numpy", inline="always")
def axpy(s, a, b):
    """s * a + b."""
    return (s * a[0] + b[0], s * a[1] + b[1], s * a[2] + b[2])


@njit(cache=True, error_model="numpy", inline="always")
def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@njit(cache=True, error_model="numpy", inline="always")
def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@njit(cache=True, error_model="numpy", inline="always")
def norm(a):
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


@njit(cache=True, error_model="numpy", inline="always")
def unit_vjp(u, length, g):
    """Pull g back through u = v / |v|: returns (g - (g.u) u) / |v|."""
    return scale(axpy(-dot(g, u), u, g), 1.0 / length)
