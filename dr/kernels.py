"""Compiled element kernels: energy gradients (forces), energies and stiffness for the masses.

Everything acts on an extended position array X = [real nodes; virtual nodes]. Virtual nodes
are positions derived from real ones:

- ghosts (moving clamp ghosts): the mirror image of a beam's second node across the plane
  through the clamped node normal to the clamped tangent (second-order clamp, DESIGN.md);
- offsets: a frame node moved by a signed distance along the strip normal, where the film is
  bonded on one face of the strip (the membrane then acts t/2 off the centreline);
- bond points: a fixed convex combination of three real nodes (a film point inside a membrane
  triangle), which sets a strip edge's plane at the bond lever whatever the mesh.

Rows of X: real nodes (n), bond points, offsets, ghosts.

Kernels accumulate the energy gradient G = dE/dX; the residual is R = loads - G after the
virtual-node gradients are pulled back onto the real nodes (chain rule), so every node that a
virtual node or a strip orientation depends on gets its reaction.

Frame geometry of a frame node j is described by five indices (prev, j, next, m1, m2): its two
neighbours along the frame and, for the edges (prev, j) and (j, next), a membrane node that
fixes the strip plane. Edge normal n = unit(d x w), d the edge vector, w from the edge start to
the membrane node. m < 0 marks an edge whose normal is fixed to +z (a taped clamp).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from . import rod as rod_element
from .triangles import triangle_gradient, triangle_local, triangle_stiffness
from .vec import add, add_to, axpy, cross, dot, get, norm, scale, sub, unit_vjp

Z_AXIS = (0.0, 0.0, 1.0)
Z0 = (0.0, 0.0, 0.0)

# columns of Packed.strip_par (LBAR: rest length attributed to the node, mm)
KB, KT, EIW, EIS, GJ, KW0, KN0, TAU0, LBAR = range(9)


class Packed(NamedTuple):
    """Element arrays of a model, as the kernels take them (see :class:`dr.Model`)."""

    n: int  # real nodes
    bond_nodes: np.ndarray  # (b, 3) the real nodes a bond point is made from
    bond_w: np.ndarray  # (b, 3) their weights (>= 0, sum 1)
    ghost_src: np.ndarray  # (g,) node mirrored
    ghost_clamp: np.ndarray  # (g,) clamped node
    ghost_t: np.ndarray  # (g, 3) unit clamped tangent
    off_geo: np.ndarray  # (o, 5) frame geometry indices of the offset node's frame node
    off_d: np.ndarray  # (o,) signed offset along the strip normal, mm
    link_ij: np.ndarray  # (l, 2)
    link_EA: np.ndarray  # N
    link_L0: np.ndarray  # mm
    link_tension_only: np.ndarray  # bool
    link_frame: np.ndarray  # bool: frame axial (True) or membrane (False), for the energy split
    clu_ptr: np.ndarray  # (c+1,) into clu_nodes
    clu_nodes: np.ndarray  # chains, concatenated
    clu_EA: np.ndarray  # N
    clu_L0: np.ndarray  # mm, rest length of the whole cable
    clu_tension_only: np.ndarray  # bool
    clu_seg: np.ndarray  # (s, 2) cable segments (node pairs), all clusters
    clu_seg_cluster: np.ndarray  # (s,) cluster of each segment
    clu_work: np.ndarray  # (len(clu_nodes),) scratch: segment lengths of the current step
    beam_idx: np.ndarray  # (b, 3) spline-beam triplets s, i, f
    beam_EI: np.ndarray  # N mm^2
    beam_k0: np.ndarray  # 1/mm rest curvature
    beam_w: np.ndarray  # weight (1/2 at a clamp: the other half belongs to the mirrored beam)
    beam_l: np.ndarray  # mm, rest length attributed to the node
    strip_idx: np.ndarray  # (k, 5) frame geometry of strip nodes
    strip_par: np.ndarray  # (k, 9) KB, KT, EIW, EIS, GJ, KW0, KN0, TAU0, LBAR
    strip_blocks: np.ndarray  # (k, 5, 6) scratch: mass blocks in the material frame
    tri_idx: np.ndarray  # (t, 3) membrane triangles
    tri_grad: np.ndarray  # (t, 3, 2) flat shape-function gradients, 1/mm
    tri_par: np.ndarray  # (t, 5) see dr.triangles (area, E h, lambda, tension-only, law)
    rod_idx: np.ndarray  # (r, 7) rod vertex stencils, see dr.rod
    rod_par: np.ndarray  # (r, dr.rod.N_PAR)
    rod_blocks: np.ndarray  # (r, 7, 6) scratch: mass blocks in the vertex's material frame

    @property
    def n_total(self) -> int:
        """Rows of the extended position array: real nodes, bond points, offsets, ghosts."""
        return self.n + self.bond_nodes.shape[0] + self.off_geo.shape[0] + self.ghost_src.shape[0]


# ----------------------------------------------------------------------------- frame geometry


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


# ----------------------------------------------------------------------------- strip term


@njit(cache=True, error_model="numpy")
def strip_forward(xl, fixed1, fixed2):
    """Geometry of one strip node from its local rows: curvature binormal, material frame.

    Discrete curvature binormal kb = 2 a x b / (|a||b| + a.b) (|kb| = 2 tan(phi/2) for a
    turning angle phi), node tangent t = unit(a/|a| + b/|b|), width direction
    u = unit(nu x t) (in the membrane plane), strip normal n = t x u. Weak-axis curvature is
    kb.u, strong-axis (in-plane) kb.n, twist (n1 x n2).t between the two edge normals.
    """
    xp, xj, xn = get(xl, 0), get(xl, 1), get(xl, 2)
    a = sub(xj, xp)
    b = sub(xn, xj)
    la, lb = norm(a), norm(b)
    den = la * lb + dot(a, b)
    c = cross(a, b)
    kap = scale(c, 2.0 / den)
    ah, bh = scale(a, 1.0 / la), scale(b, 1.0 / lb)
    us = add(ah, bh)
    lu = norm(us)
    tb = scale(us, 1.0 / lu)
    n1, l1, n2, l2, nu, ls = node_frame(xl, fixed1, fixed2)
    v = cross(nu, tb)
    lv = norm(v)
    uu = scale(v, 1.0 / lv)
    nt = cross(tb, uu)
    kw, kn, tau = dot(kap, uu), dot(kap, nt), dot(cross(n1, n2), tb)
    return (kw, kn, tau), (a, b, la, lb, den, c, kap, ah, bh, lu, tb, n1, l1, n2, l2, nu, ls, lv, uu, nt)


@njit(cache=True, error_model="numpy")
def strip_local(xl, fixed1, fixed2, par, gl, want_grad):
    """Energy (bending, torsion) of one strip node; its gradient is added to gl (5, 3).

    Also returns the node's material frame (tangent, width direction, strip normal).

    E = KB/2 (EI_w (kb.u - kw0)^2 + EI_s (kb.n - kn0)^2) + KT/2 GJ ((n1 x n2).t - tau0)^2,
    KB and KT being the node's weight over its length; the rest values make the flat state
    stress-free.
    """
    kb_, kt_ = par[KB], par[KT]
    (kw, kn, tau), geo = strip_forward(xl, fixed1, fixed2)
    a, b, la, lb, den, c, kap, ah, bh, lu, tb, n1, l1, n2, l2, nu, ls, lv, uu, nt = geo
    dw, dn, dt = kw - par[KW0], kn - par[KN0], tau - par[TAU0]
    e_bend = 0.5 * kb_ * (par[EIW] * dw * dw + par[EIS] * dn * dn)
    e_twist = 0.5 * kt_ * par[GJ] * dt * dt
    if not want_grad:
        return e_bend, e_twist, (tb, uu, nt)
    g_k = add(scale(uu, kb_ * par[EIW] * dw), scale(nt, kb_ * par[EIS] * dn))
    g_uu = scale(kap, kb_ * par[EIW] * dw)
    g_nt = scale(kap, kb_ * par[EIS] * dn)
    g_tb = cross(uu, g_nt)
    g_uu = add(g_uu, cross(g_nt, tb))
    g_v = unit_vjp(uu, lv, g_uu)
    g_nu = cross(tb, g_v)
    g_tb = add(g_tb, cross(g_v, nu))
    gt = kt_ * par[GJ] * dt
    g_n1 = scale(cross(n2, tb), gt)
    g_n2 = scale(cross(tb, n1), gt)
    g_tb = add(g_tb, scale(cross(n1, n2), gt))
    g_us = unit_vjp(tb, lu, g_tb)
    g_a = unit_vjp(ah, la, g_us)
    g_b = unit_vjp(bh, lb, g_us)
    cg = dot(c, g_k)
    f1 = 2.0 / den
    f2 = -2.0 * cg / (den * den)
    g_a = add(g_a, axpy(f1, cross(b, g_k), scale(axpy(lb, ah, b), f2)))
    g_b = add(g_b, axpy(f1, cross(g_k, a), scale(axpy(la, bh, a), f2)))
    add_to(gl, 0, g_a, -1.0)
    add_to(gl, 1, sub(g_a, g_b), 1.0)
    add_to(gl, 2, g_b, 1.0)
    node_frame_vjp(xl, fixed1, fixed2, n1, l1, n2, l2, nu, ls, g_n1, g_n2, g_nu, gl)
    return e_bend, e_twist, (tb, uu, nt)


@njit(cache=True, error_model="numpy")
def strip_measures(X, idx_all):
    """(k, 3) weak curvature, strong curvature, twist (turning angles, rad) of strip nodes."""
    out = np.zeros((idx_all.shape[0], 3))
    xl = np.zeros((5, 3))
    for k in range(idx_all.shape[0]):
        idx = idx_all[k]
        gather(X, idx, xl)
        out[k, 0], out[k, 1], out[k, 2] = strip_forward(xl, idx[3] < 0, idx[4] < 0)[0]
    return out


# ----------------------------------------------------------------------------- virtual nodes


@njit(cache=True, error_model="numpy")
def place_virtual(X, P):
    """Positions of the virtual nodes from the real ones: bond points (rows n...), ghosts,
    then offsets (after the bond points that may set their normals)."""
    for k in range(P.bond_nodes.shape[0]):
        for c in range(3):
            X[P.n + k, c] = (P.bond_w[k, 0] * X[P.bond_nodes[k, 0], c] + P.bond_w[k, 1] * X[P.bond_nodes[k, 1], c]
                             + P.bond_w[k, 2] * X[P.bond_nodes[k, 2], c])
    n = P.n + P.bond_nodes.shape[0]  # first offset row
    base = n + P.off_geo.shape[0]
    for k in range(P.ghost_src.shape[0]):
        xs, xc = get(X, P.ghost_src[k]), get(X, P.ghost_clamp[k])
        t = get(P.ghost_t, k)
        g = axpy(-2.0 * dot(sub(xs, xc), t), t, xs)
        X[base + k, 0], X[base + k, 1], X[base + k, 2] = g
    xl = np.zeros((5, 3))
    for k in range(P.off_geo.shape[0]):
        idx = P.off_geo[k]
        gather(X, idx, xl)
        nu = node_frame(xl, idx[3] < 0, idx[4] < 0)[4]
        q = axpy(P.off_d[k], nu, get(xl, 1))
        X[n + k, 0], X[n + k, 1], X[n + k, 2] = q


@njit(cache=True, error_model="numpy")
def pull_back_virtual(X, G, P):
    """Move gradients on virtual nodes onto the real nodes they are made from (chain rule):
    offsets (onto frame nodes and bond points), ghosts, then bond points."""
    n = P.n + P.bond_nodes.shape[0]
    base = n + P.off_geo.shape[0]
    xl = np.zeros((5, 3))
    gl = np.zeros((5, 3))
    for k in range(P.off_geo.shape[0]):
        idx = P.off_geo[k]
        g_q = get(G, n + k)
        gather(X, idx, xl)
        f1, f2 = idx[3] < 0, idx[4] < 0
        n1, l1, n2, l2, nu, ls = node_frame(xl, f1, f2)
        gl[:] = 0.0
        add_to(gl, 1, g_q, 1.0)
        node_frame_vjp(xl, f1, f2, n1, l1, n2, l2, nu, ls, Z0, Z0, scale(g_q, P.off_d[k]), gl)
        scatter(G, idx, gl, 1.0)
    for k in range(P.ghost_src.shape[0]):
        g = get(G, base + k)
        t = get(P.ghost_t, k)
        # g = R x_src + (I - R) x_clamp with R = I - 2 t t^T (symmetric)
        gt = 2.0 * dot(g, t)
        add_to(G, P.ghost_src[k], axpy(-gt, t, g), 1.0)
        add_to(G, P.ghost_clamp[k], t, gt)
    for k in range(P.bond_nodes.shape[0]):
        for a in range(3):
            add_to(G, P.bond_nodes[k, a], get(G, P.n + k), P.bond_w[k, a])



# ----------------------------------------------------------------------------- all elements


@njit(cache=True, error_model="numpy")
def _tension(EA, L0, L, tension_only):
    t = EA / L0 * (L - L0)
    if tension_only and t < 0.0:
        return 0.0
    return t


@njit(cache=True, error_model="numpy", inline="always")
def add_block(D, i, e, k_axial, k_geo):
    """D[i] += k_axial e e^T + k_geo (I - e e^T), e a unit vector; D rows are xx yy zz xy xz yz."""
    kd = k_axial - k_geo
    D[i, 0] += kd * e[0] * e[0] + k_geo
    D[i, 1] += kd * e[1] * e[1] + k_geo
    D[i, 2] += kd * e[2] * e[2] + k_geo
    D[i, 3] += kd * e[0] * e[1]
    D[i, 4] += kd * e[0] * e[2]
    D[i, 5] += kd * e[1] * e[2]


@njit(cache=True, error_model="numpy", inline="always")
def _sym(b):
    """3x3 matrix entries of a symmetric block stored as (xx, yy, zz, xy, xz, yz)."""
    return ((b[0], b[3], b[4]), (b[3], b[1], b[5]), (b[4], b[5], b[2]))


@njit(cache=True, error_model="numpy")
def _add_congruent(D, i, B, Q):
    """D[i] += Q B Q^T for a symmetric 3x3 B and a 3x3 Q (tuples of rows)."""
    C = (
        (Q[0][0] * B[0][0] + Q[0][1] * B[1][0] + Q[0][2] * B[2][0],
         Q[0][0] * B[0][1] + Q[0][1] * B[1][1] + Q[0][2] * B[2][1],
         Q[0][0] * B[0][2] + Q[0][1] * B[1][2] + Q[0][2] * B[2][2]),
        (Q[1][0] * B[0][0] + Q[1][1] * B[1][0] + Q[1][2] * B[2][0],
         Q[1][0] * B[0][1] + Q[1][1] * B[1][1] + Q[1][2] * B[2][1],
         Q[1][0] * B[0][2] + Q[1][1] * B[1][2] + Q[1][2] * B[2][2]),
        (Q[2][0] * B[0][0] + Q[2][1] * B[1][0] + Q[2][2] * B[2][0],
         Q[2][0] * B[0][1] + Q[2][1] * B[1][1] + Q[2][2] * B[2][1],
         Q[2][0] * B[0][2] + Q[2][1] * B[1][2] + Q[2][2] * B[2][2]),
    )
    D[i, 0] += dot(C[0], Q[0])
    D[i, 1] += dot(C[1], Q[1])
    D[i, 2] += dot(C[2], Q[2])
    D[i, 3] += dot(C[0], Q[1])
    D[i, 4] += dot(C[0], Q[2])
    D[i, 5] += dot(C[1], Q[2])


@njit(cache=True, error_model="numpy")
def add_rotated(D, i, local, frame):
    """D[i] += F B F^T for a block B given in the frame F = [t, u, n] (its columns)."""
    t, u, n = frame
    _add_congruent(D, i, _sym(local), ((t[0], u[0], n[0]), (t[1], u[1], n[1]), (t[2], u[2], n[2])))


@njit(cache=True, error_model="numpy")
def add_reflected(D, i, block, t):
    """D[i] += R B R with R = I - 2 t t^T: a ghost's stiffness seen from the node it mirrors."""
    R = ((1.0 - 2 * t[0] * t[0], -2 * t[0] * t[1], -2 * t[0] * t[2]),
         (-2 * t[1] * t[0], 1.0 - 2 * t[1] * t[1], -2 * t[1] * t[2]),
         (-2 * t[2] * t[0], -2 * t[2] * t[1], 1.0 - 2 * t[2] * t[2]))
    _add_congruent(D, i, _sym(block), R)


_SLOT = ((0, 3, 4), (3, 1, 5), (4, 5, 2))


@njit(cache=True, error_model="numpy")
def gradient(X, P, G, D):
    """Energy gradient dE/dX of all elements on the real nodes, in G (n_total, 3).

    X must hold the real positions in its first P.n rows; virtual rows are recomputed. If D
    has rows, direction-dependent stiffness blocks are accumulated in it: the exact block
    EA/L0 e e^T + |T|/L (I - e e^T) of each link end (a link's stiffness is at most twice
    its block diagonal), and the strip blocks of :func:`stiffness` turned with the strip's
    current material frame. Returns the largest element force (N) for the relative residual.
    """
    place_virtual(X, P)
    G[:] = 0.0
    tensor = D.shape[0] > 0
    if tensor:
        D[:] = 0.0
    fmax = 0.0
    for k in range(P.link_ij.shape[0]):
        i, j = P.link_ij[k, 0], P.link_ij[k, 1]
        d = sub(get(X, j), get(X, i))
        L = norm(d)
        t = _tension(P.link_EA[k], P.link_L0[k], L, P.link_tension_only[k])
        fmax = max(fmax, abs(t))
        add_to(G, i, d, -t / L)
        add_to(G, j, d, t / L)
        if tensor:
            e = scale(d, 1.0 / L)
            ka, kg = P.link_EA[k] / P.link_L0[k], abs(t) / L
            add_block(D, i, e, ka, kg)
            add_block(D, j, e, ka, kg)
    seg_len = P.clu_work
    for c in range(P.clu_ptr.shape[0] - 1):
        lo, hi = P.clu_ptr[c], P.clu_ptr[c + 1]
        L = 0.0
        for s in range(lo, hi - 1):
            li = norm(sub(get(X, P.clu_nodes[s + 1]), get(X, P.clu_nodes[s])))
            seg_len[s] = li
            L += li
        t = _tension(P.clu_EA[c], P.clu_L0[c], L, P.clu_tension_only[c])
        fmax = max(fmax, abs(t))
        if t == 0.0:
            continue
        for s in range(lo, hi - 1):
            i, j = P.clu_nodes[s], P.clu_nodes[s + 1]
            d = sub(get(X, j), get(X, i))
            f = t / seg_len[s]
            add_to(G, i, d, -f)
            add_to(G, j, d, f)
    for k in range(P.beam_idx.shape[0]):
        s, i, f = P.beam_idx[k, 0], P.beam_idx[k, 1], P.beam_idx[k, 2]
        xs, xi, xf = get(X, s), get(X, i), get(X, f)
        a, b = sub(xi, xs), sub(xf, xi)
        la, lb, lc = norm(a), norm(b), norm(sub(xf, xs))
        cr = cross(a, b)
        lcr = norm(cr)
        if lcr <= 1e-14 * la * lb:
            continue  # straight: no bending plane (and no moment if the rest state is straight)
        m = P.beam_w[k] * P.beam_EI[k] * (2.0 * lcr / (la * lb * lc) - P.beam_k0[k])
        n = scale(cr, 1.0 / lcr)
        ea = cross(n, a)  # length la, towards the centre of curvature
        eb = cross(n, b)
        sa, sb = m / (la * la), m / (lb * lb)
        fmax = max(fmax, abs(m) / min(la, lb))
        # Adriaenssens & Barnes: ends pushed away from the centre, middle node towards it
        add_to(G, s, ea, sa)
        add_to(G, f, eb, sb)
        add_to(G, i, add(scale(ea, sa), scale(eb, sb)), -1.0)
    xl = np.zeros((5, 3))
    gl = np.zeros((5, 3))
    for k in range(P.strip_idx.shape[0]):
        idx = P.strip_idx[k]
        gather(X, idx, xl)
        gl[:] = 0.0
        _, _, frame = strip_local(xl, idx[3] < 0, idx[4] < 0, P.strip_par[k], gl, True)
        scatter(G, idx, gl, 1.0)
        for r in range(3):
            fmax = max(fmax, norm(get(gl, r)))
        if tensor:
            for r in range(5):
                if idx[r] >= 0:
                    add_rotated(D, idx[r], P.strip_blocks[k, r], frame)
    xt = np.zeros((3, 3))
    gt = np.zeros((3, 3))
    for k in range(P.tri_idx.shape[0]):
        fmax = max(fmax, triangle_gradient(X, P.tri_idx[k], P.tri_grad[k], P.tri_par[k], G, D, xt, gt))
    xr = np.zeros((rod_element.ROWS, 3))
    gr = np.zeros((rod_element.ROWS, 3))
    for k in range(P.rod_idx.shape[0]):
        idx = P.rod_idx[k]
        rod_element.gather(X, idx, xr)
        gr[:] = 0.0
        _, _, frame, _ = rod_element.rod_local(xr, P.rod_par[k], gr, True)
        for r in range(rod_element.ROWS):
            if idx[r] >= 0:
                add_to(G, idx[r], get(gr, r), 1.0)
                if tensor and P.rod_par[k, rod_element.MODEL] == rod_element.STRIP:
                    add_rotated(D, idx[r], P.rod_blocks[k, r], frame)
        for r in range(3):
            fmax = max(fmax, norm(get(gr, r)))
    pull_back_virtual(X, G, P)
    if tensor:
        off = P.n + P.bond_nodes.shape[0]
        for k in range(P.off_geo.shape[0]):
            for c in range(6):
                D[P.off_geo[k, 1], c] += D[off + k, c]
        base = off + P.off_geo.shape[0]
        for k in range(P.ghost_src.shape[0]):
            add_reflected(D, P.ghost_src[k], D[base + k], get(P.ghost_t, k))
        # p = sum w_a x_a, w >= 0, sum w = 1: each node's share w_a D_p bounds the Hessian
        for k in range(P.bond_nodes.shape[0]):
            for a in range(3):
                for c in range(6):
                    D[P.bond_nodes[k, a], c] += P.bond_w[k, a] * D[P.n + k, c]
    return fmax


@njit(cache=True, error_model="numpy")
def energy(X, P):
    """Strain energy split (membrane, frame bending, frame torsion, frame axial), N mm."""
    place_virtual(X, P)
    e_mem = e_bend = e_twist = e_ax = 0.0
    for k in range(P.link_ij.shape[0]):
        L = norm(sub(get(X, P.link_ij[k, 1]), get(X, P.link_ij[k, 0])))
        t = _tension(P.link_EA[k], P.link_L0[k], L, P.link_tension_only[k])
        e = 0.5 * t * t * P.link_L0[k] / P.link_EA[k]  # N eps L0 / 2
        if P.link_frame[k]:
            e_ax += e
        else:
            e_mem += e
    for c in range(P.clu_ptr.shape[0] - 1):
        L = 0.0
        for s in range(P.clu_ptr[c], P.clu_ptr[c + 1] - 1):
            L += norm(sub(get(X, P.clu_nodes[s + 1]), get(X, P.clu_nodes[s])))
        t = _tension(P.clu_EA[c], P.clu_L0[c], L, P.clu_tension_only[c])
        e_mem += 0.5 * t * t * P.clu_L0[c] / P.clu_EA[c]
    for k in range(P.beam_idx.shape[0]):
        xs, xi, xf = get(X, P.beam_idx[k, 0]), get(X, P.beam_idx[k, 1]), get(X, P.beam_idx[k, 2])
        a, b = sub(xi, xs), sub(xf, xi)
        kap = 2.0 * norm(cross(a, b)) / (norm(a) * norm(b) * norm(sub(xf, xs)))
        dm = kap - P.beam_k0[k]
        e_bend += 0.5 * P.beam_w[k] * P.beam_EI[k] * dm * dm * P.beam_l[k]  # M^2 L / (2 EI)
    xl = np.zeros((5, 3))
    gl = np.zeros((5, 3))
    for k in range(P.strip_idx.shape[0]):
        idx = P.strip_idx[k]
        gather(X, idx, xl)
        eb, et, _ = strip_local(xl, idx[3] < 0, idx[4] < 0, P.strip_par[k], gl, False)
        e_bend += eb
        e_twist += et
    xt = np.zeros((3, 3))
    for k in range(P.tri_idx.shape[0]):
        for a in range(3):
            for c in range(3):
                xt[a, c] = X[P.tri_idx[k, a], c]
        e_mem += triangle_local(xt, P.tri_grad[k], P.tri_par[k], xt, False)
    xr = np.zeros((rod_element.ROWS, 3))
    for k in range(P.rod_idx.shape[0]):
        rod_element.gather(X, P.rod_idx[k], xr)
        eb, et, _, _ = rod_element.rod_local(xr, P.rod_par[k], xr, False)
        e_bend += eb
        e_twist += et
    return e_mem, e_bend, e_twist, e_ax


# ----------------------------------------------------------------------------- masses


@njit(cache=True, error_model="numpy")
def _strip_hessian(xl, fixed1, fixed2, par, H):
    """Hessian (15, 15) of one strip term by central differences of its exact gradient."""
    g_plus = np.zeros((5, 3))
    g_minus = np.zeros((5, 3))
    h = 1e-6 * norm(sub(get(xl, 2), get(xl, 0)))
    H[:] = 0.0
    for r in range(5):
        if (r == 3 and fixed1) or (r == 4 and fixed2):
            continue
        for c in range(3):
            x0 = xl[r, c]
            g_plus[:] = 0.0
            g_minus[:] = 0.0
            xl[r, c] = x0 + h
            strip_local(xl, fixed1, fixed2, par, g_plus, True)
            xl[r, c] = x0 - h
            strip_local(xl, fixed1, fixed2, par, g_minus, True)
            xl[r, c] = x0
            for rr in range(5):
                for cc in range(3):
                    H[3 * rr + cc, 3 * r + c] = (g_plus[rr, cc] - g_minus[rr, cc]) / (2.0 * h)


@njit(cache=True, error_model="numpy")
def _strip_blocks(xl, fixed1, fixed2, par, H, out):
    """Mass blocks of a strip term in its node's material frame, out (5, 6)."""
    active = np.ones(5, dtype=np.bool_)
    active[3], active[4] = not fixed1, not fixed2
    _, _, frame = strip_local(xl, fixed1, fixed2, np.zeros(9), np.zeros((5, 3)), False)
    frame_blocks(H, active, frame, out)


@njit(cache=True, error_model="numpy")
def frame_blocks(H, active, frame, out):
    """Mass blocks out (rows, 6) of a term with Hessian H over its rows, in a material frame.

    With |H| the absolute value of the (symmetrised) Hessian over the term's m active rows,
    H <= |H| <= m blockdiag(|H|) (Cauchy-Schwarz), so m |H|_rr bounds each row's share. Stored
    in the frame (t, u, n) so that they can turn with the element.
    """
    Hs = 0.5 * (H + H.T)
    w, V = np.linalg.eigh(Hs)
    A = (V * np.abs(w)) @ V.T
    m = 0
    for r in range(active.shape[0]):
        if active[r]:
            m += 1
    for r in range(active.shape[0]):
        for a in range(3):
            for b in range(a, 3):
                v = 0.0
                for p in range(3):
                    for q in range(3):
                        v += frame[a][p] * A[3 * r + p, 3 * r + q] * frame[b][q]
                out[r, _SLOT[a][b]] = m * v if active[r] else 0.0


@njit(cache=True, error_model="numpy")
def stiffness(X, P, S, with_links):
    """Per-node stiffness bound S (n_total,) for the fictitious masses m = f dt^2/2 S.

    Links (``with_links``; else they go into the directional blocks of :func:`gradient`):
    EA/L0 + T/L (Barnes). Clusters: the same, with the cable's axial term spread by how much
    each node changes the cable length; they stay scalar because an inner cable node's
    stiffness hangs on the kink of the cable there, which changes every step. Spline beams: the row sums (4, 8, 4) EI/l^3 of a
    triplet's lateral stiffness plus the geometric M/l^2. Strip nodes: Gershgorin row sums
    of the term's Hessian (``with_links``), or else its blocks in the strip's material frame,
    kept in P.strip_blocks for :func:`gradient` to turn with the strip every step. Virtual
    nodes pass theirs to the nodes they are made from.
    """
    place_virtual(X, P)
    S[:] = 0.0
    for k in range(P.link_ij.shape[0] if with_links else 0):
        i, j = P.link_ij[k, 0], P.link_ij[k, 1]
        L = norm(sub(get(X, j), get(X, i)))
        t = _tension(P.link_EA[k], P.link_L0[k], L, P.link_tension_only[k])
        kk = P.link_EA[k] / P.link_L0[k] + abs(t) / L
        S[i] += kk
        S[j] += kk
    for c in range(P.clu_ptr.shape[0] - 1):
        lo, hi = P.clu_ptr[c], P.clu_ptr[c + 1]
        L = 0.0
        for s in range(lo, hi - 1):
            L += norm(sub(get(X, P.clu_nodes[s + 1]), get(X, P.clu_nodes[s])))
        t = abs(_tension(P.clu_EA[c], P.clu_L0[c], L, P.clu_tension_only[c]))
        k_ax = P.clu_EA[c] / P.clu_L0[c]
        nseg = hi - lo - 1
        # |dL/dx_node| summed over the chain: 2 for a straight cable, more for a kinked one
        gsum = 0.0
        for s in range(lo, hi):
            gsum += _chain_turn(X, P.clu_nodes, lo, hi, s)
        for s in range(lo, hi):
            node = P.clu_nodes[s]
            geo = 0.0
            if s > lo:
                geo += t / norm(sub(get(X, node), get(X, P.clu_nodes[s - 1])))
            if s < hi - 1:
                geo += t / norm(sub(get(X, P.clu_nodes[s + 1]), get(X, node)))
            # a slack cable still gets a little mass so that its nodes stay finite
            S[node] += k_ax * (_chain_turn(X, P.clu_nodes, lo, hi, s) * gsum + 0.05 * nseg) + geo
    for k in range(P.beam_idx.shape[0]):
        s, i, f = P.beam_idx[k, 0], P.beam_idx[k, 1], P.beam_idx[k, 2]
        xs, xi, xf = get(X, s), get(X, i), get(X, f)
        a, b = sub(xi, xs), sub(xf, xi)
        la, lb = norm(a), norm(b)
        lm = min(la, lb)
        kap = 2.0 * norm(cross(a, b)) / (la * lb * norm(sub(xf, xs)))
        m = abs(P.beam_w[k] * P.beam_EI[k] * (kap - P.beam_k0[k]))
        kb = P.beam_w[k] * P.beam_EI[k] / (lm * lm * lm)
        S[s] += 4.0 * kb + m / (lm * lm)
        S[i] += 8.0 * kb + 2.0 * m / (lm * lm)
        S[f] += 4.0 * kb + m / (lm * lm)
    xl = np.zeros((5, 3))
    H = np.zeros((15, 15))
    for k in range(P.strip_idx.shape[0]):
        idx = P.strip_idx[k]
        gather(X, idx, xl)
        f1, f2 = idx[3] < 0, idx[4] < 0
        _strip_hessian(xl, f1, f2, P.strip_par[k], H)
        if with_links:
            _gershgorin(H, idx, S)
        else:
            _strip_blocks(xl, f1, f2, P.strip_par[k], H, P.strip_blocks[k])
    xt = np.zeros((3, 3))
    for k in range(P.tri_idx.shape[0]):
        triangle_stiffness(X, P.tri_idx[k], P.tri_grad[k], P.tri_par[k], S, with_links, xt)
    xr = np.zeros((rod_element.ROWS, 3))
    Hr = np.zeros((3 * rod_element.ROWS, 3 * rod_element.ROWS))
    for k in range(P.rod_idx.shape[0]):
        idx = P.rod_idx[k]
        rod_element.gather(X, idx, xr)
        rod_element.rod_hessian(xr, idx, P.rod_par[k], Hr)
        if with_links or P.rod_par[k, rod_element.MODEL] == rod_element.PAPER:
            _gershgorin(Hr, idx, S)  # isotropic bending: an isotropic bound
        else:
            _, _, frame, _ = rod_element.rod_local(xr, P.rod_par[k], xr, False)
            frame_blocks(Hr, idx >= 0, frame, P.rod_blocks[k])
    n = P.n + P.bond_nodes.shape[0]
    base = n + P.off_geo.shape[0]
    for k in range(P.off_geo.shape[0]):
        S[P.off_geo[k, 1]] += S[n + k]
    for k in range(P.ghost_src.shape[0]):
        S[P.ghost_src[k]] += S[base + k]
    for k in range(P.bond_nodes.shape[0]):
        for a in range(3):
            S[P.bond_nodes[k, a]] += P.bond_w[k, a] * S[P.n + k]


@njit(cache=True, error_model="numpy")
def _gershgorin(H, idx, S):
    """S[idx[r]] += the largest absolute row sum of H over row block r (Gershgorin)."""
    for r in range(idx.shape[0]):
        if idx[r] < 0:
            continue
        row = 0.0
        for c in range(3):
            acc = 0.0
            for j in range(H.shape[1]):
                acc += abs(H[3 * r + c, j])
            row = max(row, acc)
        S[idx[r]] += row


@njit(cache=True, error_model="numpy")
def _chain_turn(X, nodes, lo, hi, s):
    """|dL/dx| of chain node s: |e_in - e_out| (1 at the ends)."""
    if s == lo or s == hi - 1:
        return 1.0
    p, c, q = get(X, nodes[s - 1]), get(X, nodes[s]), get(X, nodes[s + 1])
    e1 = sub(c, p)
    e2 = sub(q, c)
    return norm(sub(scale(e1, 1.0 / norm(e1)), scale(e2, 1.0 / norm(e2))))
