"""DR element: the strip (weak- and strong-axis bending and torsion) at frame nodes.

Its plane follows the film: each edge's normal comes from the point that fixes it
(:mod:`dr.frames`). Forces are the exact gradient of one energy, so those points get their
reactions; masses come from the term's Hessian (central differences of the exact gradient),
as blocks in the strip's material frame that turn with it (tensor masses) or Gershgorin row
sums (scalar masses).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from .beams import beam_triplets
from .blocks import add_rotated, frame_blocks, gershgorin
from .errors import DRError
from .frames import gather, node_frame, node_frame_vjp, scatter
from .vec import add, add_to, axpy, cross, dot, get, norm, scale, sub, unit_vjp

# columns of Packed.strip_par (LBAR: rest length attributed to the node, mm)
KB, KT, EIW, EIS, GJ, KW0, KN0, TAU0, LBAR = range(9)


class Fields(NamedTuple):
    """The strips' arrays in :class:`dr.kernels.Packed`."""

    strip_idx: np.ndarray  # (k, 5) frame geometry of strip nodes
    strip_par: np.ndarray  # (k, 9) KB, KT, EIW, EIS, GJ, KW0, KN0, TAU0, LBAR
    strip_blocks: np.ndarray  # (k, 5, 6) scratch: mass blocks in the material frame


def pack(model, rest) -> Fields:
    """The strip beams of ``model`` (:meth:`dr.Model.add_beam` with ``EI_strong``), their rest
    measures from the rest positions ``rest.X`` (:class:`dr.model.Rest`). Raises DRError for a
    strip clamped without tape (its normal needs holding)."""
    rows = []
    for prev, j, nxt, w, e1, e2, beam in beam_triplets(model, rest.ghost_id, strip=True):
        if w < 1.0 and not model.clamps[int(j)][1]:
            raise DRError(f"strip beam clamped at node {j} must be taped (clamp(..., taped=True)): its normal needs holding")
        o = beam.orientation
        rows.append((prev, j, nxt, o[e1] if e1 >= 0 else -1, o[e2] if e2 >= 0 else -1, w, beam))
    idx = np.array([r[:5] for r in rows], dtype=np.int64).reshape(-1, 5)
    par = np.zeros((len(rows), 9))
    if rows:
        X = rest.X
        la = np.linalg.norm(X[idx[:, 1]] - X[idx[:, 0]], axis=1)
        lb = np.linalg.norm(X[idx[:, 2]] - X[idx[:, 1]], axis=1)
        w = np.array([r[5] for r in rows])
        lbar = 0.5 * (la + lb)
        par[:, LBAR] = lbar
        par[:, KB] = w / lbar
        # the twist at a taped clamp spans half an edge (clamp to edge midpoint)
        par[:, KT] = np.where(w < 1.0, 1.0 / (0.5 * lbar), 1.0 / lbar)
        par[:, EIW] = [r[6].EI for r in rows]
        par[:, EIS] = [r[6].EI_strong for r in rows]
        par[:, GJ] = [r[6].GJ for r in rows]
        par[:, [KW0, KN0, TAU0]] = strip_measures(X, idx)
    return Fields(strip_idx=idx, strip_par=par, strip_blocks=np.zeros((len(rows), 5, 6)))


def forces(X: np.ndarray, P, moment: np.ndarray) -> dict[str, np.ndarray]:
    """Adds each strip node's weak-axis moment (N mm) to ``moment`` (n,); reports its twist
    and strong-axis curvature change from rest, 1/mm (none without strips)."""
    if P.strip_idx.size == 0:
        return {}
    meas = strip_measures(X, P.strip_idx)
    np.add.at(moment, P.strip_idx[:, 1], P.strip_par[:, EIW] * (meas[:, 0] - P.strip_par[:, KW0]) / P.strip_par[:, LBAR])
    return {"strip_twist": meas[:, 2] - P.strip_par[:, TAU0],
            "strip_strong_curvature": meas[:, 1] - P.strip_par[:, KN0]}


def stencils(P) -> np.ndarray:
    """The rows of X each strip node's energy depends on (k, 5; -1: none): its frame geometry."""
    return P.strip_idx


def edges(P) -> np.ndarray:
    """None: the drift scale of dr.relax counts a strip's edges as its frame links (add_beam's EA)."""
    return np.zeros((0, 2), np.int64)


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
def strain_energy(X, P):
    """Strain energy (membrane, frame bending, frame torsion, frame axial) of all strip nodes,
    N mm: bending and torsion."""
    e_bend = e_twist = 0.0
    xl = np.zeros((5, 3))
    gl = np.zeros((5, 3))
    for k in range(P.strip_idx.shape[0]):
        idx = P.strip_idx[k]
        gather(X, idx, xl)
        eb, et, _ = strip_local(xl, idx[3] < 0, idx[4] < 0, P.strip_par[k], gl, False)
        e_bend += eb
        e_twist += et
    return 0.0, e_bend, e_twist, 0.0


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
