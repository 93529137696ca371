"""DR element: clustered cables, one tension T = EA/L0 (sum l_i - L0) over frictionless pulleys."""

from __future__ import annotations

import numpy as np
from numba import njit

from .links import tension
from .vec import add_to, get, norm, scale, sub


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
def energy(X, P):
    """Strain energy of all clusters, N mm."""
    e = 0.0
    for c in range(P.clu_ptr.shape[0] - 1):
        t = tension(P.clu_EA[c], P.clu_L0[c], _length(X, P, c), P.clu_tension_only[c])
        e += 0.5 * t * t * P.clu_L0[c] / P.clu_EA[c]
    return e


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
