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

from dataclasses import dataclass
from typing import Iterable, NamedTuple, Sequence

import numpy as np

from .errors import DRError
from . import dielectric as diel_element
from . import triangles as tri_element
from .elements import ELEMENTS
from .frames import node_frame
from .kernels import Packed, Virtual, place_virtual


def _positive(name: str, value: float) -> float:
    v = float(value)
    if not np.isfinite(v) or v <= 0:
        raise DRError(f"{name} = {value!r} must be a positive number")
    return v


def _unit(name: str, v: Sequence[float]) -> np.ndarray:
    a = np.asarray(v, dtype=float).reshape(-1)
    if a.shape != (3,) or not np.all(np.isfinite(a)) or np.linalg.norm(a) == 0:
        raise DRError(f"{name} must be a non-zero 3-vector")
    return a / np.linalg.norm(a)


class Rest(NamedTuple):
    """What an element's ``pack`` may need besides the model: the rest positions X (n_total, 3)
    mm, virtual nodes placed (clamp ghosts about the clamps' rest tangents), and the row of
    each clamp ghost by (beam number, end 0 or -1)."""

    X: np.ndarray
    ghost_id: dict


@dataclass
class _Rod:
    chain: np.ndarray
    bond: np.ndarray | None
    EI: float
    EI_strong: float | None
    GJ: float | None
    closed: bool


@dataclass
class _Beam:
    chain: np.ndarray
    EI: float
    EA: float | None
    EI_strong: float | None
    GJ: float | None
    orientation: np.ndarray | None
    closed: bool


class Model:
    """A DR model built node by node (see the module docstring for an example).

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
        self._links: list[tuple[np.ndarray, ...]] = []
        self._clusters: list[tuple[np.ndarray, float, float, bool]] = []
        self._beams: list[_Beam] = []
        self._clamps: dict[int, tuple[np.ndarray, bool, np.ndarray]] = {}
        self._offsets: list[tuple[int, float]] = []
        self._offset_ref: list[np.ndarray] = []  # their reference positions, mm
        self._triangles: list[tuple[np.ndarray, float, float, float, bool, int, float]] = []
        self._rods: list[_Rod] = []
        self._dielectric: tuple[np.ndarray, np.ndarray] | None = None  # triangles, flat areas
        self.dielectric_coefficient = 0.0  # c (N/mm), see add_dielectric
        self.triangles: np.ndarray | None = None  # optional surface for VTK output

    # ------------------------------------------------------------------ helpers
    @property
    def n(self) -> int:
        """Number of real nodes."""
        return self.nodes.shape[0]

    @property
    def n_virtual(self) -> int:
        """Number of virtual nodes made so far (offsets)."""
        return len(self._offsets)

    def _index(self, name: str, i: int, allow_virtual: bool = False) -> int:
        limit = self.n + (self.n_virtual if allow_virtual else 0)
        try:
            k = int(i)
        except (TypeError, ValueError):
            raise DRError(f"{name} = {i!r} is not a node index") from None
        if not 0 <= k < limit:
            raise DRError(f"{name} = {k} is not a node of this model (0 .. {limit - 1})")
        return k

    def _indices(self, name: str, idx: Iterable[int], allow_virtual: bool = False) -> np.ndarray:
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
        idx = self._indices("support indices", np.atleast_1d(indices))
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
        k = self._index("clamp node", i)
        t = _unit("clamp tangent", tangent)
        rest = t if rest_tangent is None else _unit("clamp rest_tangent", rest_tangent)
        self._clamps[k] = (t, bool(taped), rest)
        self.fixed[k] = True

    def add_load(self, i: int, force: Sequence[float]) -> None:
        """Add a nodal force (fx, fy, fz) in N to node ``i``."""
        k = self._index("load node", i)
        f = np.asarray(force, dtype=float).reshape(-1)
        if f.shape != (3,) or not np.all(np.isfinite(f)):
            raise DRError("load force must be a finite 3-vector (N)")
        self.loads[k] += f

    # ------------------------------------------------------------------ elements
    def _rest_lengths(self, name: str, i: np.ndarray, j: np.ndarray, rest: object) -> np.ndarray:
        x = self._ref_positions()
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

    def _ref_positions(self) -> np.ndarray:
        """Reference positions of real and virtual (offset) nodes."""
        return np.vstack([self.nodes, *self._offset_ref])

    def add_link(
        self,
        i: int | Sequence[int],
        j: int | Sequence[int],
        EA: float | Sequence[float],
        rest_length: float | Sequence[float] | None = None,
        tension_only: bool = False,
        role: str = "membrane",
    ) -> None:
        """Add links (bars or cables) between nodes i and j: T = EA/L0 (L - L0).

        ``role`` ('membrane' or 'frame') decides where their energy is counted.
        """
        ii = self._indices("link i", np.atleast_1d(i), True)
        jj = self._indices("link j", np.atleast_1d(j), True)
        if ii.shape != jj.shape:
            raise DRError("link i and j must have the same length")
        if np.any(ii == jj):
            raise DRError("a link joins a node to itself; give two different nodes")
        ea = np.broadcast_to(np.asarray(EA, dtype=float), ii.shape).copy()
        if np.any(~np.isfinite(ea)) or np.any(ea <= 0):
            raise DRError("link EA must be positive (N)")
        if role not in ("membrane", "frame"):
            raise DRError(f"link role = {role!r}: use 'membrane' or 'frame'")
        L0 = self._rest_lengths("link", ii, jj, rest_length)
        self._links.append((ii, jj, ea, L0, np.full(ii.shape, tension_only), np.full(ii.shape, role == "frame")))

    def add_cluster(
        self,
        chain: Sequence[int],
        EA: float,
        rest_length: float | None = None,
        tension_only: bool = True,
    ) -> int:
        """Add a clustered cable over ``chain`` (frictionless pulleys at the inner nodes).

        One tension for the whole chain: T = EA/L0 (sum l_i - L0). Returns its cluster number.
        """
        c = self._indices("cluster chain", chain, True)
        if c.size < 2:
            raise DRError("a cluster chain needs at least 2 nodes")
        if np.any(c[1:] == c[:-1]):
            raise DRError("cluster chain repeats a node in consecutive places")
        ea = _positive("cluster EA (N)", EA)
        L = float(np.sum(self._rest_lengths("cluster", c[:-1], c[1:], None)))
        L0 = L if rest_length is None else _positive("cluster rest_length (mm)", rest_length)
        self._clusters.append((c, ea, L0, bool(tension_only)))
        return len(self._clusters) - 1

    def add_beam(
        self,
        chain: Sequence[int],
        EI: float,
        EA: float | None = None,
        *,
        EI_strong: float | None = None,
        GJ: float | None = None,
        orientation: Sequence[int] | None = None,
        closed: bool = False,
    ) -> None:
        """Add a beam along ``chain``; its rest shape is the reference geometry.

        Without ``EI_strong`` it is the isotropic spline beam (Adriaenssens & Barnes):
        M = EI (|kappa| - kappa_0) per node triplet. Having no material frame it cannot tell
        which way its rest curvature points, so where it is naturally curved a tilt of the
        curvature plane costs nothing at first order (energy ~ tilt^4): give ``EI_strong``
        (= EI for an isotropic section), ``GJ`` and ``orientation`` for a rod that can. With ``EI_strong`` and ``GJ`` it is a strip:
        weak-axis EI, strong-axis EI_strong, torsion GJ, its plane set by ``orientation``
        (one node per edge, e.g. the membrane node next to the edge); the forces are the exact
        gradient of one energy, so the orientation nodes get their reactions. ``EA`` adds an
        axial link per segment (role 'frame'). Units: N mm^2, N.
        """
        c = self._indices("beam chain", chain)
        if c.size < 3 and not closed:
            raise DRError("a beam chain needs at least 3 nodes")
        if len(set(c.tolist())) != c.size:
            raise DRError("beam chain visits a node twice; for a loop give each node once and closed=True")
        ei = _positive("beam EI (N mm^2)", EI)
        n_edges = c.size if closed else c.size - 1
        nxt = np.roll(c, -1)[:n_edges]
        self._rest_lengths("beam edge", c[:n_edges], nxt, None)
        ends = (np.roll(c, 1), np.roll(c, -1)) if closed else (c[:-2], c[2:])
        x = self._ref_positions()
        folded = np.flatnonzero(np.linalg.norm(x[ends[1]] - x[ends[0]], axis=1) == 0.0)
        if folded.size:
            k = folded[0]
            raise DRError(f"beam chain folds back on itself: nodes {ends[0][k]} and {ends[1][k]} on either side of "
                          "a node coincide (no curvature is defined there); move them apart")
        orient = None
        if orientation is not None:
            orient = self._indices("beam orientation", orientation, True)
            if orient.size != n_edges:
                raise DRError(f"beam orientation needs one node per edge ({n_edges}), got {orient.size}")
        if EI_strong is not None:
            if GJ is None or orient is None:
                raise DRError("a strip beam (EI_strong given) also needs GJ and orientation")
            _positive("beam EI_strong (N mm^2)", EI_strong)
            _positive("beam GJ (N mm^2)", GJ)
        ea = None if EA is None else _positive("beam EA (N)", EA)
        self._beams.append(_Beam(c, ei, ea, EI_strong, GJ, orient, closed))
        if ea is not None:
            self.add_link(c[:n_edges], nxt, ea, role="frame")

    def add_triangles(self, triangles: np.ndarray, *, E: float, thickness: float, prestretch: float,
                      law: str = "linear", tension_only: bool = True, gent_jm: float = np.inf) -> None:
        """Add constant-strain membrane triangles (:mod:`dr.triangles`) over node triples.

        The reference triangles lie in the plane z = const of the nodes (the flat film); the
        rest state is that shrunk by 1 / ``prestretch``. ``law`` is 'linear' (the link-net
        law, lattice directions at 0, 60, 120 deg from the x axis), 'neo-hookean' or 'gent'
        (with ``gent_jm``, Gent's Jm > 0). Units: E in MPa, the mounted thickness in mm.
        """
        t = np.asarray(triangles)
        if t.ndim != 2 or t.shape[1] != 3 or t.shape[0] == 0:
            raise DRError("triangles must be a non-empty (t, 3) array of node indices")
        t = self._indices("triangle nodes", t.ravel()).reshape(-1, 3)
        if law not in tri_element.LAWS:
            raise DRError(f"membrane law = {law!r} is not one of {', '.join(map(repr, tri_element.LAWS))}")
        flat = self.nodes[t]
        if np.ptp(flat[:, :, 2]) > 1e-9 * max(np.ptp(self.nodes[:, :2]), 1e-300):
            raise DRError("membrane triangles need a flat reference: their nodes must share one z (mm)")
        _, area = tri_element.shape_gradients(flat[:, :, :2])
        if np.any(area <= 1e-12 * np.ptp(self.nodes[:, :2]) ** 2):
            raise DRError("a membrane triangle has no area: its three nodes lie on one line")
        self._triangles.append((t, _positive("membrane E (MPa)", E), _positive("membrane thickness (mm)", thickness),
                                _positive("pre-stretch", prestretch), bool(tension_only), tri_element.LAWS[law],
                                _positive("Gent Jm", gent_jm) if law == "gent" else np.inf))

    def add_dielectric(self, triangles: np.ndarray, coefficient: float) -> None:
        """Make the film over node triples ``triangles`` an ideal dielectric (:mod:`dr.dielectric`).

        Its energy is -c a^2 / A per triangle (current area a, flat area A in the reference),
        c = ``coefficient`` (N/mm, >= 0) from :func:`scenes.electric.dielectric_coefficient`;
        change the voltage by setting ``dielectric_coefficient``. The reference must be flat.
        """
        t = np.asarray(triangles)
        if t.ndim != 2 or t.shape[1] != 3 or t.shape[0] == 0:
            raise DRError("dielectric triangles must be a non-empty (t, 3) array of node indices")
        t = self._indices("dielectric triangle nodes", t.ravel()).reshape(-1, 3)
        c = float(coefficient)
        if not np.isfinite(c) or c < 0:
            raise DRError(f"dielectric coefficient = {coefficient!r} must be a number >= 0 (N/mm)")
        _, area = tri_element.shape_gradients(self.nodes[t][:, :, :2])
        if np.any(area <= 1e-12 * np.ptp(self.nodes[:, :2]) ** 2):
            raise DRError("a dielectric triangle has no area: its three nodes lie on one line")
        self._dielectric = (t, area)
        self.dielectric_coefficient = c

    def dielectric_energy(self, x: np.ndarray) -> tuple[float, float]:
        """(electrostatic energy N mm, current film area mm^2) at positions x (n, 3); (0, 0)
        without a dielectric."""
        if self._dielectric is None:
            return 0.0, 0.0
        return diel_element.energies(x, *self._dielectric, self.dielectric_coefficient)

    def add_rod(self, chain: Sequence[int], *, EA: float, EI: float, EI_strong: float | None = None,
                GJ: float | None = None, bond: Sequence[int] | None = None, closed: bool = False) -> None:
        """Add the discrete rod with bond points (:mod:`dr.rod`, the FEM reference's frame).

        With ``EI_strong`` and ``GJ`` it is the strip (weak-axis EI, strong-axis, torsion; its
        plane set by ``bond``, one bond node per chain node); otherwise the isotropic rod.
        Edges whose two ends are supported on all axes keep their flat frame. ``EA`` adds an
        axial link per edge (role 'frame'). Units: N mm^2, N.
        """
        c = self._indices("rod chain", chain)
        if c.size < 3:
            raise DRError("a rod chain needs at least 3 nodes")
        b = None
        if EI_strong is not None:
            if GJ is None or bond is None:
                raise DRError("a strip rod (EI_strong given) also needs GJ and bond nodes")
            b = self._indices("rod bond", bond)
            if b.size != c.size:
                raise DRError(f"rod bond needs one node per chain node ({c.size}), got {b.size}")
            _positive("rod EI_strong (N mm^2)", EI_strong)
            _positive("rod GJ (N mm^2)", GJ)
        self._rods.append(_Rod(c, b, _positive("rod EI (N mm^2)", EI), EI_strong, GJ, bool(closed)))
        n_edges = c.size if closed else c.size - 1
        self.add_link(c[:n_edges], np.roll(c, -1)[:n_edges], _positive("rod EA (N)", EA), role="frame")

    def scale_membrane_rest_lengths(self, factor: float) -> None:
        """Multiply the rest lengths of clusters, membrane links and triangles by ``factor``
        (> 0): how a pre-stretch is changed on a built model (lambda_old / lambda_new)."""
        f = _positive("rest-length factor", factor)
        self._triangles = [(t, E, h, lam / f, to, law, jm) for t, E, h, lam, to, law, jm in self._triangles]
        self._clusters = [(c, ea, L0 * f, to) for c, ea, L0, to in self._clusters]
        self._links = [(i, j, ea, np.where(frame, L0, L0 * f), to, frame) for i, j, ea, L0, to, frame in self._links]

    def offset_node(self, i: int, distance: float) -> int:
        """A virtual node at ``distance`` mm along the strip normal from frame node ``i``.

        Elements attached to it act off the beam centreline (a film bonded on one face of the
        strip). Node i must be an inner node of a beam with an orientation, or a taped clamp.
        Returns the virtual node's index for add_link / add_cluster.
        """
        k = self._index("offset node", i)
        d = float(distance)
        if not np.isfinite(d):
            raise DRError("offset distance must be a finite number (mm)")
        geo = self._frame_geometry(k)
        xl = np.where(geo[:, None] >= 0, self._ref_positions()[np.maximum(geo, 0)], 0.0)
        nu = np.array(node_frame(xl, geo[3] < 0, geo[4] < 0)[4])
        self._offsets.append((k, d))
        self._offset_ref.append(self.nodes[k] + d * nu)
        return self.n + self.n_virtual - 1

    # ------------------------------------------------------------------ packing
    def _ghosts(self) -> list[tuple[int, int, np.ndarray, int]]:
        """(beam number, end (0 or -1), tangent, neighbour) for every clamped beam end."""
        out = []
        for b, beam in enumerate(self._beams):
            if beam.closed:
                continue
            for end, nb in ((0, 1), (-1, -2)):
                node = int(beam.chain[end])
                if node in self._clamps:
                    out.append((b, end, self._clamps[node][0], int(beam.chain[nb])))
        return out

    def _frame_geometry(self, node: int) -> np.ndarray:
        """(prev, node, next, m1, m2) of ``node`` on an oriented beam (ghost ids unresolved: -2)."""
        for beam in self._beams:
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
            if node in self._clamps and self._clamps[node][1]:
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
            ghost_clamp=np.array([int(self._beams[g[0]].chain[g[1]]) for g in ghosts], dtype=np.int64),
            ghost_t=np.array([g[2] for g in ghosts], dtype=float).reshape(-1, 3),
            off_geo=np.array([self._frame_geometry(k) for k, _ in self._offsets], dtype=np.int64).reshape(-1, 5),
            off_d=np.array([d for _, d in self._offsets], dtype=float),
        )
        # rest curvatures, lengths and strip rest measures come from the reference geometry, with
        # the clamp ghosts mirrored about the clamps' rest tangents
        X = np.zeros((n + n_off + len(ghosts), 3))
        X[:n] = self.nodes
        rest_t = np.array([self._clamps[int(self._beams[g[0]].chain[g[1]])][2] for g in ghosts]).reshape(-1, 3)
        place_virtual(X, virtual._replace(ghost_t=rest_t))
        rest = Rest(X=X, ghost_id={(b, end): n + n_off + g for g, (b, end, _, _) in enumerate(ghosts)})
        parts = [e.pack(self, rest) for e in ELEMENTS]
        return Packed(*virtual, *(a for part in parts for a in part))
