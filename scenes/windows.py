"""Open windows: windows of a frame left without film.

``frame.open_windows`` names windows (:func:`scenes.members.windows`) by a point inside each. An
open window has no film, but its strips keep their own half-width: the band between a strip's
centreline and its bond line (``frame.bond_lever`` inside it) is the strip's material, which holds
the bond nodes that turn the strip's section at the lever, as the film does in a covered window.
On the mesh (:func:`open_window_masks`) an open window's triangles inside its bond lines are
removed and those of its bands kept, marked as strip material: unstretched, of the frame's E and
thickness, carrying no Maxwell stress. They double the in-plane stiffness of the strip's inner
half, which a curl does not engage (the band bends with the centreline about the same axis).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any, Sequence

import numpy as np
import shapely
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from .errors import SceneError
from .geometry import Outline
from .members import Member, windows


def open_windows(outline: Outline, members: Sequence[Member], width: float, points: Sequence,
                 name: str = "frame.open_windows") -> tuple[shapely.Polygon, ...]:
    """The windows (centreline to centreline, mm) that the ``points`` (mm) lie in, in their order.

    Raises
    ------
    SceneError
        Naming the point (``frame.open_windows[k]``) and the fix: a point on a strip or outside
        the frame, two points in one window, or every window open.
    """
    if len(points) == 0:
        return ()
    faces = windows(outline, members, width)
    films = [f.buffer(-0.5 * width) for f in faces]
    chosen: list[int] = []
    for k, (x, y) in enumerate(points):
        inside = [j for j, film in enumerate(films) if film.contains(shapely.Point(x, y))]
        if not inside:
            raise SceneError(
                f"{name}[{k}] = [{x:g}, {y:g}] is not inside a window: give a point of the window to leave "
                f"open, inside the outline and more than frame.width / 2 = {0.5 * width:g} mm from its strips "
                "(in the outline's frame: base along +x centred on the origin)")
        if inside[0] in chosen:
            raise SceneError(f"{name}[{k}] and {name}[{chosen.index(inside[0])}] lie in the same window: "
                             "give one point per window to leave open")
        chosen.append(inside[0])
    if len(chosen) == len(faces):
        raise SceneError(f"{name} opens every window ({len(faces)}): a DEMES needs pre-stretched film in at "
                         "least one window; remove a point from it")
    return tuple(faces[j] for j in chosen)


def band_region(outline: Outline, members: Sequence[Member], lever: float) -> shapely.Geometry:
    """The strips' bands in the flat scene: between the outline's centreline and its bond line
    (``lever`` mm inside), and between each member's centreline and its bond line (``lever`` to its
    left)."""
    ring = shapely.Polygon(outline.polyline(min(outline.side_length, lever) / 40)[0])
    parts = [ring.difference(ring.buffer(-lever))]
    for m in members:
        left = lever * np.array([-m.direction[1], m.direction[0]])
        parts.append(shapely.Polygon([m.start, m.end, m.end + left, m.start + left]))
    return shapely.union_all(parts)


def open_window_masks(nodes: np.ndarray, triangles: np.ndarray, lines: Sequence[np.ndarray],
                      opened: Sequence[shapely.Polygon], band: shapely.Geometry) -> tuple[np.ndarray, np.ndarray]:
    """Which triangles an open window removes and which it keeps as strip material.

    The mesh's constrained lines (``lines``: chains of node ids, the bond lines and the members'
    centrelines) cut its triangles into regions: each strip's band and each window's inside.
    A region lies in the window that holds its largest triangle's centroid, and is a band where
    most of its area has its centroids in ``band``: whole regions, so that a coarse chord of a
    fillet does not split one.

    Returns
    -------
    removed, strip
        (nt,) bool: the open windows' insides, and their bands.
    """
    nt = len(triangles)
    if not opened:
        return np.zeros(nt, bool), np.zeros(nt, bool)
    n = len(nodes)
    edges = np.sort(np.vstack([triangles[:, [0, 1]], triangles[:, [1, 2]], triangles[:, [2, 0]]]), axis=1)
    code = edges[:, 0] * n + edges[:, 1]
    lined = np.vstack([np.column_stack([c[:-1], c[1:]]) for c in lines]) if lines else np.zeros((0, 2), int)
    lined = np.sort(lined, axis=1)
    owner = np.tile(np.arange(nt), 3)
    order = np.argsort(code, kind="stable")
    code, owner = code[order], owner[order]
    # two triangles meet across an edge that no line follows
    shared = np.flatnonzero((code[1:] == code[:-1]) & ~np.isin(code[1:], lined[:, 0] * n + lined[:, 1]))
    graph = coo_matrix((np.ones(shared.size), (owner[shared], owner[shared + 1])), shape=(nt, nt))
    count, region = connected_components(graph, directed=False)
    corners = nodes[triangles][:, :, :2]
    centroid = corners.mean(axis=1)
    e1, e2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    in_band = shapely.contains_xy(band, centroid[:, 0], centroid[:, 1])
    band_share = np.bincount(region, weights=area * in_band, minlength=count) / np.bincount(
        region, weights=area, minlength=count)
    by_size = np.lexsort((area, region))  # by region, then area: each region's largest comes last
    largest = by_size[np.append(np.flatnonzero(np.diff(region[by_size])), nt - 1)]
    open_region = np.zeros(count, bool)
    for window in opened:
        open_region |= shapely.contains_xy(window, centroid[largest, 0], centroid[largest, 1])
    opened_tri = open_region[region]
    strip = opened_tri & (band_share[region] > 0.5)
    return opened_tri & ~strip, strip


def opened(mesh: Any, outline: Outline, frame: Any) -> Any:
    """``mesh`` (a :class:`scenes.mesh.TriangleMesh`) without the insides of ``frame``'s open
    windows, their bands marked as strip material (``strip_band``), its nodes renumbered."""
    lines = [np.append(mesh.bond_nodes, mesh.bond_nodes[0]), *mesh.members, *mesh.member_bonds]
    removed, strip = open_window_masks(mesh.nodes, mesh.triangles, lines, frame.open_regions,
                                       band_region(outline, frame.cross_members, frame.lever))
    kept = mesh.triangles[~removed]
    used = np.unique(kept)
    new_id = np.full(len(mesh.nodes), -1)
    new_id[used] = np.arange(used.size)
    return replace(mesh, nodes=mesh.nodes[used], triangles=new_id[kept], frame_nodes=new_id[mesh.frame_nodes],
                   bond_nodes=new_id[mesh.bond_nodes], members=tuple(new_id[c] for c in mesh.members),
                   member_bonds=tuple(new_id[c] for c in mesh.member_bonds), strip_band=strip[~removed])
