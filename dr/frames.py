"""Strip geometry at a frame node: edge normals from the film point beside each edge.

A frame node j is described by five indices (prev, j, next, m1, m2): its two neighbours along
the frame and, for the edges (prev, j) and (j, next), a point that fixes the strip plane (a film
node or bond point). Edge normal n = unit(d x w), d the edge vector, w from the edge start to
that point. m < 0 marks an edge whose normal is fixed to +z (a taped clamp). Used by the strip
element and by offset nodes (a film bonded on one face of the strip).
"""

from __future__ import annotations

from numba import njit

from .vec import add, add_to, cross, get, norm, scale, sub, unit_vjp

Z_AXIS = (0.0, 0.0, 1.0)
Z0 = (0.0, 0.0, 0.0)


@njit(cache=True, error_model="numpy")
def edge_normal(p0, p1, m, fixed):
    """Strip normal of an edge: unit(d x w); +z if fixed. Returns (n, |d x w|)."""
    if fixed:
        return Z_AXIS, 1.0
    c = cross(sub(p1, p0), sub(m, p0))
    lc = norm(c)
    return scale(c, 1.0 / lc), lc


@njit(cache=True, error_model="numpy")
def node_frame(xl, fixed1, fixed2):
    """Edge normals n1, n2 and node normal nu of a frame node from its local rows.

    xl rows: prev, j, next, m1, m2. A taped clamp (either edge fixed) has nu = +z.
    Returns n1, |c1|, n2, |c2|, nu, |n1 + n2| (0 when nu is fixed).
    """
    p, j, q = get(xl, 0), get(xl, 1), get(xl, 2)
    n1, l1 = edge_normal(p, j, get(xl, 3), fixed1)
    n2, l2 = edge_normal(j, q, get(xl, 4), fixed2)
    if fixed1 or fixed2:
        return n1, l1, n2, l2, Z_AXIS, 0.0
    s = add(n1, n2)
    ls = norm(s)
    return n1, l1, n2, l2, scale(s, 1.0 / ls), ls


@njit(cache=True, error_model="numpy")
def node_frame_vjp(xl, fixed1, fixed2, n1, l1, n2, l2, nu, ls, g_n1, g_n2, g_nu, gl):
    """Pull gradients on (n1, n2, nu) back onto the local rows gl (5, 3)."""
    if not (fixed1 or fixed2):
        g_s = unit_vjp(nu, ls, g_nu)
        g_n1 = add(g_n1, g_s)
        g_n2 = add(g_n2, g_s)
    for e in range(2):
        if (fixed1 if e == 0 else fixed2):
            continue
        a, b, m = (0, 1, 3) if e == 0 else (1, 2, 4)
        n, lc, g = (n1, l1, g_n1) if e == 0 else (n2, l2, g_n2)
        p0 = get(xl, a)
        d = sub(get(xl, b), p0)
        w = sub(get(xl, m), p0)
        g_c = unit_vjp(n, lc, g)
        g_d = cross(w, g_c)
        g_w = cross(g_c, d)
        add_to(gl, b, g_d, 1.0)
        add_to(gl, m, g_w, 1.0)
        add_to(gl, a, add(g_d, g_w), -1.0)


@njit(cache=True, error_model="numpy")
def gather(X, idx, xl):
    """Local rows (5, 3) of a frame node; rows of fixed-normal membrane nodes are zero."""
    for r in range(5):
        k = idx[r]
        for c in range(3):
            xl[r, c] = X[k, c] if k >= 0 else 0.0


@njit(cache=True, error_model="numpy")
def scatter(G, idx, gl, factor):
    for r in range(5):
        k = idx[r]
        if k >= 0:
            for c in range(3):
                G[k, c] += factor * gl[r, c]
