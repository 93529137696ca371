"""Geometrically exact frame: a discrete rod on the membrane's boundary nodes.

The rod is position-based, so rotations of any size are exact: its nodes *are* mesh nodes (no
rotational unknowns, no ties). Every edge e carries an orthonormal frame (t, d2, n): t along the
edge, d2 across the strip (in its plane, towards the membrane), n = t x d2 its normal (+z flat).
The across direction comes from a *director point* p_e, a membrane material point bonded to the
strip: d2 = unit(q - (q.t) t) with q = p_e - (edge midpoint). For the DEMES the director point
sits at the inner edge of the bonded strip, b/2 inside the centreline, so the strip follows the
film with a lever arm that does not change with the mesh. Edges whose two ends are held keep
their flat frame (the taped base: tangent and normal clamped).

Energies (reference lengths l_e of the flat chords, Voronoi lengths l_v of the free edges
around a vertex, so a clamped vertex counts half an edge, which keeps the clamp second order):

* axial, per free edge: EA / (2 l_e) (|e| - l_e)^2;
* ``"strip"``, per vertex between edges a and b: with Q = R_a^T R_b (R = [t d2 n]) the discrete
  curvature-twist vector kappa = 2 axial(Q - Q^T) / (1 + tr Q) = 2 tan(phi/2) axis (exact and
  smooth up to phi = pi per vertex) and
  (1 / 2 l_v) [GJ (k_t - k0_t)^2 + EI_w (k_d2 - k0_d2)^2 + EI_s (k_n - k0_n)^2],
  rest values from the flat outline (the fillets' in-plane curvature);
* ``"paper"``, per vertex, isotropic: kb = 2 t_a x t_b / (1 + t_a . t_b) and
  EI / (2 l_v) (|kb| - |kb0|)^2: the bending plane is free to turn (M = EI (|kappa| - kappa0)).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .rod_kernels import PAPER, STRIP, Jets, edge_terms, split, vertex_normals, vertex_terms

MODELS = ("paper", "strip")


@dataclass(frozen=True)
class RodProperties:
    """Section stiffnesses: EA (N), EI weak-axis / isotropic, EI_strong and GJ (N mm^2)."""

    model: str
    EA: float
    EI: float
    EI_strong: float = 0.0
    GJ: float = 0.0

    def __post_init__(self) -> None:
        if self.model not in MODELS:
            raise ValueError(f"frame.model = {self.model!r} is not one of {', '.join(MODELS)}")


@dataclass
class StencilTerms:
    """Energies of a batch of stencils and where their local variables go (point indices)."""

    energy: Jets  # value (S,), gradient (S, 3 m), Hessian (S, 3 m, 3 m)
    points: np.ndarray  # (S, m) point ids; local variable 3 j + c is component c of point j


def scatter(terms: list[StencilTerms], n_points: int, order: int
            ) -> tuple[np.ndarray, sp.csr_matrix | None]:
    """Gradient (3 n_points,) and Hessian (sparse) in point space from stencil derivatives."""
    g = np.zeros(3 * n_points)
    rows, cols, vals = [], [], []
    for term in terms:
        if term.points.shape[0] == 0:
            continue
        idx = (3 * term.points[:, :, None] + np.arange(3)).reshape(term.points.shape[0], -1)
        np.add.at(g, idx, term.energy.grad)
        if order >= 2:
            rows.append(np.broadcast_to(idx[:, :, None], term.energy.hess.shape).ravel())
            cols.append(np.broadcast_to(idx[:, None, :], term.energy.hess.shape).ravel())
            vals.append(term.energy.hess.ravel())
    if order < 2:
        return g, None
    if not vals:
        return g, sp.csr_matrix((3 * n_points, 3 * n_points))
    K = sp.coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(3 * n_points, 3 * n_points)).tocsr()
    return g, K


class Rod:
    """A discrete rod along ``chain`` (node ids), open or closed, on node positions (nn, 3).

    Parameters
    ----------
    X
        Reference (stress-free) positions of all nodes, (nn, 3) mm.
    chain
        Node ids along the rod, in order; for a closed rod the last joins the first.
    closed
        Whether the rod is a loop.
    held
        (nn,) bool: nodes whose positions are prescribed. Edges between two held nodes keep
        their reference frame; vertices between two such edges carry no energy.
    props
        Stiffnesses and model.
    directors
        Sparse (n_edges, nn) weights giving each edge's director point as a combination of node
        positions; needed by the 'strip' model and by a film offset.
    offset
        Film offset d (mm, + along n): where the membrane acts on the strip.
    """

    def __init__(self, X: np.ndarray, chain: np.ndarray, closed: bool, held: np.ndarray,
                 props: RodProperties, directors: sp.spmatrix | None = None, offset: float = 0.0):
        self.X = np.asarray(X, dtype=float)
        self.chain = np.asarray(chain)
        self.closed = bool(closed)
        self.props = props
        self.offset = float(offset)
        nn, m = self.X.shape[0], self.chain.size
        self.n_nodes = nn
        n_edges = m if closed else m - 1
        self.needs_frames = props.model == "strip" or self.offset != 0.0
        if self.needs_frames and directors is None:
            raise ValueError("the 'strip' model and a film offset need director points per edge")
        if directors is not None and directors.shape != (n_edges, nn):
            raise ValueError(f"directors must be ({n_edges}, {nn}), got {directors.shape}")
        self.B = sp.vstack([sp.identity(nn, format="csr"),
                            directors if directors is not None else sp.csr_matrix((0, nn))]).tocsr()
        self.B3 = sp.kron(self.B, sp.identity(3), format="csr")
        self.n_points = self.B.shape[0]

        ends = np.column_stack([self.chain[:n_edges], np.roll(self.chain, -1)[:n_edges]])
        self.edges = ends
        self.edge_held = held[ends[:, 0]] & held[ends[:, 1]]
        self.rest_length = np.linalg.norm(self.X[ends[:, 1]] - self.X[ends[:, 0]], axis=1)
        t0 = (self.X[ends[:, 1]] - self.X[ends[:, 0]]) / self.rest_length[:, None]
        n0 = np.tile([0.0, 0.0, 1.0], (n_edges, 1))
        self.rest_frames = np.stack([t0, np.cross(n0, t0), n0], axis=1)  # (E, 3 axes, 3)

        k = np.arange(m) if closed else np.arange(1, m - 1)
        a, b = (k - 1) % n_edges, k % n_edges
        keep = ~(self.edge_held[a] & self.edge_held[b])
        self.vertex = k[keep]  # chain positions of the vertices with energy
        self.vertex_edges = np.column_stack([a[keep], b[keep]])
        w = np.where(self.edge_held, 0.0, self.rest_length)
        self.voronoi = 0.5 * (w[a[keep]] + w[b[keep]])
        self.vertex_points = self._vertex_points(self.vertex)
        self.free_edges = np.flatnonzero(~self.edge_held)
        self.rest_kappa = np.zeros((self.vertex.size, 3))  # the flat outline's, measured next
        self.rest_kappa = self._vertex_jets(self.X, 0)[0]

    # ------------------------------------------------------------------ stencils
    def _vertex_points(self, k: np.ndarray) -> np.ndarray:
        """Point ids of vertex stencils at chain positions k: 3 nodes (+ 2 director points)."""
        m, nn = self.chain.size, self.n_nodes
        n_edges = self.edges.shape[0]
        ids = [self.chain[(k - 1) % m], self.chain[k], self.chain[(k + 1) % m]]
        if self.needs_frames:
            ids += [nn + (k - 1) % n_edges, nn + k % n_edges]
        return np.column_stack(ids)

    def _points(self, x: np.ndarray, ids: np.ndarray) -> np.ndarray:
        """Stencil point coordinates (S, m, 3), mm."""
        return np.ascontiguousarray((self.B @ x)[ids])

    def _edge_data(self, vertex_edges: np.ndarray) -> tuple[np.ndarray, ...]:
        a, b = vertex_edges[:, 0], vertex_edges[:, 1]
        return (self.edge_held[a], self.edge_held[b], np.ascontiguousarray(self.rest_frames[a]),
                np.ascontiguousarray(self.rest_frames[b]))

    def _vertex_jets(self, x: np.ndarray, order: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Curvature vectors (S, 3) and bending and torsion energy jets of the vertices."""
        pr = self.props
        return vertex_terms(self._points(x, self.vertex_points), *self._edge_data(self.vertex_edges),
                            self.rest_kappa, 0.5 / self.voronoi, PAPER if pr.model == "paper" else STRIP,
                            float(pr.EI), float(pr.EI_strong), float(pr.GJ), self.needs_frames, order)

    # ------------------------------------------------------------------ energies
    def evaluate(self, x: np.ndarray, order: int = 2
                 ) -> tuple[dict[str, float], np.ndarray | None, sp.csr_matrix | None]:
        """Energies (N mm: 'bending', 'torsion', 'axial'), and for order >= 1 the gradient
        (3 nn,) N and for order 2 the tangent N/mm (None below the order that needs them)."""
        _, bending, torsion = self._vertex_jets(x, order)
        ids = self.edges[self.free_edges]
        axial = edge_terms(self._points(x, ids), self.rest_length[self.free_edges],
                           float(self.props.EA), order)
        energies = {"bending": float(bending[:, 0].sum()), "torsion": float(torsion[:, 0].sum()),
                    "axial": float(axial[:, 0].sum())}
        if order == 0:
            return energies, None, None
        terms = [StencilTerms(split(bending + torsion), self.vertex_points),
                 StencilTerms(split(axial), ids)]
        g, K = scatter(terms, self.n_points, order)
        g = self.B3.T @ g
        if K is not None:
            K = (self.B3.T @ K @ self.B3).tocsr()
        return energies, g, K

    # ------------------------------------------------------------------ film offset
    def normals(self, x: np.ndarray, nodes: np.ndarray, order: int = 2) -> tuple[Jets, np.ndarray]:
        """Strip normals at chain positions ``nodes`` (mean of the two edge normals, unit).

        Returns their values (S, 3), gradients (S, 3, 15) and Hessians (S, 3, 15, 15) in the
        stencil coordinates, and the stencil point ids (S, 5).
        """
        ids = self._vertex_points(nodes)
        n_edges = self.edges.shape[0]
        vertex_edges = np.column_stack([(nodes - 1) % n_edges, nodes % n_edges])
        jets = vertex_normals(self._points(x, ids), *self._edge_data(vertex_edges), order)
        return split(jets), ids

    # ------------------------------------------------------------------ output
    def section_forces(self, x: np.ndarray) -> dict[str, np.ndarray]:
        """Per edge: axial force (N), and the mean of its end vertices' bending moment and
        torsional moment (N mm)."""
        kappa = self._vertex_jets(x, 0)[0]
        pr = self.props
        if pr.model == "paper":
            dk = np.linalg.norm(kappa, axis=1) - np.linalg.norm(self.rest_kappa, axis=1)
            moment, torque = pr.EI * dk / self.voronoi, np.zeros(dk.size)
        else:
            dk = kappa - self.rest_kappa
            moment = np.hypot(pr.EI * dk[:, 1], pr.EI_strong * dk[:, 2]) / self.voronoi
            torque = pr.GJ * dk[:, 0] / self.voronoi
        n_edges = self.edges.shape[0]
        out = {}
        for name, v in (("bending_moment_N_mm", moment), ("torsion_moment_N_mm", torque)):
            acc = np.zeros(n_edges)
            np.add.at(acc, self.vertex_edges.ravel(), np.repeat(0.5 * v, 2))
            out[name] = acc
        length = np.linalg.norm(x[self.edges[:, 1]] - x[self.edges[:, 0]], axis=1)
        out["axial_force_N"] = pr.EA * (length - self.rest_length) / self.rest_length
        return out
