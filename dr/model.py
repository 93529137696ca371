"""The low-level DR model: nodes, supports, clamps, links, clustered cables, beams, loads.

A cantilever of the frame strip, 80 mm in 20 segments, under a small tip load, against the
linear deflection P L^3 / (3 EI):

>>> import numpy as np, dr
>>> nodes = np.zeros((21, 3)); nodes[:, 0] = np.linspace(0.0, 80.0, 21)   # mm (rest geometry)
>>> m = dr.Model(nodes)
>>> m.clamp(0, tangent=(1, 0, 0))              # pin node 0 and fix the beam tangent there
>>> m.add_beam(range(21), EI=0.78, EA=1300.0)  # N mm^2, N
>>> m.add_load(20, (0.0, 0.0, -1e-5))          # N
>>> res = dr.relax(m, tol=1e-8)
>>> res.status, round(float(-res.x[20, 2]) / (1e-5 * 80.0**3 / (3 * 0.78)), 3)
('converged', 1.0)

``m.support([0, 1])`` pins nodes (or ``axes="z"``), ``m.add_link``/``m.add_cluster`` add bars
and cables over pulleys.

Rest lengths and rest curvatures default to the reference geometry ``nodes``; the start of the
relaxation can be a different geometry (``relax(m, x_start=...)``).
"""

from __future__ import annotations

from typing import Iterable, NamedTuple, Sequence

import numpy as np

from . import beams as beam_element
from .checks import positive, prestretch_tensor, unit
from .errors import DRError
from .elements import ELEMENTS
from .frames import node_frame
from .kernels import Packed, Virtual, place_virtual


class Rest(NamedTuple):
    """What an element's ``pack`` may need besides the model: the rest positions X (n_total, 3)
    mm, virtual nodes placed (clamp ghosts about the clamps' rest tangents), and the row of
    each clamp ghost by (beam number, end 0 or -1)."""

    X: np.ndarray
    ghost_id: dict


class Model(*(e.Methods for e in ELEMENTS if hasattr(e, "Methods"))):
    """A DR model built node by node (see the module docstring for an example).

    Supports, clamps, loads and offset nodes are its own; the methods that add elements
    (``add_link``, ``add_cluster``, ``add_beam``, ``add_triangles``, ``add_dielectric``,
    ``add_rod``) are each element module's ``Methods`` (:mod:`dr.elements`).

    Parameters
    ----------
    nodes
        (n, 3) reference node positions in mm: the stress-free geometry that defines default
        rest lengths and rest curvatures.
    """

    def __init__(self, nodes: np.ndarray | Sequence[Sequence[float]]) -> None:
        x = np.array(nodes, dtype=float)
        if x.ndim != 2 or x.shape[1] != 3 or x.shape[0] < 2:
            raise DRError("nodes must be an (n, 3) array of positions in mm with n >= 2")
        if not np.all(np.isfinite(x)):
            raise DRError("nodes must be finite numbers (mm)")
        self.nodes = x
        self.fixed = np.zeros(x.shape, dtype=bool)
        self.loads = np.zeros(x.shape)
        # what each element type's add method was given, by its Fields (read by its pack)
        self.stored: dict[type, list] = {e.Fields: [] for e in ELEMENTS}
        self.clamps: dict[int, tuple[np.ndarray, bool, np.ndarray]] = {}  # tangent, taped, rest tangent
        self._offsets: list[tuple[int, float]] = []
        self._offset_ref: list[np.ndarray] = []  # their reference positions, mm
        self.triangles: np.ndarray | None = None  # optional surface for VTK output

    # ------------------------------------------------------------------ helpers
    @property
    def beams(self) -> list[beam_element.Beam]:
        """The beams added so far (:meth:`add_beam`), in order."""
        return self.stored[beam_element.Fields]

    @property
    def n(self) -> int:
        """Number of real nodes."""
        return self.nodes.shape[0]

    @property
    def n_virtual(self) -> int:
        """Number of virtual nodes made so far (offsets)."""
        return len(self._offsets)

    def node_index(self, name: str, i: int, allow_virtual: bool = False) -> int:
        """``i`` as a node index (virtual nodes too if ``allow_virtual``); DRError naming the
        argument ``name`` otherwise."""
        limit = self.n + (self.n_virtual if allow_virtual else 0)
        try:
            k = int(i)
        except (TypeError, ValueError):
            raise DRError(f"{name} = {i!r} is not a node index") from None
        if not 0 <= k < limit:
            raise DRError(f"{name} = {k} is not a node of this model (0 .. {limit - 1})")
        return k

    def node_indices(self, name: str, idx: Iterable[int], allow_virtual: bool = False) -> np.ndarray:
        """``idx`` as a non-empty int64 array of node indices, as :meth:`node_index`."""
        arr = np.atleast_1d(np.asarray(list(idx) if not isinstance(idx, np.ndarray) else idx))
        if arr.size == 0:
            raise DRError(f"{name} is empty")
        if not np.issubdtype(arr.dtype, np.integer):
            raise DRError(f"{name} must hold node indices (integers)")
        limit = self.n + (self.n_virtual if allow_virtual else 0)
        bad = arr[(arr < 0) | (arr >= limit)]
        if bad.size:
            raise DRError(f"{name} holds {bad[0]}, not a node of this model (0 .. {limit - 1})")
        return arr.astype(np.int64)

    # ------------------------------------------------------------------ supports and loads
    def support(self, indices: int | Iterable[int], axes: str = "xyz") -> None:
        """Fix the given coordinates ('xyz' pins) of the nodes ``indices``."""
        idx = self.node_indices("support indices", np.atleast_1d(indices))
        if not axes or set(axes) - set("xyz"):
            raise DRError(f"support axes = {axes!r}: use a combination of 'x', 'y', 'z'")
        for a in axes:
            self.fixed[idx, "xyz".index(a)] = True

    def clamp(
        self,
        i: int,
        tangent: Sequence[float],
        taped: bool = False,
        rest_tangent: Sequence[float] | None = None,
    ) -> None:
        """Pin node ``i`` and fix the tangent of the beam that ends there.

        Second-order clamp (docs/elements.md): a moving ghost, the mirror image of the beam's next node
        across the plane through node i normal to ``tangent``, with the clamp triplet's moment
        at half weight. The beam's rest shape at the clamp has ``rest_tangent`` (default: the
        clamped tangent, i.e. the beam is clamped as built); a different rest tangent turns the
        end by a prescribed angle. ``taped`` also holds a strip's normal at +z there (the strip
        is taped flat), which a strip beam needs at a clamped end.
        """
        k = self.node_index("clamp node", i)
        t = unit("clamp tangent", tangent)
        rest = t if rest_tangent is None else unit("clamp rest_tangent", rest_tangent)
        self.clamps[k] = (t, bool(taped), rest)
        self.fixed[k] = True

    def add_load(self, i: int, force: Sequence[float]) -> None:
        """Add a nodal force (fx, fy, fz) in N to node ``i``."""
        k = self.node_index("load node", i)
        f = np.asarray(force, dtype=float).reshape(-1)
        if f.shape != (3,) or not np.all(np.isfinite(f)):
            raise DRError("load force must be a finite 3-vector (N)")
        self.loads[k] += f

    # ------------------------------------------------------------------ elements
    def rest_lengths(self, name: str, i: np.ndarray, j: np.ndarray, rest: object) -> np.ndarray:
        """Rest lengths (mm) of elements between nodes i and j: ``rest`` (a number or one per
        element) or, if None, their reference distances; DRError naming ``name`` for one <= 0."""
        x = self.ref_positions()
        L = np.linalg.norm(x[j] - x[i], axis=1)
        if rest is None:
            L0 = L
        else:
            L0 = np.broadcast_to(np.asarray(rest, dtype=float), L.shape).copy()
        bad = np.flatnonzero(~np.isfinite(L0) | (L0 <= 0))
        if bad.size:
            k = bad[0]
            what = "the nodes coincide" if rest is None else f"rest length {L0[k]!r}"
            raise DRError(
                f"{name} between nodes {i[k]} and {j[k]}: {what}; rest lengths must be positive (mm), "
                "a zero-length element has no direction: move the nodes apart"
            )
        return L0

    def ref_positions(self) -> np.ndarray:
        """Reference positions of real and virtual (offset) nodes."""
        return np.vstack([self.nodes, *self._offset_ref])

    def scale_membrane_rest_lengths(self, factor: float) -> None:
        """Multiply the rest lengths of clusters, membrane links and triangles by ``factor``
        (> 0): how a pre-stretch is changed on a built model (lambda_old / lambda_new)."""
        f = positive("rest-length factor", factor)
        for e in ELEMENTS:
            if hasattr(e, "scale_membrane"):
                self.stored[e.Fields] = e.scale_membrane(self.stored[e.Fields], f)

    def set_membrane_prestretch(self, prestretch: np.ndarray) -> None:
        """Give clusters, membrane links and triangles the rest state of their flat reference
        mapped by P^-1: ``prestretch`` is the tensor P (2, 2) in the nodes' x, y
        (:mod:`scenes.prestretch`; a cable or link of flat span d rests at |P^-1 d|)."""
        P = prestretch_tensor(prestretch)
        for e in ELEMENTS:
            if hasattr(e, "prestretch_membrane"):
                self.stored[e.Fields] = e.prestretch_membrane(self.stored[e.Fields], self, P)

    def offset_node(self, i: int, distance: float) -> int:
        """A virtual node at ``distance`` mm along the strip normal from frame node ``i``.

        Elements attached to it act off the beam centreline (a film bonded on one face of the
        strip). Node i must be an inner node of a beam with an orientation, or a taped clamp.
        Returns the virtual node's index for add_link / add_cluster.
        """
        k = self.node_index("offset node", i)
        d = float(distance)
        if not np.isfinite(d):
            raise DRError("offset distance must be a finite number (mm)")
        geo = self._frame_geometry(k)
        xl = np.where(geo[:, None] >= 0, self.ref_positions()[np.maximum(geo, 0)], 0.0)
        nu = np.array(node_frame(xl, geo[3] < 0, geo[4] < 0)[4])
        self._offsets.append((k, d))
        self._offset_ref.append(self.nodes[k] + d * nu)
        return self.n + self.n_virtual - 1

    # ------------------------------------------------------------------ packing
    def _ghosts(self) -> list[tuple[int, int, np.ndarray, int]]:
        """(beam number, end (0 or -1), tangent, neighbour) for every clamped beam end."""
        out = []
        for b, beam in enumerate(self.beams):
            if beam.closed:
                continue
            for end, nb in ((0, 1), (-1, -2)):
                node = int(beam.chain[end])
                if node in self.clamps:
                    out.append((b, end, self.clamps[node][0], int(beam.chain[nb])))
        return out

    def _frame_geometry(self, node: int) -> np.ndarray:
        """(prev, node, next, m1, m2) of ``node`` on an oriented beam (ghost ids unresolved: -2)."""
        for beam in self.beams:
            if beam.orientation is None:
                continue
            pos = np.flatnonzero(beam.chain == node)
            if pos.size == 0:
                continue
            p = int(pos[0])
            c, o, m = beam.chain, beam.orientation, beam.chain.size
            if beam.closed:
                return np.array([c[p - 1], node, c[(p + 1) % m], o[p - 1], o[p]])
            if 0 < p < m - 1:
                return np.array([c[p - 1], node, c[p + 1], o[p - 1], o[p]])
            if node in self.clamps and self.clamps[node][1]:
                # taped clamp: normal +z; neighbour slots hold a real node, unused for nu = +z
                nb = c[1] if p == 0 else c[-2]
                return np.array([nb, node, nb, -1, -1])
            raise DRError(f"node {node} is a free end of a beam: it has no strip normal; offsets need an inner node or a taped clamp")
        raise DRError(f"node {node} is on no beam with an orientation: give add_beam(..., orientation=...) first")

    def pack(self) -> Packed:
        """The arrays the compiled kernels take: the virtual nodes', then each element type's
        (its module's ``pack``, in the order of dr.elements)."""
        n, n_off = self.n, self.n_virtual
        ghosts = self._ghosts()
        virtual = Virtual(
            n=n,
            ghost_src=np.array([g[3] for g in ghosts], dtype=np.int64),
            ghost_clamp=np.array([int(self.beams[g[0]].chain[g[1]]) for g in ghosts], dtype=np.int64),
            ghost_t=np.array([g[2] for g in ghosts], dtype=float).reshape(-1, 3),
            off_geo=np.array([self._frame_geometry(k) for k, _ in self._offsets], dtype=np.int64).reshape(-1, 5),
            off_d=np.array([d for _, d in self._offsets], dtype=float),
        )
        # rest curvatures, lengths and strip rest measures come from the reference geometry, with
        # the clamp ghosts mirrored about the clamps' rest tangents
        X = np.zeros((n + n_off + len(ghosts), 3))
        X[:n] = self.nodes
        rest_t = np.array([self.clamps[int(self.beams[g[0]].chain[g[1]])][2] for g in ghosts]).reshape(-1, 3)
        place_virtual(X, virtual._replace(ghost_t=rest_t))
        rest = Rest(X=X, ghost_id={(b, end): n + n_off + g for g, (b, end, _, _) in enumerate(ghosts)})
        parts = [e.pack(self, rest) for e in ELEMENTS]
        return Packed(*virtual, *(a for part in parts for a in part))
