"""DR element: the strip (weak- and strong-axis bending and torsion) at frame nodes.

Its plane follows the film: each edge's normal comes from the point that fixes it
(:mod:`dr.frames`). Forces are the exact gradient of one energy, so those points get their
reactions; masses come from the term's Hessian (central differences of the exact gradient),
as blocks in the strip's material frame that turn with it (tensor masses) or Gershgorin row
sums (scalar masses).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .blocks import add_rotated, frame_blocks, gershgorin
from .frames import gather, node_frame, node_frame_vjp, scatter
from .vec import add, add_to, axpy, cross, dot, get, norm, scale, sub, unit_vjp

# columns of Packed.strip_par (LBAR: rest length attributed to the node, mm)
KB, KT, EIW, EIS, GJ, KW0, KN0, TAU0, LBAR = range(9)


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


@njit(cache=True, error_model="numpy", inline="always")
def gradient(X, P, G, D):
    """Add the strips' energy gradient to G and, if D has rows, their mass blocks turned with
    each node's current material frame. Returns the largest nodal force, N."""
    if P.strip_idx.shape[0] == 0:
        return 0.0  # no scratch arrays for a model without this element
    fmax = 0.0
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
        if D.shape[0] > 0:
            for r in range(5):
                if idx[r] >= 0:
                    add_rotated(D, idx[r], P.strip_blocks[k, r], frame)
    return fmax


@njit(cache=True, error_model="numpy")
def energy(X, P):
    """Bending and torsion energy of all strip nodes, N mm."""
    e_bend = e_twist = 0.0
    xl = np.zeros((5, 3))
    gl = np.zeros((5, 3))
    for k in range(P.strip_idx.shape[0]):
        idx = P.strip_idx[k]
        gather(X, idx, xl)
        eb, et, _ = strip_local(xl, idx[3] < 0, idx[4] < 0, P.strip_par[k], gl, False)
        e_bend += eb
        e_twist += et
    return e_bend, e_twist


@njit(cache=True, error_model="numpy")
def stiffness(X, P, S, with_links):
    """Gershgorin row sums of each term's Hessian into S (``with_links``), or else its blocks
    in the strip's material frame into P.strip_blocks for :func:`gradient` to turn."""
    xl = np.zeros((5, 3))
    H = np.zeros((15, 15))
    for k in range(P.strip_idx.shape[0]):
        idx = P.strip_idx[k]
        gather(X, idx, xl)
        f1, f2 = idx[3] < 0, idx[4] < 0
        _strip_hessian(xl, f1, f2, P.strip_par[k], H)
        if with_links:
            gershgorin(H, idx, S)
        else:
            _strip_blocks(xl, f1, f2, P.strip_par[k], H, P.strip_blocks[k])
