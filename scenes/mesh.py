"""The membrane's triangle mesh, defined once for every solver (FEM reference and DR triangles).

The region inside ``scene.outline`` is meshed with ``triangle`` (quality mesh, no Steiner points
on the boundary) at the scene's spacing h0 = side / divisions, with boundary nodes at every piece
end of the outline (fillet ends, so the clamps), at the base midpoint s = 0 and at the apex. The
strip's bond line, ``frame.bond_lever`` inside the centreline, is a line of mesh edges whose
vertices are the frame nodes' *bond nodes*: the film points that turn the strip's cross-section.
A mirror-symmetric outline is meshed on its right half and mirrored, so a symmetric scene gives a
symmetric discrete problem. ``refinement = k`` splits every triangle into four k times (element
size h0 / 2^k, nested meshes); new boundary nodes are put back on the curved outline at the mid
arc length of their edge, new bond-line nodes halfway between their neighbours on it.

``mesh.grading = g > 1`` grades the mesh towards the frame: the outline, the bond line and the
symmetry axis are spaced at the local size h(d) = min(h0, h0 / g + d / 2) of the distance d
from the outline, and the triangles are refined until each is within the area of an equilateral
triangle of h at its centroid. The frame's rod and the row of film it turns are where a uniform
mesh's shape error lives (docs/discrete-problem.md, "Graded meshes"). The size depends on d
only, so the right half meshed and mirrored stays symmetric, and ``refinement`` splits the
graded mesh as it does a uniform one.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, NamedTuple

import numpy as np
import triangle as tr
from matplotlib.path import Path as MplPath
from scipy.spatial import cKDTree

from .errors import SceneError
from .member_lines import SizeField, graded, member_lines, rows_between, spaced
from .members import Member, mirror_plan, ring_crossings
from .scene import Scene
from .windows import opened

GRADING_SLOPE = 0.5
"""Growth of a graded mesh's element size with the distance from the outline (mm per mm).
Measured at 130 % (P1 on 28 divisions, grading 4, against the P2 reference): slopes 0.25, 0.5
and 1 give shape errors 0.057 %, 0.064 %, 0.071 % on 6603, 6120, 5700 free DOFs."""

GRADING_PASSES = 12
"""Most refinement passes of a graded mesh (each refines the triangles above their local size)."""

@dataclass(frozen=True)
class TriangleMesh:
    """Flat straight-sided triangle mesh of a scene's membrane.

    Attributes
    ----------
    nodes
        (nv, 2) flat positions, mm.
    triangles
        (nt, 3) vertex ids, counter-clockwise seen from +z.
    frame_nodes, frame_s
        Boundary vertices ordered counter-clockwise from the base midpoint, and their arc
        lengths along the outline, mm.
    bond_nodes
        (nf,) for each frame node the vertex on the bond line beside it.
    spacing
        Nominal element size h0 / 2^refinement, mm: the boundary node spacing of a uniform mesh
        (a graded mesh's is this / ``mesh.grading`` and its elements grow to this inside).
    members, member_bonds
        For each of ``frame.members``, its centreline's vertex ids from its start to its end (both
        frame nodes), a line of mesh edges; and for each of them its bond node, on the member's
        bond line ``frame.bond_lever`` to its left (where the member crosses the outline's
        strip, the bond line's end, on the outline's bond line).
    strip_band
        (nt,) bool: the triangles of an open window's strip bands, the strip's own material
        (:mod:`scenes.windows`); the others are film. All False where every window has film.
    """

    nodes: np.ndarray
    triangles: np.ndarray
    frame_nodes: np.ndarray
    frame_s: np.ndarray
    bond_nodes: np.ndarray
    spacing: float
    members: tuple[np.ndarray, ...] = ()
    member_bonds: tuple[np.ndarray, ...] = ()
    strip_band: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.strip_band is None:
            object.__setattr__(self, "strip_band", np.zeros(len(self.triangles), bool))

    @property
    def film_triangles(self) -> np.ndarray:
        """(nf, 3) the film's triangles."""
        return self.triangles[~self.strip_band]

    @property
    def band_triangles(self) -> np.ndarray:
        """(nb, 3) the open windows' strip-band triangles."""
        return self.triangles[self.strip_band]

    @property
    def frame_bond(self) -> np.ndarray:
        """(nf, 2) the bond-line points of the frame nodes, mm."""
        return self.nodes[self.bond_nodes]


# ----------------------------------------------------------------------------- boundary


def _is_mirror_symmetric(scene: Scene) -> bool:
    o = scene.outline
    s = np.linspace(0.0, o.length, 721, endpoint=False)
    p, _ = o.evaluate(s)
    q, _ = o.evaluate(o.length - s)
    return bool(np.allclose(p * [-1.0, 1.0], q, atol=1e-9 * o.side_length))


def _boundary_arc_lengths(landmarks: np.ndarray, start: float, stop: float, h: float,
                          h_of: Callable[[np.ndarray], np.ndarray] | None = None) -> np.ndarray:
    """Arc lengths in [start, stop) at most h apart (or the local spacing h_of(s)), every
    landmark in that range included."""
    marks = np.unique(np.concatenate([[start, stop], landmarks[(landmarks > start) & (landmarks < stop)]]))
    parts = []
    for a, b in zip(marks[:-1], marks[1:]):
        if h_of is not None:
            parts.append(graded(a, b, h_of))
            continue
        n = max(1, int(np.ceil((b - a) / h - 1e-9)))
        parts.append(a + (b - a) * np.arange(n) / n)
    return np.concatenate(parts)


def _check_plane_graph(points: np.ndarray, loop: int, segments: np.ndarray) -> None:
    """Refuse what the mesh generator cannot take (it may crash on it): interior points outside
    the outline, or segments that cross or touch other than at a shared end. Where the frame
    is narrower than the strip, the strip's inner edge crosses itself or the outline."""
    inside = MplPath(points[:loop]).contains_points(points[loop:])
    a, b = points[segments[:, 0]], points[segments[:, 1]]
    reach = float(np.linalg.norm(b - a, axis=1).max())
    pairs = cKDTree(0.5 * (a + b)).query_pairs(reach, output_type="ndarray")
    i, j = pairs[:, 0], pairs[:, 1]
    apart = ~(segments[i][:, :, None] == segments[j][:, None, :]).any(axis=(1, 2))
    i, j = i[apart], j[apart]

    def side(p, q, r):  # sign of the turn p -> q -> r
        return np.sign((q[:, 0] - p[:, 0]) * (r[:, 1] - p[:, 1]) - (q[:, 1] - p[:, 1]) * (r[:, 0] - p[:, 0]))

    d1, d2 = side(a[i], b[i], a[j]), side(a[i], b[i], b[j])
    cross = (d1 * d2 <= 0) & (side(a[j], b[j], a[i]) * side(a[j], b[j], b[i]) <= 0)
    # collinear segments (the symmetry axis) cross only where their spans along the line meet
    line = (d1 == 0) & (d2 == 0)
    if line.any():
        u = b[i] - a[i]
        ti, tj = (np.einsum("kj,kj->k", q, u) for q in (a[i], b[i])), (np.einsum("kj,kj->k", q, u) for q in (a[j], b[j]))
        (pi, qi), (pj, qj) = ti, tj
        meet = np.maximum(np.minimum(pi, qi), np.minimum(pj, qj)) <= np.minimum(np.maximum(pi, qi), np.maximum(pj, qj))
        cross &= ~line | meet
    if not inside.all() or cross.any():
        raise SceneError("the bond line (frame.bond_lever inside the outline) leaves the outline or "
                         "crosses itself: the frame is too narrow or too sharply bent for its strip; widen the "
                         "outline, raise frame.corner_radius or lower frame.width")


def _triangulate(points: np.ndarray, loop: int, extra_segments: np.ndarray, h: float,
                 size: SizeField | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Triangles of the closed polygon ``points[:loop]`` with further points and interior
    segments (the bond line) that every mesh must follow; no new points on any segment. Element
    size h, or with ``size`` the local size at each triangle's centroid (at most h)."""
    segments = np.vstack([np.column_stack([np.arange(loop), np.roll(np.arange(loop), -1)]),
                          extra_segments]).astype(np.int32)
    _check_plane_graph(points, loop, segments)
    area = np.sqrt(3.0) / 4.0 * h * h
    out = tr.triangulate({"vertices": points, "segments": segments}, f"pq30a{area:.10f}YY")
    if size is not None:
        # refine until every triangle is within the area of an equilateral one of the local size
        for _ in range(GRADING_PASSES):
            v, t = out["vertices"], out["triangles"]
            target = np.sqrt(3.0) / 4.0 * size(v[t].mean(axis=1)) ** 2
            if np.all(_areas(v, t) <= target * (1.0 + 1e-9)):
                break
            out = tr.triangulate({"vertices": v, "segments": out["segments"], "triangles": t,
                                  "triangle_max_area": target}, "rpq30aYY")
    if not np.allclose(out["vertices"][: len(points)], points):
        raise SceneError("the mesh generator moved the outline's points: the outline is too coarse for "
                         "its corners; raise mesh.divisions or frame.corner_radius")
    return out["vertices"], out["triangles"]


def _areas(v: np.ndarray, t: np.ndarray) -> np.ndarray:
    e1, e2 = v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]]
    return 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])


def _bond_points(scene: Scene, s: np.ndarray) -> np.ndarray:
    """Points ``frame.bond_lever`` inside the outline at arc lengths s: the bond line."""
    return scene.outline.inner_offset(s, scene.frame.lever)


def _snap(s: np.ndarray, landmarks: np.ndarray, L: float) -> np.ndarray:
    """Arc lengths equal to a landmark up to round-off (mirrored ones) set exactly to it."""
    k = np.abs(s[:, None] - landmarks[None, :]) < 1e-9 * L
    out = s.copy()
    rows, cols = np.nonzero(k)
    out[rows] = landmarks[cols]
    return out


def mid_arc_length(sa: np.ndarray, sb: np.ndarray, L: float) -> np.ndarray:
    """Arc length halfway between sa and sb along the shorter way round the closed outline."""
    d = np.mod(sb - sa + 0.5 * L, L) - 0.5 * L
    return np.mod(sa + 0.5 * d, L)


class _Base(NamedTuple):
    """An unrefined mesh: vertices (nv, 2), triangles (nt, 3), boundary vertex ids, their arc
    lengths, their bond-line vertex ids, the members' centreline chains and their nodes' bond
    nodes."""

    verts: np.ndarray
    tris: np.ndarray
    frame_nodes: np.ndarray
    frame_s: np.ndarray
    bond_nodes: np.ndarray
    members: tuple[np.ndarray, ...] = ()
    member_bonds: tuple[np.ndarray, ...] = ()


def _base_mesh(scene: Scene, size: SizeField | None = None) -> _Base:
    """The mesh at the scene's spacing h0 (or the local size ``size``, at most h0)."""
    o = scene.outline
    h = scene.spacing
    L = o.length
    lever = scene.frame.lever
    s_apex = o.apex_arc_length()
    landmarks = np.unique(np.concatenate([o.breakpoints(), [s_apex, *scene.base_region()],
                                          *([m.s_start, *ring_crossings(o, m, scene.frame.lever, 0.0), m.s_end,
                                             *ring_crossings(o, m, scene.frame.lever, scene.frame.lever)]
                                            for m in scene.frame.cross_members)]))
    # one node where landmarks meet to round-off (a member square to the outline crosses the
    # bond ring at its own end's bond point)
    landmarks = landmarks[np.append(True, np.diff(landmarks) > 1e-9 * L)]
    along = None if size is None else (lambda s: size(o.evaluate(s)[0]))

    def spaced_on_axis(a: float, b: float) -> np.ndarray:
        if size is None:
            return spaced(a, b, h)
        return graded(a, b, lambda y: size(np.column_stack([np.zeros_like(y), y])))

    plan = mirror_plan(scene.frame.cross_members, 1e-9 * scene.outline.side_length) if _is_mirror_symmetric(scene) else None
    if plan is not None:
        right_members, crossing, partner = plan
        members = scene.frame.cross_members
        s_right = _boundary_arc_lengths(landmarks, 0.0, s_apex, h, along)
        right = o.evaluate(s_right)[0]
        right[0, 0] = 0.0
        apex = o.evaluate(s_apex)[0][0]
        apex[0] = 0.0
        bond = _bond_points(scene, np.append(s_right, s_apex))
        H = apex[1]
        # a member crossing the axis square meets it at a node, its bond line at another
        marks = np.unique([H, H - lever, lever, 0.0, *(y for k in crossing for y in (members[k].start[1],
                                                                                   members[k].start[1] + lever))])[::-1]
        y_sym = np.concatenate([spaced_on_axis(a, b) for a, b in zip(marks[:-1], marks[1:])])[1:]
        sym = np.column_stack([np.zeros_like(y_sym), y_sym])  # apex side down to y > 0
        loop = np.vstack([right, apex, sym])
        nl = len(loop)

        def on_axis_at(y: float) -> int:
            return len(right) + 1 + int(np.argmin(np.abs(y_sym - y)))

        i_top, i_bottom = on_axis_at(H - lever), on_axis_at(lever)
        chain = np.concatenate([[i_bottom], nl + np.arange(len(right) - 1), [i_top]])
        ring_of = (lambda i: nl + i - 1)  # the bond node of right-half frame node i > 0
        lines = member_lines(scene, [members[k] for k in right_members], s_right, np.vstack([loop, bond[1:-1]]),
                              ring_of, size)
        for k in crossing:  # its right half, from the axis to its right end
            member = members[k] if members[k].end[0] > 0 else Member(members[k].end, members[k].start,
                                                                     members[k].s_end, members[k].s_start)
            at = [int(np.argmin(np.abs(s_right - sj))) for sj in (ring_crossings(o, member, lever, 0.0)[1], member.s_end,
                                                                   ring_crossings(o, member, lever, lever)[1])]
            axis, axis_bond = on_axis_at(member.end[1]), on_axis_at(member.end[1] + lever)
            points, inner, beside = rows_between(lines.points, (axis, ring_of(at[0])), (axis_bond, ring_of(at[2])), h, size)
            lines = lines.with_member(points, np.concatenate([[axis], inner, [ring_of(at[0]), at[1]]]),
                                      np.concatenate([[axis_bond], beside, [ring_of(at[2])]]),
                                      np.concatenate([[axis_bond], beside, [ring_of(at[2])] * 2]))
        verts, tris = _triangulate(lines.points, nl, np.vstack([np.column_stack([chain[:-1], chain[1:]]),
                                                                *lines.segments]), h, size)
        on_axis = np.abs(verts[:, 0]) < 1e-9 * o.side_length
        verts[on_axis, 0] = 0.0
        mirror_id = np.arange(len(verts))
        off = np.flatnonzero(~on_axis)
        mirror_id[off] = len(verts) + np.arange(off.size)
        verts = np.vstack([verts, verts[off] * [-1.0, 1.0]])
        tris = np.vstack([tris, mirror_id[tris][:, ::-1]])
        # boundary: right half 0..len(right) (apex), then the mirrored right half, reversed
        b_right = np.arange(len(right) + 1)
        b_left = mirror_id[np.arange(1, len(right))][::-1]
        s_b = _snap(np.concatenate([np.append(s_right, s_apex), (L - s_right[1:])[::-1]]), landmarks, L)
        bond_b = np.concatenate([chain, mirror_id[chain[1:-1]][::-1]])
        # the members in the scene's order: a left member is its partner's mirror image, run
        # backwards so that its bond line is on its left; a crossing member is its right half's
        # mirror image run backwards, then that half
        chains, bonds = {}, {}
        for j, k in enumerate(right_members):
            chains[k], bonds[k] = lines.centre[j], lines.bonds[j]
        for k, j in partner.items():
            chains[k], bonds[k] = mirror_id[chains[j]][::-1], mirror_id[bonds[j]][::-1]
        for j, k in enumerate(crossing, start=len(right_members)):
            half, half_bonds = lines.centre[j], lines.bonds[j]
            chains[k] = np.concatenate([mirror_id[half][::-1], half[1:]])
            bonds[k] = np.concatenate([mirror_id[half_bonds][::-1], half_bonds[1:]])
        order = range(len(members))
        return _Base(verts, tris, np.concatenate([b_right, b_left]), s_b, bond_b,
                     tuple(chains[k] for k in order), tuple(bonds[k] for k in order))
    s = _boundary_arc_lengths(landmarks, 0.0, L, h, along)
    m = s.size
    ring = m + np.arange(m)
    points = np.vstack([o.evaluate(s)[0], _bond_points(scene, s)])
    lines = member_lines(scene, scene.frame.cross_members, s, points, lambda i: m + i, size)
    segments = np.vstack([np.column_stack([ring, np.roll(ring, -1)]), *lines.segments])
    verts, tris = _triangulate(lines.points, m, segments, h, size)
    return _Base(verts, tris, np.arange(m), s, ring, tuple(lines.centre), tuple(lines.bonds))


def _size_field(scene: Scene) -> SizeField | None:
    """The scene's local element size (None: uniform at h0): h0 / mesh.grading on the outline,
    growing by GRADING_SLOPE times the distance from it, up to h0."""
    g = scene.mesh.grading
    if g == 1.0:
        return None
    h0, outline = scene.spacing, scene.outline
    return lambda p: np.minimum(h0, h0 / g + GRADING_SLOPE * outline.distance(p))


def _refine(verts: np.ndarray, tris: np.ndarray) -> tuple[np.ndarray, np.ndarray, dict]:
    """Split every triangle into four at its edge midpoints. Returns the new vertices, triangles
    and the map (a, b) -> midpoint vertex of every old edge (a < b)."""
    nv = len(verts)
    pairs = np.sort(np.vstack([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]]), axis=1)
    edges, inverse = np.unique(pairs, axis=0, return_inverse=True)
    mid = nv + inverse.reshape(3, -1).T  # (nt, 3): midpoints of edges 01, 12, 20
    a, b, c = tris.T
    m01, m12, m20 = mid.T
    fine = np.vstack([np.column_stack([a, m01, m20]), np.column_stack([m01, b, m12]),
                      np.column_stack([m20, m12, c]), np.column_stack([m01, m12, m20])])
    new = np.vstack([verts, 0.5 * (verts[edges[:, 0]] + verts[edges[:, 1]])])
    return new, fine, {(int(p), int(q)): nv + k for k, (p, q) in enumerate(edges)}


def chain_with_midpoints(chain: np.ndarray, midpoint: dict) -> np.ndarray:
    """An open chain of vertex ids with the midpoint of each of its edges put between its ends."""
    mids = [midpoint[(min(p, q), max(p, q))] for p, q in zip(chain[:-1].tolist(), chain[1:].tolist())]
    return np.column_stack([chain, np.append(mids, -1)]).ravel()[:-1]


def membrane_mesh(scene: Scene, refinement: int = 0) -> TriangleMesh:
    """The membrane mesh of ``scene`` at ``refinement`` (element size halved that many times).

    Raises
    ------
    SceneError
        If ``refinement`` is not a whole number >= 0.
    """
    if isinstance(refinement, bool) or not isinstance(refinement, (int, np.integer)) or refinement < 0:
        raise SceneError(f"fem.refinement = {refinement!r} must be a whole number >= 0")
    o = scene.outline
    L = o.length
    verts, tris, b_ids, b_s, b_bond, members, member_bonds = _base_mesh(scene, _size_field(scene))
    for _ in range(int(refinement)):
        verts, tris, midpoint = _refine(verts, tris)
        members = tuple(chain_with_midpoints(c, midpoint) for c in members)
        # two nodes sharing a bond node (a member's end) give it to the node between them
        shared = {**midpoint, **{(int(b), int(b)): int(b) for c in member_bonds for b in c}}
        member_bonds = tuple(chain_with_midpoints(c, shared) for c in member_bonds)
        ring = np.roll(b_ids, -1)
        new_ids = np.array([midpoint[(min(p, q), max(p, q))] for p, q in zip(b_ids, ring)])
        new_bond = np.array([midpoint[(min(p, q), max(p, q))] for p, q in zip(b_bond, np.roll(b_bond, -1))])
        s_mid = mid_arc_length(b_s, np.roll(b_s, -1), L)
        verts[new_ids] = o.evaluate(s_mid)[0]
        b_ids = np.column_stack([b_ids, new_ids]).ravel()
        b_s = np.column_stack([b_s, s_mid]).ravel()
        b_bond = np.column_stack([b_bond, new_bond]).ravel()
    # counter-clockwise seen from +z, so that element normals point up in the flat state
    p = verts[tris]
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    flip = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0] < 0
    tris[flip] = tris[flip][:, ::-1]
    order = np.argsort(b_s)
    mesh = TriangleMesh(
        nodes=verts,
        triangles=tris.astype(np.int64),
        frame_nodes=b_ids[order].astype(np.int64),
        frame_s=b_s[order],
        bond_nodes=b_bond[order].astype(np.int64),
        spacing=scene.spacing / 2 ** int(refinement),
        members=tuple(c.astype(np.int64) for c in members),
        member_bonds=tuple(c.astype(np.int64) for c in member_bonds),
    )
    return opened(mesh, scene.outline, scene.frame) if scene.frame.open_regions else mesh

