"""The paper's discretisation of a DEMES scene: frame nodes and a triangular membrane lattice.

The lattice is triangular with spacing s = base side / divisions, aligned with the base side
and anchored at its first corner, so that for the triangle its lines run parallel to the three
sides. Each lattice line, clipped by the frame outline, is one cable from frame to frame
through the lattice nodes inside. Frame nodes sit where cables meet the frame, plus the
landmarks (base midpoint, apex, fillet ends where the clamps are) and enough extra nodes that
no frame segment is much longer than s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import triangle
from matplotlib.tri import Triangulation

from scenes import Outline, SceneError

DIRECTIONS = np.array([[1.0, 0.0], [0.5, np.sqrt(3) / 2], [-0.5, np.sqrt(3) / 2]])
"""Lattice line directions: parallel to the base and to the triangle's other two sides."""

INNER_MARGIN = 0.35
"""Lattice nodes closer than this many spacings to the frame are dropped (no slivers)."""

MERGE = 0.3
"""Frame points closer than this many spacings along the frame share one node."""


@dataclass
class Net:
    """Flat reference geometry of the DR model of a scene.

    Attributes
    ----------
    nodes
        (n, 3) positions, mm: frame nodes first (in order along the frame from the base
        midpoint), then the membrane's inner lattice nodes.
    n_frame
        Number of frame nodes.
    frame_s
        (n_frame,) arc length of each frame node, mm.
    cables
        Node chains from frame to frame along the lattice lines.
    cable_film
        (c,) area of film each cable stands for, mm^2: the part of the region nearer to its
        lattice line than to the next kept line of its family (shared by length among the runs
        of one line), so that each family of cables carries the whole film up to the frame.
    triangles
        (t, 3) counter-clockwise membrane triangles over all nodes (display, strip plane).
    spacing
        Lattice spacing s, mm.
    length
        Frame length, mm.
    """

    nodes: np.ndarray
    n_frame: int
    frame_s: np.ndarray
    cables: list[np.ndarray]
    cable_film: np.ndarray
    triangles: np.ndarray
    spacing: float
    length: float

    def frame_node_at(self, s: float) -> int:
        """Index of the frame node nearest to arc length s (mm)."""
        return int(_nearest_periodic(self.frame_s, np.array([s]), self.length)[0])

    def bond_points(self, outline: Outline, lever: float) -> tuple[np.ndarray, np.ndarray]:
        """For each frame edge (k, k+1 mod n_frame), its bond point, as the FEM's: the midpoint
        of the points ``lever`` mm inside its two ends (along the outline's normals). Returns
        the three nodes (nf, 3) of the membrane triangle that holds it and their barycentric
        weights (nf, 3)."""
        nf = self.n_frame
        xy0, t = outline.evaluate(self.frame_s)
        inner = xy0 + lever * np.column_stack([-t[:, 1], t[:, 0]])  # inward: the outline is ccw
        p = 0.5 * (inner + np.roll(inner, -1, axis=0))
        xy = self.nodes[:, :2]
        tri = Triangulation(xy[:, 0], xy[:, 1], self.triangles)
        cell = tri.get_trifinder()(p[:, 0], p[:, 1])
        if np.any(cell < 0):
            raise SceneError(f"frame.bond_lever = {lever:g} mm puts a bond point outside the membrane")
        corners = self.triangles[cell]
        q = xy[corners]  # (nf, 3, 2)
        T = np.stack([q[:, 1] - q[:, 0], q[:, 2] - q[:, 0]], axis=2)
        w12 = np.linalg.solve(T, (p - q[:, 0])[:, :, None])[:, :, 0]
        w = np.column_stack([1.0 - w12.sum(axis=1), w12])
        return corners, np.clip(w, 0.0, 1.0) / np.clip(w, 0.0, 1.0).sum(axis=1)[:, None]


def build_net(outline: Outline, divisions: int, landmarks: list[float]) -> Net:
    """Lattice, cables, frame nodes and triangles for ``outline`` at ``divisions`` per base side.

    ``landmarks`` are arc lengths (mm) that must carry a frame node (clamps, apex, ...).
    """
    s = outline.side_length / divisions
    origin = outline.vertices[0]
    h = s * np.sqrt(3) / 2
    # lattice points covering the outline's bounding box
    poly = outline.polyline(s / 8)[0]
    lo, hi = poly.min(axis=0) - s, poly.max(axis=0) + s
    jmax = int(np.ceil((hi[1] - origin[1]) / h)) + 1
    jmin = int(np.floor((lo[1] - origin[1]) / h)) - 1
    span = int(np.ceil((hi[0] - lo[0]) / s)) + abs(jmin) + jmax + 2
    i0 = int(np.floor((lo[0] - origin[0]) / s)) - jmax - 1
    ii, jj = np.meshgrid(np.arange(i0, i0 + span + 2 * jmax), np.arange(jmin, jmax + 1), indexing="ij")
    ii, jj = ii.ravel(), jj.ravel()
    pts = origin + ii[:, None] * s * DIRECTIONS[0] + jj[:, None] * s * DIRECTIONS[1]
    inside = outline.contains(pts, spacing=s / 8) & (outline.distance(pts) > INNER_MARGIN * s)
    inner_xy = pts[inside]
    if inner_xy.shape[0] < 3:
        raise SceneError(
            f"mesh.divisions = {divisions} is too coarse: only {inner_xy.shape[0]} membrane nodes "
            "fit inside the frame; use more divisions"
        )

    # cables: each lattice line, split into runs between its frame crossings
    raw_cables: list[tuple[float, np.ndarray, float]] = []  # (s_start, inner ids, s_end)
    raw_line: list[tuple[int, int]] = []  # (family, line number) of each raw cable
    for family, direction in enumerate(DIRECTIONS):
        normal = np.array([-direction[1], direction[0]])
        line_of = np.round((inner_xy - origin) @ normal / h).astype(int)
        offsets = (poly - origin) @ normal / h
        for k in range(int(np.floor(offsets.min())), int(np.ceil(offsets.max())) + 1):
            p0 = origin + k * h * normal
            t_cross, s_cross = outline.intersect_line(p0, direction)
            on_line = np.flatnonzero(line_of == k)
            t_nodes = (inner_xy[on_line] - p0) @ direction
            for m in range(0, t_cross.size - 1, 2):
                sel = (t_nodes > t_cross[m]) & (t_nodes < t_cross[m + 1])
                run = on_line[sel][np.argsort(t_nodes[sel])]
                if run.size or t_cross[m + 1] - t_cross[m] >= 0.5 * s:
                    raw_cables.append((s_cross[m], run, s_cross[m + 1]))
                    raw_line.append((family, k))

    # frame nodes: cable ends, landmarks, and fill so that segments stay near s
    length = outline.length
    ends = np.array([c[0] for c in raw_cables] + [c[2] for c in raw_cables])
    special = np.mod(np.array(sorted(set(np.round(landmarks, 12)))), length)
    frame_s = _place_frame_nodes(ends, special, length, s)
    ends_node = _nearest_periodic(frame_s, ends, length)
    nc = len(raw_cables)
    nf = frame_s.size
    frame_xy = outline.evaluate(frame_s)[0]
    cables, lines = [], []
    for k, (_, run, _) in enumerate(raw_cables):
        a, b = ends_node[k], ends_node[k + nc]
        if a == b:
            continue  # both ends snapped to one node: a cable of no length
        cables.append(np.concatenate([[a], nf + run, [b]]).astype(np.int64))
        lines.append(raw_line[k])
    nodes_xy = np.vstack([frame_xy, inner_xy])
    lengths = np.array([np.linalg.norm(np.diff(nodes_xy[c], axis=0), axis=1).sum() for c in cables])
    film = _tributary_areas(outline.polyline(s / 32)[0], origin, h, np.array(lines).reshape(-1, 2), lengths)
    seg = np.stack([np.arange(nf), (np.arange(nf) + 1) % nf], axis=1)
    tri = triangle.triangulate({"vertices": nodes_xy, "segments": seg}, "pQ")
    if tri["vertices"].shape[0] != nodes_xy.shape[0]:
        raise SceneError("mesh.divisions is too small for this outline: the membrane cannot be triangulated")
    t = tri["triangles"].astype(np.int64)
    e1, e2 = nodes_xy[t[:, 1]] - nodes_xy[t[:, 0]], nodes_xy[t[:, 2]] - nodes_xy[t[:, 0]]
    area2 = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    t[area2 < 0] = t[area2 < 0][:, ::-1]
    nodes = np.zeros((nodes_xy.shape[0], 3))
    nodes[:, :2] = nodes_xy
    return Net(nodes, nf, frame_s, cables, film, t, s, length)


def _tributary_areas(poly: np.ndarray, origin: np.ndarray, h: float, lines: np.ndarray,
                     lengths: np.ndarray) -> np.ndarray:
    """Film area (mm^2) each cable stands for: per family, the region (polygon ``poly``) cut
    into slabs halfway between the kept lattice lines (the outermost slabs reach the frame),
    each slab shared among its line's cables in proportion to their ``lengths``."""
    area = np.zeros(len(lines))
    for family, direction in enumerate(DIRECTIONS):
        normal = np.array([-direction[1], direction[0]])
        mine = np.flatnonzero(lines[:, 0] == family)
        offsets = np.unique(lines[mine, 1])
        cuts = np.concatenate([[-np.inf], 0.5 * (offsets[1:] + offsets[:-1]) * h, [np.inf]])
        for k, lo, hi in zip(offsets, cuts[:-1], cuts[1:]):
            slab = _clip(_clip(poly, origin, normal, lo, 1.0), origin, normal, hi, -1.0)
            on_line = mine[lines[mine, 1] == k]
            area[on_line] = _shoelace(slab) * lengths[on_line] / lengths[on_line].sum()
    return area


def _clip(poly: np.ndarray, origin: np.ndarray, normal: np.ndarray, cut: float, sign: float) -> np.ndarray:
    """The part of polygon ``poly`` where sign * ((x - origin) . normal - cut) >= 0
    (Sutherland-Hodgman against one half-plane)."""
    if poly.shape[0] == 0 or not np.isfinite(cut):
        return poly
    d = sign * ((poly - origin) @ normal - cut)
    nxt = np.roll(poly, -1, axis=0)
    d_next = np.roll(d, -1)
    inside = d >= 0
    crossing = inside != (d_next >= 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        cross = poly + (nxt - poly) * (d / np.where(crossing, d - d_next, 1.0))[:, None]
    # each vertex, if inside, then the crossing on its way to the next, if any
    points = np.stack([poly, cross], axis=1).reshape(-1, 2)
    keep = np.stack([inside, crossing], axis=1).ravel()
    return points[keep]


def _shoelace(poly: np.ndarray) -> float:
    if poly.shape[0] < 3:
        return 0.0
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def _nearest_periodic(grid: np.ndarray, values: np.ndarray, length: float) -> np.ndarray:
    d = np.abs(np.mod(values[:, None] - grid[None, :] + 0.5 * length, length) - 0.5 * length)
    return np.argmin(d, axis=1)


def _place_frame_nodes(ends: np.ndarray, special: np.ndarray, length: float, s: float) -> np.ndarray:
    """Arc lengths of the frame nodes, starting at the base midpoint (s = 0).

    Candidate points (landmarks and cable ends) closer than MERGE * s to a neighbour form a
    group; a group becomes its landmark(s), or its mean if it has none. Grouping by gaps does
    not depend on the order of the points, so a symmetric outline gets symmetric nodes. Gaps
    longer than 1.5 s are then split evenly.
    """
    pts = np.mod(np.concatenate([special, ends]), length)
    is_special = np.arange(pts.size) < special.size
    order = np.argsort(pts)
    pts, is_special = pts[order], is_special[order]
    gaps = np.diff(np.append(pts, pts[0] + length))
    # rotate so that the first group starts after a real gap
    first = (int(np.argmax(gaps > MERGE * s)) + 1) % pts.size
    pts = np.roll(pts, -first)
    is_special = np.roll(is_special, -first)
    pts = np.unwrap(pts, period=length)
    kept = []
    group = [0]
    for k in range(1, pts.size + 1):
        if k < pts.size and pts[k] - pts[k - 1] <= MERGE * s:
            group.append(k)
            continue
        g = np.array(group)
        marks = g[is_special[g]]
        kept.extend(pts[marks] if marks.size else [pts[g].mean()])
        group = [k]
    kept = np.sort(np.mod(np.array(kept), length))
    out = []
    for a, b in zip(kept, np.append(kept[1:], kept[0] + length)):
        k = max(1, int(np.round((b - a) / s)))
        out.extend(a + (b - a) * np.arange(k) / k)
    out = np.mod(np.array(out), length)
    start = int(np.argmin(np.minimum(out, length - out)))
    return np.roll(out, -start)
