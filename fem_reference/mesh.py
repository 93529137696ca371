"""The membrane mesh as scikit-fem sees it: the scene's one triangle mesh (``scenes.mesh``, which
DR's membrane triangles use too), as P1 or isoparametric P2 (``MeshTri2``, boundary edge nodes
on the outline as well).

Node numbering is scikit-fem's DOF numbering: vertices first, then (P2) one node per edge.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp
from skfem import Basis, ElementTriP1, ElementTriP2, ElementVector, MeshTri1, MeshTri2

from scenes import Scene, SceneError
from scenes.mesh import chain_with_midpoints, mid_arc_length, membrane_mesh
from scenes.transfer import locate

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
        (nf, 2) for each frame node its point on the bond line (``frame.bond_lever`` inside), mm:
        a line of mesh edges.
    spacing
        Boundary node spacing along the outline, mm (vertex to vertex).
    cells, cell_type
        VTK connectivity of the elements ('triangle' or 'triangle6') in node numbers.
    members, member_inner
        For each of ``frame.members``, the nodes on its centreline from its start to its end
        (with P2 the edge nodes between the vertices), and (m, 2) their points on the member's
        bond line (``scenes.mesh.TriangleMesh.member_bonds``), mm.
    strip_band
        (nel,) bool: the elements of the open windows' strip bands, the strip's material
        (``scenes.mesh.TriangleMesh.strip_band``); the others are film.
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
    members: tuple[np.ndarray, ...] = ()
    member_inner: tuple[np.ndarray, ...] = ()
    strip_band: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.strip_band is None:
            self.strip_band = np.zeros(len(self.cells), bool)

    @property
    def n_nodes(self) -> int:
        return self.nodes.shape[0]

    @property
    def film_cells(self) -> np.ndarray:
        """The film elements' VTK connectivity."""
        return self.cells[~self.strip_band]

    def part_basis(self, strip: bool) -> Basis | None:
        """The vector basis on the film's elements (``strip`` False) or the strip bands' (None
        where there are none); the whole basis where every element is film."""
        chosen = np.flatnonzero(self.strip_band == strip)
        if chosen.size == len(self.strip_band):
            return self.basis
        if chosen.size == 0:
            return None
        return Basis(self.mesh, self.basis.elem, elements=chosen, quadrature=(self.basis.X, self.basis.W))

    def interpolation(self, points: np.ndarray, cells: np.ndarray | None = None,
                      gradients: bool = False) -> list[sp.csr_matrix]:
        """Sparse (m, nn) matrices of the shape-function values (and, with ``gradients``, their
        x and y derivatives) at reference points (m, 2) mm, optionally in given cells."""
        if cells is None:
            # a point on the rim of an open window is on the mesh's boundary: nearest edge's cell
            cells, base = locate(self.linear.p.T, self.linear.t.T, points)
            if np.any(np.linalg.norm(base - points, axis=1) > 1e-9 * self.spacing):
                raise FEMError("a point of the strip's inner edge falls outside the film mesh: a corner is "
                               "too sharp for the mesh; raise frame.corner_radius or mesh.divisions")
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
        pts = fine.nodes
        cells, base = locate(self.linear.p.T, self.linear.t.T, pts)
        P, Gx, Gy = self.interpolation(base, cells, gradients=True)
        offset = pts - base
        return P @ x + (Gx @ x) * offset[:, :1] + (Gy @ x) * offset[:, 1:]


# ----------------------------------------------------------------------------- build


def build_mesh(scene: Scene, refinement: int = 0, element: str = "P1") -> MembraneMesh:
    """Mesh of ``scene``'s membrane at ``refinement`` (element size halved that many times).

    Raises
    ------
    SceneError
        If ``refinement`` or ``element`` is not valid.
    """
    if element not in ELEMENTS:
        raise SceneError(f"fem.element = {element!r} is not one of {', '.join(map(repr, ELEMENTS))}")
    o = scene.outline
    L = o.length
    shared = membrane_mesh(scene, refinement)
    mesh = MeshTri1(shared.nodes.T.copy(), shared.triangles.T.copy())
    linear = mesh
    # the boundary is the outline, and the open windows' rims
    boundary, holes = mesh.boundary_nodes(), shared.strip_band.any()
    if not np.isin(shared.frame_nodes, boundary).all() or (not holes and boundary.size != shared.frame_nodes.size):
        raise FEMError("the film mesh's boundary does not follow the outline (a corner too tight for the "
                       "mesh spacing, or the strip's inner edge crossing itself); raise frame.corner_radius "
                       "or mesh.divisions")
    b_vert, nodes_s, nodes_inner = shared.frame_nodes, shared.frame_s, shared.frame_bond
    nv = mesh.p.shape[1]
    members = shared.members
    member_inner = tuple(shared.nodes[b] for b in shared.member_bonds)
    if element == "P2":
        s_of = np.full(nv, np.nan)
        s_of[b_vert] = nodes_s
        inner_of = np.full((nv, 2), np.nan)
        inner_of[b_vert] = nodes_inner
        quad = MeshTri2.from_mesh(mesh)
        facets = quad.boundary_facets()
        facets = facets[np.isfinite(s_of[quad.facets[:, facets]]).all(axis=0)]  # the outline's, not a hole's
        a, b = quad.facets[:, facets]
        s_mid = mid_arc_length(s_of[a], s_of[b], L)
        doflocs = quad.doflocs.copy()
        doflocs[:, nv + facets] = o.evaluate(s_mid)[0].T
        mesh = replace(quad, doflocs=doflocs)
        b_vert = np.concatenate([b_vert, nv + facets])
        nodes_s = np.concatenate([nodes_s, s_mid])
        nodes_inner = np.vstack([nodes_inner, 0.5 * (inner_of[a] + inner_of[b])])
        edge_node = {(int(i), int(j)): nv + f for f, (i, j) in enumerate(np.sort(quad.facets, axis=0).T)}
        members = tuple(chain_with_midpoints(c, edge_node) for c in members)
        member_inner = tuple(np.insert(p, np.arange(1, len(p)), 0.5 * (p[:-1] + p[1:]), axis=0) for p in member_inner)
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
        spacing=shared.spacing,
        cells=cells,
        cell_type=cell_type,
        members=tuple(np.asarray(c, np.int64) for c in members),
        member_inner=member_inner,
        strip_band=shared.strip_band,
    )
