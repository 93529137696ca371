"""The film fields (:mod:`results.film`) of a DR state, per membrane triangle.

The triangles (DR triangles, and the nets' lattice and bond-line triangles) give F. A link of
the link net is a triangle edge with the triangle's own strain, so the linear law of the
triangle is the links' law. A clustered cable has one strain along its length (its nodes slide),
which a triangle's edge does not have: the strain of the family along such an edge is the
cable's.
"""

from __future__ import annotations

import numpy as np

from results import CellBlock
from results.film import LATTICE_ANGLES_DEG, FilmLaw, film_fields, triangle_gradients
from scenes.electric import electrode_coverage

from .clusters import lengths as cable_lengths
from .kernels import Packed
from .model import Model

_PARALLEL = 1e-6
"""|sin| of the angle below which a flat edge lies along a lattice direction."""


def cluster_strains(P: Packed, x: np.ndarray) -> np.ndarray:
    """Strain (L - L0) / L0 of each clustered cable at positions x (n, 3) mm, its length L the
    sum of its segments."""
    return (cable_lengths(x, P) - P.clu_L0) / P.clu_L0


def _edge_family_strains(model: Model, P: Packed, x: np.ndarray) -> np.ndarray:
    """(t, 3) strain of each triangle's family k carried by a cable segment along its edge
    (NaN where no cable runs along that family's edge)."""
    tri, flat = model.triangles, model.nodes[:, :2]
    n = flat.shape[0]
    seg_strain = cluster_strains(P, x)[P.clu_seg_cluster]
    seg = np.sort(P.clu_seg, axis=1)
    order = np.argsort(seg[:, 0] * n + seg[:, 1])
    keys = (seg[:, 0] * n + seg[:, 1])[order]
    edges = np.stack([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]], axis=1)  # (t, 3, 2)
    d = flat[edges[..., 1]] - flat[edges[..., 0]]
    d /= np.linalg.norm(d, axis=2, keepdims=True)
    angles = np.radians(LATTICE_ANGLES_DEG)
    sin = np.abs(d[..., 0, None] * np.sin(angles) - d[..., 1, None] * np.cos(angles))  # (t, edge, family)
    e_sorted = np.sort(edges, axis=2)
    e_keys = e_sorted[..., 0] * n + e_sorted[..., 1]
    at = np.clip(np.searchsorted(keys, e_keys), 0, max(keys.size - 1, 0))
    on_cable = (keys[at] == e_keys) if keys.size else np.zeros(e_keys.shape, bool)
    strains = np.full((tri.shape[0], 3), np.nan)
    t, e, k = np.nonzero((sin < _PARALLEL) & on_cable[..., None])
    strains[t, k] = seg_strain[order[at[t, e]]]
    return strains


def film_surface(model: Model, x: np.ndarray, scene) -> CellBlock:
    """The membrane surface block of a DR state at positions x (n, 3) mm, with the film fields
    of ``scene`` (the state's pre-stretch and voltage)."""
    P = model.pack()
    strains = _edge_family_strains(model, P, x) if P.clu_seg.size else None
    film = FilmLaw.of_scene(scene, electrode_coverage(scene, model.nodes[model.triangles]))
    fields = film_fields(triangle_gradients(model.nodes, x, model.triangles), film, strains)
    return CellBlock("triangle", model.triangles, fields)
