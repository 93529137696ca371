"""Self-contact of the frame and folds of the membrane: where the model stops being physical.

Neither is modelled as a contact force; the solver stops at the first state that has one and
says at which pre-stretch.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from results.crossing import closest_frame_approach, segment_distances  # noqa: F401 (re-exported)


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


def frame_contact(x: np.ndarray, held: np.ndarray, threshold: float) -> Contact | None:
    """Closest approach of distant segments of the closed frame polyline x (m, 3): contact when
    the centrelines come closer than ``threshold`` (mm, the strip thickness); see
    :func:`results.crossing.closest_frame_approach`."""
    found = closest_frame_approach(x, held, threshold)
    if found is None or found[0] >= threshold:
        return None
    return Contact("frame", found[0], found[1])


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
