"""Where a DR state stops being finite: the nodes and the degenerate elements that cause it.

A link, cable segment or beam edge whose two nodes coincide has no direction, and a strip whose
orientation node lies on its edge's line has no plane: their forces are 0/0. These functions
name them, for the input check of :func:`dr.relax` (an error) and for its ``not_finite`` stop.
"""

from __future__ import annotations

import numpy as np

from .kernels import Packed

COINCIDENT = 1e-12
"""Relative distance (of the model's size) below which two nodes count as one point."""


def degenerate_elements(X: np.ndarray, P: Packed, limit: int = 3) -> list[str]:
    """Up to ``limit`` descriptions of elements without a direction or plane at positions X."""
    n = P.n
    x = X[:n]
    ok = x[np.isfinite(x).all(axis=1)]
    size = float(np.ptp(ok, axis=0).max()) if ok.shape[0] > 1 else 0.0
    size = size or 1.0
    tiny = COINCIDENT * size
    found: list[str] = []

    def pairs(kind: str, ij: np.ndarray) -> None:
        real = ij[(ij < n).all(axis=1)]
        length = np.linalg.norm(x[real[:, 1]] - x[real[:, 0]], axis=1)
        for i, j in real[length <= tiny][: limit - len(found)]:
            found.append(f"{kind} between nodes {i} and {j}: the nodes coincide")

    pairs("link", P.link_ij)
    pairs("cable segment", P.clu_seg)
    if P.strip_idx.size:
        for prev, j, nxt, m1, m2 in P.strip_idx:
            for a, b, m in ((prev, j, m1), (j, nxt, m2)):
                if m < 0 or max(a, b, m) >= n or len(found) >= limit:
                    continue
                d, w = x[b] - x[a], x[m] - x[a]
                if np.linalg.norm(np.cross(d, w)) <= tiny * max(np.linalg.norm(d), tiny):
                    found.append(f"strip edge {a}-{b}: its orientation node {m} lies on the edge's line "
                                 "(the strip has no plane)")
    return found[:limit]


def where_not_finite(X: np.ndarray, R: np.ndarray, P: Packed, before: np.ndarray | None = None) -> str:
    """A sentence naming the first node with a non-finite position or force, and the
    degenerate elements at X, or else at ``before`` (the last finite state), if any."""
    n = P.n
    bad_x = np.flatnonzero(~np.isfinite(X[:n]).all(axis=1))
    bad_r = np.flatnonzero(~np.isfinite(R[:n]).all(axis=1))
    if bad_x.size:
        where = f"the position of node {bad_x[0]}" + (f" (and {bad_x.size - 1} more)" if bad_x.size > 1 else "")
    elif bad_r.size:
        where = f"the force on node {bad_r[0]}" + (f" (and {bad_r.size - 1} more)" if bad_r.size > 1 else "")
    else:
        where = "the fictitious masses (a stiffness so large or so small that they overflow)"
    elements = degenerate_elements(X, P)
    if not elements and before is not None:
        elements = degenerate_elements(before, P)
    return where + (" (" + "; ".join(elements) + ")" if elements else "")
