"""The stiffness matrix of a DR model, assembled from its exact gradient.

K = d2E/dx2 is never written out element by element: it is the central difference of the
gradient (:func:`dr.kernels.gradient`), as the matrix-free products of :mod:`dr.stability` are.
Assembling it costs far fewer gradients than a Lanczos search needs products: nodes that no
element couples to a common node cannot share a row of K, so one difference moves all of them
at once and each of its rows is read off for the one node of the group that touches it (a
distance-2 colouring of the node graph, as for sparse Jacobians). Each element type names the
rows of X its energy depends on (``stencils`` of each module of dr.elements); virtual rows
count as the real nodes they are placed from.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp

from .elements import ELEMENTS
from .kernels import Packed, gradient


class Pattern(NamedTuple):
    """Which nodes the stiffness couples, and the node groups one difference moves together."""

    pairs: np.ndarray  # (p, 2) node pairs (i, j) that share an element (both orders, i == j too)
    colour: np.ndarray  # (n,) group of each node; -1 for a node with no free DOF


def _real_rows(P: Packed) -> sp.csr_matrix:
    """(n_total, n) 0/1: the real nodes each row of X is placed from (itself for a real node)."""
    n, n_total = P.n, P.n_total
    rows = sp.lil_matrix((n_total, n))
    rows[np.arange(n), np.arange(n)] = 1.0
    base = n + P.off_geo.shape[0]
    for k in range(P.ghost_src.shape[0]):  # ghosts first, as dr.kernels.place_virtual places them
        rows[base + k] = rows[int(P.ghost_src[k])] + rows[int(P.ghost_clamp[k])]
    for k in range(P.off_geo.shape[0]):
        rows[n + k] = sum((rows[int(r)] for r in P.off_geo[k] if r >= 0), sp.lil_matrix((1, n)))
    return (rows.tocsr() != 0).astype(float)


def pattern(P: Packed, free_nodes: np.ndarray) -> Pattern:
    """The node graph of ``P``'s elements and a greedy distance-2 colouring of its nodes with a
    free DOF (``free_nodes``, (n,) bool): two nodes share a group only if no node shares an
    element with both."""
    n = P.n
    real = _real_rows(P)
    blocks = []
    for element in ELEMENTS:
        stencil = np.asarray(element.stencils(P), dtype=np.int64)
        if stencil.size == 0:
            continue
        e, k = np.nonzero(stencil >= 0)
        incidence = sp.csr_matrix((np.ones(e.size), (e, stencil[e, k])), shape=(stencil.shape[0], P.n_total))
        blocks.append(incidence @ real)
    element_nodes = sp.vstack(blocks).tocsr() if blocks else sp.csr_matrix((0, n))
    coupled = ((element_nodes.T @ element_nodes) + sp.identity(n)).tocsr()
    coupled.data[:] = 1.0
    moved = sp.diags(free_nodes.astype(float))
    conflict = (coupled @ moved @ coupled.T @ moved).tocsr()  # free nodes two steps apart
    colour = np.full(n, -1, dtype=np.int64)
    for j in np.flatnonzero(free_nodes):
        taken = colour[conflict.indices[conflict.indptr[j]:conflict.indptr[j + 1]]]
        used = np.zeros(taken.size + 2, bool)
        used[taken[(taken >= 0) & (taken < used.size)]] = True
        colour[j] = int(np.argmin(used))
    i, j = coupled.nonzero()
    return Pattern(np.stack([i, j], axis=1), colour)


def stiffness_matrix(P: Packed, x: np.ndarray, free: np.ndarray, pat: Pattern, step: float) -> tuple[sp.csr_matrix, int]:
    """K (3n, 3n) N/mm at the real positions ``x`` (n, 3) mm on the DOFs ``free`` ((n, 3)
    bool; rows and columns of held DOFs zero), symmetrised, by central differences moving each
    node by ``step`` mm; and the number of gradient pairs it took."""
    n = P.n
    X = np.zeros((P.n_total, 3))
    G, no_blocks = np.zeros_like(X), np.zeros((0, 6))
    groups = int(pat.colour.max(initial=-1)) + 1
    i, j = pat.pairs[:, 0], pat.pairs[:, 1]
    keep = pat.colour[j] >= 0
    i, j = i[keep], j[keep]
    rows, cols, values = [], [], []
    pairs = 0
    for c in range(groups):
        in_group = pat.colour[j] == c
        gi, gj = i[in_group], j[in_group]
        for axis in range(3):
            d = np.zeros((n, 3))
            d[pat.colour == c, axis] = 1.0
            d *= free
            if not d.any():
                continue
            pairs += 1
            out = []
            for sign in (1.0, -1.0):
                X[:n] = x + sign * step * d
                gradient(X, P, G, no_blocks)
                out.append(G[:n].copy())
            column = (out[0] - out[1]) / (2.0 * step)  # (n, 3): rows of K for the group's columns
            for r in range(3):
                rows.append(3 * gi + r)
                cols.append(3 * gj + axis)
                values.append(column[gi, r])
    K = sp.csr_matrix((np.concatenate(values or [np.zeros(0)]),
                       (np.concatenate(rows or [np.zeros(0, int)]), np.concatenate(cols or [np.zeros(0, int)]))),
                      shape=(3 * n, 3 * n))
    mask = sp.diags(free.reshape(-1).astype(float))
    return (mask @ (0.5 * (K + K.T)) @ mask).tocsr(), pairs
