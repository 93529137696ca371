"""Does a film pass through itself, or a frame through the film? A check on any solver's state.

The film is a triangulated surface (node positions and triangles); the frame a chain of segments.
Two triangles that share no node cross when an edge of one pierces the other; a frame segment
crosses the film when it pierces a triangle that none of its nodes belongs to. Only pairs
closer than the longest triangle edge are tested (a k-d tree on the centroids).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree


@dataclass
class Crossing:
    """What crossed: 'film' (two triangles) or 'frame' (a segment through a triangle), the
    elements' indices, and where (mm)."""

    kind: str
    first: int
    second: int
    where: np.ndarray

    def describe(self) -> str:
        p = self.where
        at = f"near ({p[0]:.1f}, {p[1]:.1f}, {p[2]:.1f}) mm"
        if self.kind == "film":
            return f"the film passes through itself (triangles {self.first} and {self.second}) {at}"
        return f"the frame passes through the film (frame segment {self.first}, triangle {self.second}) {at}"


def _pierces(p0: np.ndarray, p1: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Whether segments p0-p1 (k, 3) cross triangles abc (k, 3) in their interiors (Moller-
    Trumbore with the segment parameter in (0, 1)); coplanar pairs count as not crossing."""
    d = p1 - p0
    e1, e2 = b - a, c - a
    h = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, h)
    scale = np.linalg.norm(d, axis=1) * np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1)
    ok = np.abs(det) > 1e-12 * scale
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = np.where(ok, 1.0 / det, 0.0)
        s = p0 - a
        u = inv * np.einsum("ij,ij->i", s, h)
        q = np.cross(s, e1)
        v = inv * np.einsum("ij,ij->i", d, q)
        t = inv * np.einsum("ij,ij->i", e2, q)
    return ok & (u > 0) & (v > 0) & (u + v < 1) & (t > 0) & (t < 1)


def film_crossing(x: np.ndarray, triangles: np.ndarray, segments: np.ndarray | None = None) -> Crossing | None:
    """The first crossing of the film ``triangles`` (t, 3) with itself, or of the frame
    ``segments`` (k, 2) node pairs with the film, at node positions x (n, 3) mm; None if none."""
    tri = np.asarray(triangles, dtype=np.int64)
    p = x[tri]  # (t, 3, 3)
    if not np.isfinite(p).all() or tri.shape[0] < 2:
        return None
    edges = np.linalg.norm(p - np.roll(p, 1, axis=1), axis=2)
    reach = float(edges.max())
    centroid = p.mean(axis=1)
    tree = cKDTree(centroid)
    pairs = tree.query_pairs(reach, output_type="ndarray")
    if pairs.size:
        i, j = pairs[:, 0], pairs[:, 1]
        apart = ~(tri[i][:, :, None] == tri[j][:, None, :]).any(axis=(1, 2))
        i, j = i[apart], j[apart]
        for a, b in ((i, j), (j, i)):  # the edges of a against the triangles of b
            for k in range(3):
                hit = _pierces(p[a, k], p[a, (k + 1) % 3], p[b, 0], p[b, 1], p[b, 2])
                if hit.any():
                    n = int(np.flatnonzero(hit)[0])
                    return Crossing("film", int(a[n]), int(b[n]), centroid[a[n]])
    if segments is None or len(segments) == 0:
        return None
    seg = np.asarray(segments, dtype=np.int64)
    mid = 0.5 * (x[seg[:, 0]] + x[seg[:, 1]])
    near = cKDTree(mid).query_ball_tree(tree, reach + float(np.linalg.norm(x[seg[:, 1]] - x[seg[:, 0]], axis=1).max()))
    s_idx = np.repeat(np.arange(seg.shape[0]), [len(n) for n in near])
    t_idx = np.fromiter((t for n in near for t in n), dtype=np.int64, count=s_idx.size)
    if s_idx.size == 0:
        return None
    apart = ~(seg[s_idx][:, :, None] == tri[t_idx][:, None, :]).any(axis=(1, 2))
    s_idx, t_idx = s_idx[apart], t_idx[apart]
    hit = _pierces(x[seg[s_idx, 0]], x[seg[s_idx, 1]], p[t_idx, 0], p[t_idx, 1], p[t_idx, 2])
    if hit.any():
        n = int(np.flatnonzero(hit)[0])
        return Crossing("frame", int(s_idx[n]), int(t_idx[n]), mid[s_idx[n]])
    return None
