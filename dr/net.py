"""The paper's discretisation of a DEMES scene: frame nodes, their bond nodes and a triangular
membrane lattice.

The lattice is triangular with spacing s = base side / divisions, aligned with the base side
and anchored at its first corner, so that for the triangle its lines run parallel to the three
sides. The film meets the strip on the *bond line*, ``frame.bond_lever`` inside the frame
centreline (the strip's inner edge by default), the same line at every mesh density: each
lattice line, clipped by the bond line, is one cable from bond node to bond node through the
lattice nodes inside, and the row of film between the centreline and the bond line is a band
of constant-strain triangles, as in the FEM's mesh. Frame nodes sit where cables meet the bond
line (each with its bond node beside it), plus the landmarks (base midpoint, apex, fillet ends
where the clamps are) and enough extra nodes that no frame segment is much longer than s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import triangle

from scenes import Outline, SceneError

DIRECTIONS = np.array([[1.0, 0.0], [0.5, np.sqrt(3) / 2], [-0.5, np.sqrt(3) / 2]])
"""Lattice line directions: parallel to the base and to the triangle's other two sides."""

INNER_MARGIN = 0.35
"""Lattice nodes closer than this many spacings to the bond line are dropped (no slivers)."""

MERGE = 0.3
"""Frame points closer than this many spacings along the frame share one node."""


@dataclass
class Net:
    """Flat reference geometry of the DR model of a scene.

    Attributes
    ----------
    nodes
        (n, 3) positions, mm: frame nodes first (in order along the frame from the base
        midpoint), then their bond nodes (same order), then the membrane's lattice nodes.
    n_frame
        Number of frame nodes (and of bond nodes).
    frame_s
        (n_frame,) arc length of each frame node, mm.
    cables
        Node chains from bond node to bond node along the lattice lines.
    cable_film
        (c,) area of film each cable stands for, mm^2: the part of the polygon of bond nodes
        nearer to its lattice line than to the next kept line of its family (shared by length
        among the runs of one line), so that each family of cables carries the whole film
        inside it.
    row_triangles
        (r, 3) counter-clockwise film triangles between the centreline and the bond line.
    triangles
        (t, 3) counter-clockwise membrane triangles over all nodes, the row first (display,
        fold and crossing checks).
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
    row_triangles: np.ndarray
    triangles: np.ndarray
    spacing: float
    length: float

    @property
    def bond_nodes(self) -> np.ndarray:
        """(n_frame,) the bond node of each frame node."""
        return self.n_frame + np.arange(self.n_frame)

    def frame_node_at(self, s: float) -> int:
        """Index of the frame node nearest to arc length s (mm)."""
        return int(_nearest_periodic(self.frame_s, np.array([s]), self.length)[0])


def build_net(outline: Outline, divisions: int, landmarks: list[float], lever: float) -> Net:
    """Lattice, cables, frame and bond nodes and triangles for ``outline`` at ``divisions`` per
    base side, the film bonded ``lever`` mm inside the centreline.

    ``landmarks`` are arc lengths (mm) that must carry a frame node (clamps, apex, ...).
    """
    s = outline.side_length / divisions
    origin = outline.vertices[0]
    h = s * np.sqrt(3) / 2
    # the bond line as a fine polygon, each vertex with the centreline arc length it stands on
    poly_s = outline.polyline(s / 32)[1]
    bond_poly = outline.inner_offset(poly_s, lever)
    if np.any(outline.distance(bond_poly) < lever * (1 - 1e-6)) or _shoelace(bond_poly) <= 0.0:
        raise SceneError("the bond line (frame.bond_lever inside the outline) folds over itself: the frame is "
                         "too sharply bent for its strip; raise frame.corner_radius or lower frame.bond_lever")
    # lattice points covering the outline's bounding box
    lo, hi = bond_poly.min(axis=0) - s, bond_poly.max(axis=0) + s
    jmax = int(np.ceil((hi[1] - origin[1]) / h)) + 1
    jmin = int(np.floor((lo[1] - origin[1]) / h)) - 1
    span = int(np.ceil((hi[0] - lo[0]) / s)) + abs(jmin) + jmax + 2
    i0 = int(np.floor((lo[0] - origin[0]) / s)) - jmax - 1
    ii, jj = np.meshgrid(np.arange(i0, i0 + span + 2 * jmax), np.arange(jmin, jmax + 1), indexing="ij")
    ii, jj = ii.ravel(), jj.ravel()
    pts = origin + ii[:, None] * s * DIRECTIONS[0] + jj[:, None] * s * DIRECTIONS[1]
    inside = outline.contains(pts, spacing=s / 8) & (outline.distance(pts) > lever + INNER_MARGIN * s)
    inner_xy = pts[inside]
    if inner_xy.shape[0] < 3:
        raise SceneError(
            f"mesh.divisions = {divisions} is too coarse: only {inner_xy.shape[0]} membrane nodes "
            "fit inside the bond line; use more divisions (or a smaller frame.bond_lever)"
        )

    # cables: each lattice line, split into runs between its bond-line crossings
    raw_cables: list[tuple[float, np.ndarray, float]] = []  # (s_start, inner ids, s_end)
    raw_line: list[tuple[int, int]] = []  # (family, line number) of each raw cable
    for family, direction in enumerate(DIRECTIONS):
        normal = np.array([-direction[1], direction[0]])
        line_of = np.round((inner_xy - origin) @ normal / h).astype(int)
        offsets = (bond_poly - origin) @ normal / h
        for k in range(int(np.floor(offsets.min())), int(np.ceil(offsets.max())) + 1):
            p0 = origin + k * h * normal
            t_cross, s_cross = _crossings(bond_poly, poly_s, outline.length, p0, direction)
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
    cables, lines = [], []
    for k, (_, run, _) in enumerate(raw_cables):
        a, b = ends_node[k], ends_node[k + nc]
        if a == b:
            continue  # both ends snapped to one node: a cable of no length
        cables.append(np.concatenate([[nf + a], 2 * nf + run, [nf + b]]).astype(np.int64))
        lines.append(raw_line[k])
    nodes_xy = np.vstack([outline.evaluate(frame_s)[0], outline.inner_offset(frame_s, lever), inner_xy])
    lengths = np.array([np.linalg.norm(np.diff(nodes_xy[c], axis=0), axis=1).sum() for c in cables])
    # the cables carry the film inside the polygon of bond nodes, the row the rest: together
    # the polygon of frame nodes, as the FEM's mesh on the same frame nodes
    film = _tributary_areas(nodes_xy[nf:2 * nf], origin, h, np.array(lines).reshape(-1, 2), lengths)
    row = _row_triangles(nodes_xy, nf)
    loop = np.stack([np.arange(nf), (np.arange(nf) + 1) % nf], axis=1)
    inner = nodes_xy[nf:]
    tri = triangle.triangulate({"vertices": inner, "segments": loop}, "pQ")
    if tri["vertices"].shape[0] != inner.shape[0]:
        raise SceneError("mesh.divisions is too small for this outline: the membrane cannot be triangulated")
    t = tri["triangles"].astype(np.int64) + nf
    e1, e2 = nodes_xy[t[:, 1]] - nodes_xy[t[:, 0]], nodes_xy[t[:, 2]] - nodes_xy[t[:, 0]]
    area2 = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    t[area2 < 0] = t[area2 < 0][:, ::-1]
    nodes = np.zeros((nodes_xy.shape[0], 3))
    nodes[:, :2] = nodes_xy
    return Net(nodes, nf, frame_s, cables, film, row, np.vstack([row, t]), s, length)


def _crossings(poly: np.ndarray, poly_s: np.ndarray, length: float, point: np.ndarray,
               direction: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Crossings of the line ``point + t direction`` with the closed polygon ``poly`` whose
    vertices stand on centreline arc lengths ``poly_s``: line parameters t (mm, sorted) and the
    arc lengths s there (interpolated along the crossed edge)."""
    nxt, s_next = np.roll(poly, -1, axis=0), np.roll(poly_s, -1)
    s_next = np.where(s_next < poly_s, s_next + length, s_next)
    normal = np.array([-direction[1], direction[0]])
    da, db = (poly - point) @ normal, (nxt - point) @ normal
    cut = (da > 0) != (db > 0)  # half-open: a vertex on the line counts once
    f = da[cut] / (da[cut] - db[cut])
    t = (poly[cut] + f[:, None] * (nxt[cut] - poly[cut]) - point) @ direction
    s_at = np.mod(poly_s[cut] + f * (s_next[cut] - poly_s[cut]), length)
    order = np.argsort(t)
    return t[order], s_at[order]


def _row_triangles(nodes_xy: np.ndarray, nf: int) -> np.ndarray:
    """The band between the frame loop (nodes 0..nf-1) and the bond loop (nf..2nf-1): each quad
    (frame k, frame k+1, bond k+1, bond k) split along its shorter diagonal, counter-clockwise.
    Equal diagonals (a rectangle) are split by the side of x = 0 the quad is on, so that a
    mirror-symmetric frame gets a mirror-symmetric row."""
    f0 = np.arange(nf)
    f1 = (f0 + 1) % nf
    b0, b1 = nf + f0, nf + f1
    d_f0 = np.linalg.norm(nodes_xy[b1] - nodes_xy[f0], axis=1)
    d_f1 = np.linalg.norm(nodes_xy[b0] - nodes_xy[f1], axis=1)
    tie = np.abs(d_f0 - d_f1) <= 1e-9 * (d_f0 + d_f1)
    x_mid = nodes_xy[f0, 0] + nodes_xy[f1, 0]
    along_f0 = np.where(tie, x_mid > 0, d_f0 < d_f1)
    first = np.where(along_f0[:, None], np.column_stack([f0, f1, b1]), np.column_stack([f0, f1, b0]))
    second = np.where(along_f0[:, None], np.column_stack([f0, b1, b0]), np.column_stack([f1, b1, b0]))
    return np.vstack([first, second]).astype(np.int64)


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
