"""Second-order forward-mode differentiation, vectorised over many small stencils.

A :class:`Jet` carries a value together with its gradient and Hessian with respect to ``n``
local variables (the coordinates of one stencil: a frame vertex and its neighbours, or the six
entries of a deformation gradient), for a whole batch of stencils at once. Writing an energy
once with jets gives its exact gradient and tangent, so the frame and the membrane laws need no
hand-derived second derivatives (the tests still check them against finite differences).

Shapes: ``val`` (*shape), ``grad`` (*shape, n), ``hess`` (*shape, n, n); the leading axis is the
batch. Binary operations broadcast like numpy on ``val``.
"""

from __future__ import annotations

from typing import Callable

import numpy as np


class Jet:
    """Value, gradient and Hessian of a batch of scalar (or vector-component) quantities."""

    __slots__ = ("val", "grad", "hess")
    __array_priority__ = 1000  # ndarray (op) Jet defers to Jet's reflected operators

    def __init__(self, val: np.ndarray, grad: np.ndarray, hess: np.ndarray):
        self.val, self.grad, self.hess = val, grad, hess

    # ------------------------------------------------------------------ construction
    @classmethod
    def variables(cls, values: np.ndarray) -> "Jet":
        """Independent variables: ``values`` (batch, *shape); n = prod(shape) per stencil."""
        values = np.asarray(values, dtype=float)
        batch, shape = values.shape[0], values.shape[1:]
        n = int(np.prod(shape))
        grad = np.broadcast_to(np.eye(n).reshape(*shape, n), (batch, *shape, n)).copy()
        return cls(values.copy(), grad, np.zeros((batch, *shape, n, n)))

    @property
    def n(self) -> int:
        """Number of local variables."""
        return self.grad.shape[-1]

    def constant_like(self, val: np.ndarray) -> "Jet":
        """A constant (zero derivatives) with this jet's number of variables."""
        val = np.asarray(val, dtype=float)
        return Jet(val, np.zeros((*val.shape, self.n)), np.zeros((*val.shape, self.n, self.n)))

    # ------------------------------------------------------------------ indexing and shape
    def __getitem__(self, key) -> "Jet":
        return Jet(self.val[key], self.grad[key], self.hess[key])

    def expand(self) -> "Jet":
        """Add a trailing value axis of length 1, to broadcast a scalar against a vector."""
        return Jet(self.val[..., None], self.grad[..., None, :], self.hess[..., None, :, :])

    def sum(self, axis: int) -> "Jet":
        """Sum over a value axis (counted from the front, batch axis is 0)."""
        return Jet(self.val.sum(axis), self.grad.sum(axis), self.hess.sum(axis))

    # ------------------------------------------------------------------ arithmetic
    def __neg__(self) -> "Jet":
        return Jet(-self.val, -self.grad, -self.hess)

    def __add__(self, other) -> "Jet":
        if isinstance(other, Jet):
            return Jet(self.val + other.val, self.grad + other.grad, self.hess + other.hess)
        other = np.asarray(other, dtype=float)
        val = self.val + other
        return Jet(val, np.broadcast_to(self.grad, (*val.shape, self.n)),
                   np.broadcast_to(self.hess, (*val.shape, self.n, self.n)))

    __radd__ = __add__

    def __sub__(self, other) -> "Jet":
        return self + (-other)

    def __rsub__(self, other) -> "Jet":
        return (-self) + other

    def __mul__(self, other) -> "Jet":
        if isinstance(other, Jet):
            a, b = self, other
            ga, gb = a.grad, b.grad
            cross = ga[..., :, None] * gb[..., None, :]
            return Jet(
                a.val * b.val,
                a.val[..., None] * gb + b.val[..., None] * ga,
                a.val[..., None, None] * b.hess + b.val[..., None, None] * a.hess
                + cross + np.swapaxes(cross, -1, -2),
            )
        c = np.asarray(other, dtype=float)
        return Jet(self.val * c, self.grad * c[..., None], self.hess * c[..., None, None])

    __rmul__ = __mul__

    def __truediv__(self, other) -> "Jet":
        if isinstance(other, Jet):
            return self * other.reciprocal()
        return self * (1.0 / np.asarray(other, dtype=float))

    def __rtruediv__(self, other) -> "Jet":
        return self.reciprocal() * other

    # ------------------------------------------------------------------ functions
    def apply(self, f: np.ndarray, df: np.ndarray, d2f: np.ndarray) -> "Jet":
        """Chain rule for a scalar function with value f, first and second derivatives."""
        g = self.grad
        return Jet(
            f,
            df[..., None] * g,
            df[..., None, None] * self.hess + d2f[..., None, None] * (g[..., :, None] * g[..., None, :]),
        )

    def reciprocal(self) -> "Jet":
        r = 1.0 / self.val
        return self.apply(r, -r * r, 2 * r * r * r)

    def sqrt(self) -> "Jet":
        s = np.sqrt(self.val)
        return self.apply(s, 0.5 / s, -0.25 / (s * self.val))

    def square(self) -> "Jet":
        return self.apply(self.val**2, 2 * self.val, np.full_like(self.val, 2.0))


# ---------------------------------------------------------------------- helpers


def where(mask: np.ndarray, a, b):
    """Element-wise choice between jets or arrays (``b`` may be a constant), by a value mask."""
    if not isinstance(a, Jet):
        return np.where(mask, a, b)
    if not isinstance(b, Jet):
        b = a.constant_like(np.broadcast_to(np.asarray(b, dtype=float), a.val.shape))
    return Jet(
        np.where(mask, a.val, b.val),
        np.where(mask[..., None], a.grad, b.grad),
        np.where(mask[..., None, None], a.hess, b.hess),
    )


def sqrt(a):
    """Square root of a jet or an array."""
    return a.sqrt() if isinstance(a, Jet) else np.sqrt(a)


def dot(a: Jet, b: Jet | np.ndarray) -> Jet:
    """Dot product over the last value axis (3-vectors): (batch, 3) . (batch, 3) -> (batch,)."""
    return (a * b).sum(axis=a.val.ndim - 1)


def cross(a: Jet, b: Jet) -> Jet:
    """Cross product of (batch, 3) jets."""
    comps = [a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1],
             a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
             a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]]
    return stack(comps)


def stack(parts: list[Jet]) -> Jet:
    """Stack (batch,) jets into a (batch, k) jet."""
    return Jet(np.stack([p.val for p in parts], axis=1),
               np.stack([p.grad for p in parts], axis=1),
               np.stack([p.hess for p in parts], axis=1))


def norm(a: Jet) -> Jet:
    """Euclidean length of (batch, 3) jets."""
    return dot(a, a).sqrt()


def unit(a: Jet) -> Jet:
    """a / |a| for (batch, 3) jets."""
    return a * norm(a).reciprocal().expand()


def derivatives(energy: Callable[[Jet], Jet], values: np.ndarray) -> Jet:
    """Energies (batch,) of stencils with coordinates ``values`` (batch, *shape), as a jet."""
    return energy(Jet.variables(values))
