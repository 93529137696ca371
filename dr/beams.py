"""DR element: the Adriaenssens-Barnes spline beam, M = EI (|kappa| - kappa_0) per node triplet."""

from __future__ import annotations

import numpy as np
from numba import njit

from .vec import add, add_to, cross, get, norm, scale, sub


@njit(cache=True, error_model="numpy", inline="always")
def curvature(xs, xi, xf):
    """Circle curvature through a triplet, 2 |a x b| / (|a| |b| |c|) (1/mm), with a = xi - xs,
    b = xf - xi, and (a, b, |a|, |b|, a x b, |a x b|)."""
    a, b = sub(xi, xs), sub(xf, xi)
    la, lb, lc = norm(a), norm(b), norm(sub(xf, xs))
    cr = cross(a, b)
    lcr = norm(cr)
    return 2.0 * lcr / (la * lb * lc), a, b, la, lb, cr, lcr


@njit(cache=True, error_model="numpy")
def curvatures(X, idx):
    """Curvatures (b,) of triplets idx (b, 3) at positions X, 1/mm."""
    out = np.zeros(idx.shape[0])
    for k in range(idx.shape[0]):
        out[k] = curvature(get(X, idx[k, 0]), get(X, idx[k, 1]), get(X, idx[k, 2]))[0]
    return out


@njit(cache=True, error_model="numpy", inline="always")
def gradient(X, P, G, D):
    """Add the beams' energy gradient to G. Returns the largest nodal force, N."""
    fmax = 0.0
    for k in range(P.beam_idx.shape[0]):
        s, i, f = P.beam_idx[k, 0], P.beam_idx[k, 1], P.beam_idx[k, 2]
        kap, a, b, la, lb, cr, lcr = curvature(get(X, s), get(X, i), get(X, f))
        if lcr <= 1e-14 * la * lb:
            continue  # straight: no bending plane (and no moment if the rest state is straight)
        m = P.beam_w[k] * P.beam_EI[k] * (kap - P.beam_k0[k])
        n = scale(cr, 1.0 / lcr)
        ea = cross(n, a)  # length la, towards the centre of curvature
        eb = cross(n, b)
        sa, sb = m / (la * la), m / (lb * lb)
        fmax = max(fmax, abs(m) / min(la, lb))
        # Adriaenssens & Barnes: ends pushed away from the centre, middle node towards it
        add_to(G, s, ea, sa)
        add_to(G, f, eb, sb)
        add_to(G, i, add(scale(ea, sa), scale(eb, sb)), -1.0)
    return fmax


@njit(cache=True, error_model="numpy")
def energy(X, P):
    """Bending energy M^2 L / (2 EI) of all triplets, N mm."""
    e = 0.0
    for k in range(P.beam_idx.shape[0]):
        kap = curvature(get(X, P.beam_idx[k, 0]), get(X, P.beam_idx[k, 1]), get(X, P.beam_idx[k, 2]))[0]
        dm = kap - P.beam_k0[k]
        e += 0.5 * P.beam_w[k] * P.beam_EI[k] * dm * dm * P.beam_l[k]
    return e


@njit(cache=True, error_model="numpy")
def stiffness(X, P, S, with_links):
    """Row sums (4, 8, 4) EI/l^3 of a triplet's lateral stiffness plus the geometric M/l^2."""
    for k in range(P.beam_idx.shape[0]):
        s, i, f = P.beam_idx[k, 0], P.beam_idx[k, 1], P.beam_idx[k, 2]
        kap, _, _, la, lb, _, _ = curvature(get(X, s), get(X, i), get(X, f))
        lm = min(la, lb)
        m = abs(P.beam_w[k] * P.beam_EI[k] * (kap - P.beam_k0[k]))
        kb = P.beam_w[k] * P.beam_EI[k] / (lm * lm * lm)
        S[s] += 4.0 * kb + m / (lm * lm)
        S[i] += 8.0 * kb + 2.0 * m / (lm * lm)
        S[f] += 4.0 * kb + m / (lm * lm)
