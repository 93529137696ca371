"""Does a film pass through itself, or a frame through the film or itself? A check on any
solver's state.

The film is a triangulated surface (node positions and triangles); the frame a chain of segments.
Two triangles that share no node cross when an edge of one pierces the other; a frame segment
crosses the film when it pierces a triangle that none of its nodes belongs to. Only pairs
closer than the longest triangle edge are tested (a k-d tree on the centroids). The frame passes
through itself where two of its distant segments come closer than half the strip's thickness: a
strip that only touches itself has its centrelines a thickness apart.
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
        if self.kind == "frame_self":
            return f"the frame passes through itself (segments {self.first} and {self.second}) {at}"
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
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # det may be denormal
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
        # two triangles cross only where their bounding boxes overlap, and most near pairs of a
        # smooth film lie side by side (the DEMES at 150 %: 5 ms a check instead of 16)
        lo, hi = p.min(axis=1), p.max(axis=1)
        boxes = np.all((lo[i] <= hi[j]) & (lo[j] <= hi[i]), axis=1)
        i, j = i[boxes], j[boxes]
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


def segment_distances(p0: np.ndarray, p1: np.ndarray, q0: np.ndarray, q1: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Shortest distances (k,) between segments p0-p1 and q0-q1 (k, 3) and the midpoints of the
    closest pairs (k, 3)."""
    d1, d2, r = p1 - p0, q1 - q0, p0 - q0
    a = np.einsum("ij,ij->i", d1, d1)
    e = np.einsum("ij,ij->i", d2, d2)
    f = np.einsum("ij,ij->i", d2, r)
    c = np.einsum("ij,ij->i", d1, r)
    b = np.einsum("ij,ij->i", d1, d2)
    den = a * e - b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(den > 1e-14 * a * e, np.clip((b * f - c * e) / den, 0, 1), 0.0)
        t = (b * s + f) / e
        s = np.where(t < 0, np.clip(-c / a, 0, 1), np.where(t > 1, np.clip((b - c) / a, 0, 1), s))
    t = np.clip(t, 0, 1)
    cp, cq = p0 + s[:, None] * d1, q0 + t[:, None] * d2
    return np.linalg.norm(cp - cq, axis=1), 0.5 * (cp + cq)


def _distant_pairs(x: np.ndarray, held: np.ndarray, threshold: float) -> tuple[np.ndarray, np.ndarray]:
    """Segment pairs (i, j) of the closed polyline x (m, 3) that may come within ``threshold``
    mm and are far enough apart along it to count."""
    a, b = x, np.roll(x, -1, axis=0)
    seg_held = held & np.roll(held, -1)
    lengths = np.linalg.norm(b - a, axis=1)
    pairs = cKDTree(0.5 * (a + b)).query_pairs(lengths.max() + threshold, output_type="ndarray")
    if pairs.size == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    pairs = np.sort(pairs, axis=1)
    i, j = pairs[:, 0], pairs[:, 1]  # i < j
    start = np.concatenate([[0.0], np.cumsum(lengths)])  # arc length at each node
    between = start[j] - start[i + 1]  # the segments strictly between, either way round the frame
    gap = np.minimum(between, start[-1] - (start[j + 1] - start[i]))
    keep = (j - i > 1) & (j - i < x.shape[0] - 1) & (gap >= 0.5 * np.pi * threshold) & ~(seg_held[i] & seg_held[j])
    return i[keep], j[keep]


def closest_frame_approach(x: np.ndarray, held: np.ndarray, threshold: float
                           ) -> tuple[float, np.ndarray, int, int] | None:
    """Closest approach of distant segments of the closed frame polyline x (m, 3): (distance mm,
    where (3,) mm, segment i, segment j), or None if no pair comes within ``threshold`` mm.

    Segments that are both ``held`` are not compared, nor segments less than pi/2 * threshold
    apart along the frame: to bring two of its points within ``threshold`` the centreline must
    turn back at least through a half circle of that diameter, so closer pairs are the rod's own
    chord, not contact (segments shorter than the thickness, as on fine meshes, would otherwise
    touch their neighbours' neighbours).
    """
    i, j = _distant_pairs(x, held, threshold)
    if i.size == 0:
        return None
    dist, mid = segment_distances(x[i], np.roll(x, -1, axis=0)[i], x[j], np.roll(x, -1, axis=0)[j])
    k = int(np.argmin(dist))
    return float(dist[k]), mid[k], int(i[k]), int(j[k])


def frame_crossing(x: np.ndarray, thickness: float, held: np.ndarray | None = None) -> Crossing | None:
    """Where the closed frame polyline x (m, 3) mm passes through itself: two distant segments
    closer than half the strip ``thickness`` (mm); None if nowhere."""
    if not np.isfinite(x).all():
        return None
    reach = 0.5 * thickness
    found = closest_frame_approach(x, np.zeros(x.shape[0], bool) if held is None else held, reach)
    if found is None or found[0] >= reach:
        return None
    return Crossing("frame_self", found[2], found[3], found[1])
