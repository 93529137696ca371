"""DR element: clustered cables, one tension T = EA/L0 (sum l_i - L0) over frictionless pulleys."""

from __future__ import annotations

from typing import NamedTuple, Sequence

import numpy as np
from numba import njit

from results import CellBlock

from .checks import positive
from .errors import DRError
from .links import tension, tensions
from .vec import add_to, get, norm, scale, sub


class Fields(NamedTuple):
    """The clustered cables' arrays in :class:`dr.kernels.Packed`."""

    clu_seg: np.ndarray  # (s, 2) cable segments (node pairs), all clusters
    clu_ptr: np.ndarray  # (c+1,) into clu_nodes
    clu_nodes: np.ndarray  # chains, concatenated
    clu_EA: np.ndarray  # N
    clu_L0: np.ndarray  # mm, rest length of the whole cable
    clu_tension_only: np.ndarray  # bool
    clu_seg_cluster: np.ndarray  # (s,) cluster of each segment
    clu_work: np.ndarray  # (len(clu_nodes),) scratch: segment lengths of the current step


class Methods:
    """The :class:`dr.Model` method that adds clustered cables."""

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
        c = self.node_indices("cluster chain", chain, True)
        if c.size < 2:
            raise DRError("a cluster chain needs at least 2 nodes")
        if np.any(c[1:] == c[:-1]):
            raise DRError("cluster chain repeats a node in consecutive places")
        ea = positive("cluster EA (N)", EA)
        L = float(np.sum(self.rest_lengths("cluster", c[:-1], c[1:], None)))
        L0 = L if rest_length is None else positive("cluster rest_length (mm)", rest_length)
        self.stored[Fields].append((c, ea, L0, bool(tension_only)))
        return len(self.stored[Fields]) - 1


def scale_membrane(stored: list, factor: float) -> list:
    """The cables of ``stored`` with rest lengths times ``factor``."""
    return [(c, ea, L0 * factor, to) for c, ea, L0, to in stored]


def prestretch_membrane(stored: list, model, P: np.ndarray) -> list:
    """The cables of ``stored`` with rest lengths sum |P^-1 d| over their segments (d the flat
    x, y span, P the pre-stretch tensor (2, 2))."""
    ref = model.ref_positions()[:, :2]
    return [(c, ea, float(np.linalg.norm(np.linalg.solve(P, np.diff(ref[c], axis=0).T), axis=0).sum()), to)
            for c, ea, _, to in stored]


def pack(model, rest) -> Fields:
    """The clustered cables of ``model`` (:meth:`dr.Model.add_cluster`); ``rest`` is unused."""
    cl = model.stored[Fields]
    ptr = np.zeros(len(cl) + 1, dtype=np.int64)
    ptr[1:] = np.cumsum([c[0].size for c in cl])
    nodes = np.concatenate([c[0] for c in cl]) if cl else np.zeros(0, np.int64)
    seg = np.concatenate([np.stack([c[0][:-1], c[0][1:]], axis=1) for c in cl]) if cl else np.zeros((0, 2), np.int64)
    return Fields(
        clu_seg=seg.astype(np.int64),
        clu_ptr=ptr,
        clu_nodes=nodes.astype(np.int64),
        clu_EA=np.array([c[1] for c in cl], dtype=float),
        clu_L0=np.array([c[2] for c in cl], dtype=float),
        clu_tension_only=np.array([c[3] for c in cl], dtype=bool),
        clu_seg_cluster=np.repeat(np.arange(len(cl)), [c[0].size - 1 for c in cl]).astype(np.int64),
        clu_work=np.zeros(nodes.size),
    )


def forces(X: np.ndarray, P, moment: np.ndarray) -> dict[str, np.ndarray]:
    """The tension of each clustered cable at X, N (``moment`` is left alone)."""
    return {"cluster_tension": tensions(P.clu_EA, P.clu_L0, lengths(X, P), P.clu_tension_only)}


def cells(P, real: np.ndarray, forces: dict[str, np.ndarray]) -> dict[str, CellBlock]:
    """The VTK line block of the cables' segments, each with its cable's tension (N) and number.
    ``real`` maps a row of X to the real node it is drawn at."""
    if not P.clu_seg.size:
        return {}
    return {"membrane_clusters": CellBlock("line", real[P.clu_seg], {
        "tension_N": forces["cluster_tension"][P.clu_seg_cluster], "cluster_id": P.clu_seg_cluster.astype(float)})}


def stencils(P) -> np.ndarray:
    """The rows of X each clustered cable's energy depends on (c, longest chain; -1: none): its
    whole chain, since its tension follows the sum of its segments."""
    counts = np.diff(P.clu_ptr)
    out = np.full((counts.size, int(counts.max(initial=0))), -1, dtype=np.int64)
    cable = np.repeat(np.arange(counts.size), counts)
    out[cable, np.arange(cable.size) - P.clu_ptr[cable]] = P.clu_nodes
    return out


def edges(P) -> np.ndarray:
    """Node pairs (k, 2) of the cables' segments."""
    return P.clu_seg


def lengths(X: np.ndarray, P) -> np.ndarray:
    """Length of each clustered cable at positions X (n, 3) mm, the sum of its segments, mm."""
    seg = np.linalg.norm(X[P.clu_seg[:, 1]] - X[P.clu_seg[:, 0]], axis=1)
    return np.bincount(P.clu_seg_cluster, weights=seg, minlength=P.clu_L0.size)


@njit(cache=True, error_model="numpy")
def _length(X, P, c):
    """Current length of cluster c, with its segment lengths kept in P.clu_work."""
    L = 0.0
    for s in range(P.clu_ptr[c], P.clu_ptr[c + 1] - 1):
        li = norm(sub(get(X, P.clu_nodes[s + 1]), get(X, P.clu_nodes[s])))
        P.clu_work[s] = li
        L += li
    return L


@njit(cache=True, error_model="numpy", inline="always")
def gradient(X, P, G, D):
    """Add the clusters' energy gradient to G. Returns the largest cable tension, N."""
    fmax = 0.0
    for c in range(P.clu_ptr.shape[0] - 1):
        t = tension(P.clu_EA[c], P.clu_L0[c], _length(X, P, c), P.clu_tension_only[c])
        fmax = max(fmax, abs(t))
        if t == 0.0:
            continue
        for s in range(P.clu_ptr[c], P.clu_ptr[c + 1] - 1):
            i, j = P.clu_nodes[s], P.clu_nodes[s + 1]
            d = sub(get(X, j), get(X, i))
            f = t / P.clu_work[s]
            add_to(G, i, d, -f)
            add_to(G, j, d, f)
    return fmax


@njit(cache=True, error_model="numpy")
def strain_energy(X, P):
    """Strain energy (membrane, frame bending, frame torsion, frame axial) of all clusters, N mm:
    membrane only."""
    e = 0.0
    for c in range(P.clu_ptr.shape[0] - 1):
        t = tension(P.clu_EA[c], P.clu_L0[c], _length(X, P, c), P.clu_tension_only[c])
        e += 0.5 * t * t * P.clu_L0[c] / P.clu_EA[c]
    return e, 0.0, 0.0, 0.0


@njit(cache=True, error_model="numpy")
def stiffness(X, P, S, with_links):
    """Scalar bound per cable node: EA/L0 spread by how much each node changes the cable
    length, plus T/l of its segments. Scalar, because an inner node's stiffness hangs on the
    cable's kink there, which changes every step."""
    for c in range(P.clu_ptr.shape[0] - 1):
        lo, hi = P.clu_ptr[c], P.clu_ptr[c + 1]
        t = abs(tension(P.clu_EA[c], P.clu_L0[c], _length(X, P, c), P.clu_tension_only[c]))
        k_ax = P.clu_EA[c] / P.clu_L0[c]
        nseg = hi - lo - 1
        # |dL/dx_node| summed over the chain: 2 for a straight cable, more for a kinked one
        gsum = 0.0
        for s in range(lo, hi):
            gsum += _chain_turn(X, P.clu_nodes, lo, hi, s)
        for s in range(lo, hi):
            geo = 0.0
            if s > lo:
                geo += t / P.clu_work[s - 1]
            if s < hi - 1:
                geo += t / P.clu_work[s]
            # a slack cable still gets a little mass so that its nodes stay finite
            S[P.clu_nodes[s]] += k_ax * (_chain_turn(X, P.clu_nodes, lo, hi, s) * gsum + 0.05 * nseg) + geo


@njit(cache=True, error_model="numpy")
def _chain_turn(X, nodes, lo, hi, s):
    """|dL/dx| of chain node s: |e_in - e_out| (1 at the ends)."""
    if s == lo or s == hi - 1:
        return 1.0
    p, c, q = get(X, nodes[s - 1]), get(X, nodes[s]), get(X, nodes[s + 1])
    e1 = sub(c, p)
    e2 = sub(q, c)
    return norm(sub(scale(e1, 1.0 / norm(e1)), scale(e2, 1.0 / norm(e2))))
