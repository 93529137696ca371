"""Transfer of positions between meshes of one scene: which triangle holds a flat point, and
the piecewise-linear interpolation of nodal positions there (a coarse state as a finer mesh's
start)."""

from __future__ import annotations

import numpy as np
from matplotlib.tri import Triangulation

from .mesh import TriangleMesh


def locate(nodes: np.ndarray, triangles: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The triangle of a straight-sided mesh that each point lies in, and where.

    A refined mesh's boundary nodes sit on the curved outline, outside the coarser mesh's
    straight edges: such a point gets the triangle of its nearest boundary edge and the nearest
    point on that edge as its base (interpolating there and extrapolating with the triangle's
    gradient over ``points - base`` turns the outline's bulge with the frame).

    Parameters
    ----------
    nodes, triangles
        (nv, 2) flat vertices, mm, and (nt, 3) vertex ids of the mesh.
    points
        (m, 2) flat points, mm.

    Returns
    -------
    cells, base
        (m,) triangle ids and (m, 2) base points, mm (the point itself inside the mesh).
    """
    cells = Triangulation(nodes[:, 0], nodes[:, 1], triangles).get_trifinder()(points[:, 0], points[:, 1])
    base = points.astype(float).copy()
    out = np.flatnonzero(cells < 0)
    if out.size:
        # boundary edges: the edges of exactly one triangle, each with that triangle
        pairs = np.sort(np.vstack([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1)
        owner = np.tile(np.arange(len(triangles)), 3)
        _, first, count = np.unique(pairs, axis=0, return_index=True, return_counts=True)
        edge = first[count == 1]
        a, b = nodes[pairs[edge, 0]], nodes[pairs[edge, 1]]
        ab = b - a
        u = np.clip(np.einsum("mkj,kj->mk", points[out, None, :] - a[None], ab) / np.einsum("kj,kj->k", ab, ab),
                    0.0, 1.0)
        near = a[None] + u[..., None] * ab[None]
        k = np.argmin(np.linalg.norm(points[out, None, :] - near, axis=2), axis=1)
        base[out] = near[np.arange(out.size), k]
        cells[out] = owner[edge[k]]
    return cells, base


def transfer_linear(mesh: TriangleMesh, x: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Positions (m, 3) at flat points (m, 2) from positions x (nv, 3) at ``mesh``'s vertices:
    the piecewise-linear interpolation, extended outside the mesh with the affine map of the
    nearest boundary triangle (:func:`locate`), mm."""
    cells, _ = locate(mesh.nodes, mesh.triangles, points)
    tri = mesh.triangles[cells]
    p0, p1, p2 = (mesh.nodes[tri[:, k]] for k in range(3))
    # barycentric coordinates of the points (negative outside the triangle: the affine extension)
    T = np.stack([p1 - p0, p2 - p0], axis=2)  # (m, 2, 2)
    l12 = np.linalg.solve(T, (points - p0)[:, :, None])[:, :, 0]
    w = np.column_stack([1.0 - l12.sum(axis=1), l12])
    return np.einsum("mk,mkc->mc", w, x[tri])
