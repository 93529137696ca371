"""The symmetries of a DR model and the states that keep them.

A frame symmetric about x = 0 on a mesh that is too, with supports that are, has the mirror
x -> -x; a model with nothing to tell the two faces of the film apart (no film offset, no
out-of-plane load) has the flip z -> -z; and then their product. The flat state keeps all of
them, a twisted state the product only, a curled state the mirror. Where a relaxation from a
state that keeps a symmetry ends on one that breaks it, the path crossed a symmetry-breaking
bifurcation; which of the two mirror-image branches the relaxation fell to was picked by
round-off and by the drift a relaxation leaves along a soft mode. The path instead locates
the bifurcation, restores the symmetry of the state it left (:func:`restore`) and leaves it
along its lowest mode on the side the scene's lift asks for (:mod:`results.path`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .stability import potential_energy

SYMMETRIC = 1e-3
"""A state within this fraction of the side length of its image keeps the symmetry: above the
drift of a relaxed twisted state along its soft curl mode (5e-4 of the side, measured on a
40 x 60 mm rectangle at 8 divisions), far below a branch that broke it."""


class Symmetry(NamedTuple):
    """x (n, 3) -> image[x] * sign: a node permutation and a sign per axis."""

    name: str
    image: np.ndarray  # (n,) node index of each node's image
    sign: np.ndarray  # (3,)

    def apply(self, x: np.ndarray) -> np.ndarray:
        return x[self.image] * self.sign


def model_symmetries(model, mirror: np.ndarray | None) -> list[Symmetry]:
    """The model's symmetries among the mirror (``mirror``: the node map of x -> -x, None if
    the mesh has none), the flip z -> -z and their product: those that map the supports onto
    themselves and leave the potential energy of a state with no symmetry unchanged."""
    n = model.n
    identity = np.arange(n)
    candidates = [Symmetry("flip", identity, np.array([1.0, 1.0, -1.0]))]
    if mirror is not None:
        candidates += [Symmetry("mirror", mirror, np.array([-1.0, 1.0, 1.0])),
                       Symmetry("mirror_flip", mirror, np.array([-1.0, 1.0, -1.0]))]
    P = model.pack()
    X = np.zeros((P.n_total, 3))
    # a state with no symmetry: the flat nodes moved by a fixed, smooth, asymmetric field
    span = float(np.ptp(model.nodes[:, :2], axis=0).max()) or 1.0
    u = model.nodes / span
    probe = model.nodes + 0.05 * span * np.stack([u[:, 1] ** 2, u[:, 0] * u[:, 1], u[:, 0] + u[:, 1] ** 3 + 0.3], axis=1)
    probe[model.fixed] = model.nodes[model.fixed]
    X[:n] = probe
    e = potential_energy(X, P, model.loads)
    kept = []
    for g in candidates:
        if not np.array_equal(model.fixed[g.image], model.fixed):
            continue
        if np.abs(g.apply(model.nodes)[model.fixed] - model.nodes[model.fixed]).max(initial=0.0) > 1e-9 * span:
            continue
        X[:n] = g.apply(probe)
        if abs(potential_energy(X, P, model.loads) - e) <= 1e-9 * max(abs(e), 1e-300):
            kept.append(g)
    return kept


def kept_by(x: np.ndarray, symmetries: list[Symmetry], side_length: float) -> list[Symmetry]:
    """The symmetries the state ``x`` (n, 3) mm keeps (:data:`SYMMETRIC`)."""
    return [g for g in symmetries if np.abs(g.apply(x) - x).max() <= SYMMETRIC * side_length]


def restore(x: np.ndarray, symmetries: list[Symmetry], fixed: np.ndarray | None = None) -> np.ndarray:
    """``x`` made to keep ``symmetries`` exactly: the mean of it and its images (the model's
    symmetries commute, so projecting on each in turn projects on all); the held coordinates
    ``fixed`` (n, 3) bool stay bit for bit where they are."""
    y = x
    for g in symmetries:
        y = 0.5 * (y + g.apply(y))
    if fixed is not None:
        y = np.where(fixed, x, y)
    return y


def restore_mode(shape: np.ndarray, symmetries: list[Symmetry]) -> np.ndarray:
    """A mode shape (n, 3) of a state that keeps ``symmetries``, made to keep or reverse each of
    them exactly (whichever it mostly does): a mode of a symmetric state does one or the other,
    and one found at a state that drifted off it mixes the two. Largest nodal move 1."""
    for g in symmetries:
        image = g.apply(shape)
        kept, reversed_ = 0.5 * (shape + image), 0.5 * (shape - image)
        shape = reversed_ if np.linalg.norm(reversed_) > np.linalg.norm(kept) else kept
    return shape / np.linalg.norm(shape, axis=1).max()
