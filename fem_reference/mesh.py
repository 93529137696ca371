"""Triangle mesh of the membrane region whose boundary nodes lie on the frame centreline.

The region inside ``scene.outline`` is meshed with ``triangle`` (quality mesh, no Steiner points on
the boundary) at the scene's spacing h0 = side / divisions, with boundary nodes at every piece end
of the outline (fillet ends, so the clamps), at the base midpoint s = 0 and at the apex. A mirror-
symmetric outline is meshed on its right half and mirrored, so a symmetric scene gives a
symmetric discrete problem. ``refinement = k`` splits every triangle into four k times (element
size h0 / 2^k, nested meshes for a clean convergence study); new boundary nodes are put back on
the curved outline at the mid arc length of their edge. P2 meshes are isoparametric
(``MeshTri2``) with their boundary edge nodes on the outline as well.

Node numbering is scikit-fem's DOF numbering: vertices first, then (P2) one node per edge.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp
import triangle as tr
from matplotlib.path import Path as MplPath
from matplotlib.tri import Triangulation
from scipy.spatial import cKDTree
from skfem import Basis, ElementTriP1, ElementTriP2, ElementVector, MeshTri1, MeshTri2

from scenes import Scene, SceneError

from .errors import FEMError

ELEMENTS = {"P1": ElementTriP1, "P2": ElementTriP2}


@dataclass
class MembraneMesh:
    """The flat membrane mesh and its frame (boundary) nodes.

    Attributes
    ----------
    mesh
        ``MeshTri1`` (P1) or isoparametric ``MeshTri2`` (P2), mm.
    linear
        The straight-sided ``MeshTri1`` with the same vertices (point location, output).
    element
        'P1' or 'P2'.
    basis
        Vector basis (3 components) of the membrane displacement.
    nodes
        (nn, 2) reference positions of the DOF nodes, mm.
    frame_nodes, frame_s
        Boundary nodes ordered counter-clockwise from the base midpoint, and their arc lengths (mm).
    frame_inner
        (nf, 2) for each frame node its point on the strip's inner edge (b/2 inside), mm: a line
        of mesh edges.
    spacing
        Boundary node spacing along the outline, mm (vertex to vertex).
    cells, cell_type
        VTK connectivity of the elements ('triangle' or 'triangle6') in node numbers.
    """

    mesh: MeshTri1
    linear: MeshTri1
    element: str
    basis: Basis
    nodes: np.ndarray
    frame_nodes: np.ndarray
    frame_s: np.ndarray
    frame_inner: np.ndarray
    spacing: float
    cells: np.ndarray
    cell_type: str

    @property
    def n_nodes(self) -> int:
        return self.nodes.shape[0]

    def interpolation(self, points: np.ndarray, cells: np.ndarray | None = None,
                      gradients: bool = False) -> list[sp.csr_matrix]:
        """Sparse (m, nn) matrices of the shape-function values (and, with ``gradients``, their
        x and y derivatives) at reference points (m, 2) mm, optionally in given cells."""
        if cells is None:
            try:
                cells = self.linear.element_finder()(points[:, 0], points[:, 1])
            except ValueError:  # skfem: 'Point is outside of the mesh'
                raise FEMError("a point of the strip's inner edge falls outside the film mesh: a corner is "
                               "too sharp for the mesh; raise frame.corner_radius or mesh.divisions") from None
        scalar = Basis(self.mesh, ELEMENTS[self.element]())
        local = scalar.mapping.invF(points.T[:, :, None], tind=cells)
        fields = [scalar.elem.gbasis(scalar.mapping, local, k, tind=cells)[0]
                  for k in range(scalar.Nbfun)]
        parts = [np.array([np.asarray(f)[:, 0] for f in fields])]  # (nbfun, m)
        if gradients:
            parts += [np.array([f.grad[j][:, 0] for f in fields]) for j in range(2)]
        rows = np.tile(np.arange(points.shape[0]), scalar.Nbfun)
        cols = scalar.element_dofs[:, cells].ravel()
        out = []
        for values in parts:
            P = sp.coo_matrix((values.ravel(), (rows, cols)), shape=(points.shape[0], scalar.N)).tocsr()
            P.data[np.abs(P.data) < 1e-14 * np.abs(P.data).max()] = 0.0
            P.eliminate_zeros()
            out.append(P)
        return out

    def transfer(self, x: np.ndarray, fine: "MembraneMesh") -> np.ndarray:
        """Node positions (nn_fine, 3) on a finer mesh of the same region, from positions x
        (nn, 3) on this one: interpolated, and outside this mesh's straight-edged boundary
        extrapolated with the local deformation gradient (so the curved outline's offset turns
        with the frame)."""
        lin = self.linear
        pts = fine.nodes
        cells = Triangulation(lin.p[0], lin.p[1], lin.t.T).get_trifinder()(pts[:, 0], pts[:, 1])
        base = pts.copy()
        out = np.flatnonzero(cells < 0)
        if out.size:
            facets = lin.boundary_facets()
            a, b = lin.p[:, lin.facets[0, facets]].T, lin.p[:, lin.facets[1, facets]].T
            ab = b - a
            u = np.clip(np.einsum("mkj,kj->mk", pts[out, None, :] - a[None], ab)
                        / np.einsum("kj,kj->k", ab, ab), 0.0, 1.0)
            near = a[None] + u[..., None] * ab[None]
            k = np.argmin(np.linalg.norm(pts[out, None, :] - near, axis=2), axis=1)
            base[out] = near[np.arange(out.size), k]
            cells[out] = lin.f2t[0, facets[k]]
        P, Gx, Gy = self.interpolation(base, cells, gradients=True)
        offset = pts - base
        return P @ x + (Gx @ x) * offset[:, :1] + (Gy @ x) * offset[:, 1:]


# ----------------------------------------------------------------------------- boundary


def _is_mirror_symmetric(scene: Scene) -> bool:
    o = scene.outline
    s = np.linspace(0.0, o.length, 721, endpoint=False)
    p, _ = o.evaluate(s)
    q, _ = o.evaluate(o.length - s)
    return bool(np.allclose(p * [-1.0, 1.0], q, atol=1e-9 * o.side_length))


def _boundary_arc_lengths(landmarks: np.ndarray, start: float, stop: float, h: float) -> np.ndarray:
    """Arc lengths in [start, stop) at most h apart, every landmark in that range included."""
    marks = np.unique(np.concatenate([[start, stop], landmarks[(landmarks > start) & (landmarks < stop)]]))
    parts = []
    for a, b in zip(marks[:-1], marks[1:]):
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

    cross = ((side(a[i], b[i], a[j]) * side(a[i], b[i], b[j]) <= 0)
             & (side(a[j], b[j], a[i]) * side(a[j], b[j], b[i]) <= 0))
    if not inside.all() or cross.any():
        raise FEMError("the strip's inner edge (frame.width / 2 inside the outline) leaves the outline or "
                       "crosses itself: the frame is too narrow or too sharply bent for its strip; widen the "
                       "outline, raise frame.corner_radius or lower frame.width")


def _triangulate(points: np.ndarray, loop: int, extra_segments: np.ndarray, h: float
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Triangles of the closed polygon ``points[:loop]`` with further points and interior
    segments (the bonded strip's inner edge) that every mesh must follow; no new points on any
    segment."""
    segments = np.vstack([np.column_stack([np.arange(loop), np.roll(np.arange(loop), -1)]),
                          extra_segments]).astype(np.int32)
    _check_plane_graph(points, loop, segments)
    area = np.sqrt(3.0) / 4.0 * h * h
    out = tr.triangulate({"vertices": points, "segments": segments}, f"pq30a{area:.10f}YY")
    if not np.allclose(out["vertices"][: len(points)], points):
        raise FEMError("the mesh generator moved the outline's points: the outline is too coarse for "
                       "its corners; raise mesh.divisions or frame.corner_radius")
    return out["vertices"], out["triangles"]


def _inner_points(scene: Scene, s: np.ndarray) -> np.ndarray:
    """Points b/2 inside the outline at arc lengths s: the inner edge of the bonded strip."""
    p, t = scene.outline.evaluate(s)
    return p + 0.5 * scene.frame.width * np.column_stack([-t[:, 1], t[:, 0]])


def _spaced(a: float, b: float, h: float) -> np.ndarray:
    """Points from a (included) towards b (excluded) at most h apart."""
    n = max(1, int(np.ceil(abs(b - a) / h - 1e-9)))
    return a + (b - a) * np.arange(n) / n


def _base_mesh(scene: Scene) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Vertices (nv, 2), triangles (nt, 3), boundary vertex ids, their arc lengths, and their
    points on the strip's inner edge (nb, 2), at the scene's spacing h0.

    The inner edge of the bonded strip (b/2 inside the centreline) is a line of mesh nodes: the
    strip's orientation is tied to the film there, and the film kinks along it.
    """
    o = scene.outline
    h = scene.spacing
    L = o.length
    half_b = 0.5 * scene.frame.width
    s_apex = o.apex_arc_length()
    landmarks = np.unique(np.concatenate([o.breakpoints(), [s_apex, *scene.base_region()]]))
    if _is_mirror_symmetric(scene):
        s_right = _boundary_arc_lengths(landmarks, 0.0, s_apex, h)
        right = o.evaluate(s_right)[0]
        right[0, 0] = 0.0
        apex = o.evaluate(s_apex)[0][0]
        apex[0] = 0.0
        inner = _inner_points(scene, np.append(s_right, s_apex))
        inner[[0, -1], 0] = 0.0
        H = apex[1]
        y_sym = np.concatenate([_spaced(H, H - half_b, h), _spaced(H - half_b, half_b, h),
                                _spaced(half_b, 0.0, h)])[1:]
        sym = np.column_stack([np.zeros_like(y_sym), y_sym])  # apex side down to y > 0
        loop = np.vstack([right, apex, sym])
        nl = len(loop)
        i_top = len(right) + 1 + int(np.argmin(np.abs(y_sym - (H - half_b))))
        i_bottom = len(right) + 1 + int(np.argmin(np.abs(y_sym - half_b)))
        chain = np.concatenate([[i_bottom], nl + np.arange(len(right) - 1), [i_top]])
        verts, tris = _triangulate(np.vstack([loop, inner[1:-1]]), nl,
                                   np.column_stack([chain[:-1], chain[1:]]), h)
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
        inner_b = np.vstack([inner, (inner[1:-1] * [-1.0, 1.0])[::-1]])
        return verts, tris, np.concatenate([b_right, b_left]), s_b, inner_b
    s = _boundary_arc_lengths(landmarks, 0.0, L, h)
    inner = _inner_points(scene, s)
    m = s.size
    ring = m + np.arange(m)
    verts, tris = _triangulate(np.vstack([o.evaluate(s)[0], inner]), m,
                               np.column_stack([ring, np.roll(ring, -1)]), h)
    return verts, tris, np.arange(m), s, inner


def _snap(s: np.ndarray, landmarks: np.ndarray, L: float) -> np.ndarray:
    """Arc lengths equal to a landmark up to round-off (mirrored ones) set exactly to it."""
    k = np.abs(s[:, None] - landmarks[None, :]) < 1e-9 * L
    out = s.copy()
    rows, cols = np.nonzero(k)
    out[rows] = landmarks[cols]
    return out


def _mid_arc_length(sa: np.ndarray, sb: np.ndarray, L: float) -> np.ndarray:
    """Arc length halfway between sa and sb along the shorter way round the closed outline."""
    d = np.mod(sb - sa + 0.5 * L, L) - 0.5 * L
    return np.mod(sa + 0.5 * d, L)


# ----------------------------------------------------------------------------- build


def build_mesh(scene: Scene, refinement: int = 0, element: str = "P1") -> MembraneMesh:
    """Mesh of ``scene``'s membrane at ``refinement`` (element size halved that many times).

    Raises
    ------
    SceneError
        If ``refinement`` or ``element`` is not valid.
    """
    if isinstance(refinement, bool) or not isinstance(refinement, (int, np.integer)) or refinement < 0:
        raise SceneError(f"fem.refinement = {refinement!r} must be a whole number >= 0")
    if element not in ELEMENTS:
        raise SceneError(f"fem.element = {element!r} is not one of {', '.join(map(repr, ELEMENTS))}")
    o = scene.outline
    L = o.length
    verts, tris, b_ids, b_s, b_inner = _base_mesh(scene)
    mesh = MeshTri1(verts.T.copy(), tris.T.copy())
    s_of = np.full(mesh.p.shape[1], np.nan)
    s_of[b_ids] = b_s
    inner_of = np.full((mesh.p.shape[1], 2), np.nan)
    inner_of[b_ids] = b_inner
    for _ in range(int(refinement)):
        facets = mesh.boundary_facets()
        a, b = mesh.facets[:, facets]
        s_mid = _mid_arc_length(s_of[a], s_of[b], L)
        nv = mesh.p.shape[1]
        fine = mesh.refined()
        p = fine.p.copy()
        new = nv + facets  # refined() numbers edge midpoints after the old vertices, in facet order
        p[:, new] = o.evaluate(s_mid)[0].T
        mesh = MeshTri1(p, fine.t)
        s_of = np.concatenate([s_of, np.full(p.shape[1] - nv, np.nan)])
        s_of[new] = s_mid
        inner_of = np.vstack([inner_of, np.full((p.shape[1] - nv, 2), np.nan)])
        inner_of[new] = 0.5 * (inner_of[a] + inner_of[b])  # the inner edge's new mid node
    linear = mesh
    b_vert = np.flatnonzero(~np.isnan(s_of))
    if not np.array_equal(np.sort(b_vert), np.sort(mesh.boundary_nodes())):
        raise FEMError("the film mesh's boundary does not follow the outline (a corner too tight for the "
                       "mesh spacing, or the strip's inner edge crossing itself); raise frame.corner_radius "
                       "or mesh.divisions")
    nodes_s = s_of[b_vert]
    nodes_inner = inner_of[b_vert]
    nv = mesh.p.shape[1]
    if element == "P2":
        quad = MeshTri2.from_mesh(mesh)
        facets = quad.boundary_facets()
        a, b = quad.facets[:, facets]
        s_mid = _mid_arc_length(s_of[a], s_of[b], L)
        doflocs = quad.doflocs.copy()
        doflocs[:, nv + facets] = o.evaluate(s_mid)[0].T
        mesh = replace(quad, doflocs=doflocs)
        b_vert = np.concatenate([b_vert, nv + facets])
        nodes_s = np.concatenate([nodes_s, s_mid])
        nodes_inner = np.vstack([nodes_inner, 0.5 * (inner_of[a] + inner_of[b])])
        t2f = linear.t2f  # local edges (0-1, 1-2, 0-2): VTK triangle6 order
        cells = np.vstack([linear.t, nv + t2f]).T
        cell_type = "triangle6"
    else:
        cells, cell_type = linear.t.T.copy(), "triangle"
    # counter-clockwise seen from +z, so that element normals point up in the flat state
    p = linear.p[:, linear.t]
    flip = (p[0, 1] - p[0, 0]) * (p[1, 2] - p[1, 0]) - (p[1, 1] - p[1, 0]) * (p[0, 2] - p[0, 0]) < 0
    swap = [0, 2, 1, 5, 4, 3] if cell_type == "triangle6" else [0, 2, 1]
    cells[flip] = cells[flip][:, swap]
    basis = Basis(mesh, ElementVector(ELEMENTS[element](), 3))
    nodes = basis.doflocs[:, ::3].T.copy()
    order = np.argsort(nodes_s)
    return MembraneMesh(
        mesh=mesh,
        linear=linear,
        element=element,
        basis=basis,
        nodes=nodes,
        frame_nodes=b_vert[order],
        frame_s=nodes_s[order],
        frame_inner=nodes_inner[order],
        spacing=scene.spacing / 2**int(refinement),
        cells=cells,
        cell_type=cell_type,
    )
