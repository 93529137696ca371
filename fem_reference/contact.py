"""Self-contact of the frame and folds of the membrane: where the model stops being physical.

Neither is modelled as a contact force; the solver stops at the first state that has one and
says at which pre-stretch.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree


@dataclass
class Contact:
    """What was found: 'frame' or 'membrane', the distance (mm) or fold cosine, and where."""

    kind: str
    value: float
    where: np.ndarray  # (3,) mm

    def describe(self) -> str:
        if self.kind == "frame":
            return (f"the frame touches itself (centrelines {self.value:.3g} mm apart near "
                    f"({self.where[0]:.1f}, {self.where[1]:.1f}, {self.where[2]:.1f}) mm)")
        return (f"the membrane folds onto itself (adjacent elements turned by "
                f"{np.degrees(np.arccos(np.clip(self.value, -1, 1))):.0f} deg near "
                f"({self.where[0]:.1f}, {self.where[1]:.1f}, {self.where[2]:.1f}) mm)")


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


def frame_contact(x: np.ndarray, held: np.ndarray, threshold: float) -> Contact | None:
    """Closest approach of distant segments of the closed frame polyline x (m, 3).

    Contact when the centrelines come closer than ``threshold`` (mm, the strip thickness).
    Segments that are both held are not compared, nor segments less than pi/2 * threshold apart
    along the frame: to bring two of its points within ``threshold`` the centreline must turn
    back at least through a half circle of that diameter, so closer pairs are the rod's own
    chord, not contact (segments shorter than the thickness, as on fine meshes, would otherwise
    touch their neighbours' neighbours).
    """
    a, b = x, np.roll(x, -1, axis=0)
    seg_held = held & np.roll(held, -1)
    lengths = np.linalg.norm(b - a, axis=1)
    pairs = np.array(sorted(cKDTree(0.5 * (a + b)).query_pairs(lengths.max() + threshold)), dtype=int)
    if pairs.size == 0:
        return None
    i, j = pairs[:, 0], pairs[:, 1]  # i < j
    start = np.concatenate([[0.0], np.cumsum(lengths)])  # arc length at each node
    between = start[j] - start[i + 1]  # the segments strictly between, either way round the frame
    gap = np.minimum(between, start[-1] - (start[j + 1] - start[i]))
    keep = (j - i > 1) & (j - i < x.shape[0] - 1) & (gap >= 0.5 * np.pi * threshold) & ~(seg_held[i] & seg_held[j])
    i, j = i[keep], j[keep]
    if i.size == 0:
        return None
    dist, mid = segment_distances(a[i], b[i], a[j], b[j])
    k = int(np.argmin(dist))
    return Contact("frame", float(dist[k]), mid[k]) if dist[k] < threshold else None


def membrane_fold(x: np.ndarray, triangles: np.ndarray, facet_triangles: np.ndarray,
                  taut: np.ndarray | None = None, cos_limit: float = -0.5) -> Contact | None:
    """Adjacent triangles (vertex positions x) whose normals turn by more than 120 deg.

    ``facet_triangles`` is (2, nf) with -1 on the boundary (scikit-fem's ``f2t``); with ``taut``
    (per triangle) only pairs of taut triangles count.
    """
    p = x[triangles]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]
    inner = facet_triangles[1] >= 0
    t1, t2 = facet_triangles[0, inner], facet_triangles[1, inner]
    if taut is not None:
        keep = taut[t1] & taut[t2]
        t1, t2 = t1[keep], t2[keep]
        if t1.size == 0:
            return None
    cos = np.einsum("ij,ij->i", n[t1], n[t2])
    k = int(np.argmin(cos))
    if cos[k] >= cos_limit:
        return None
    return Contact("membrane", float(cos[k]), p[t1[k]].mean(axis=0))
