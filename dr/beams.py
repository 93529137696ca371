"""DR element: the Adriaenssens-Barnes spline beam, M = EI (|kappa| - kappa_0) per node triplet."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from .triplets import beam_triplets
from .vec import add, add_to, cross, get, norm, scale, sub


class Fields(NamedTuple):
    """The spline beams' arrays in :class:`dr.kernels.Packed`."""

    beam_idx: np.ndarray  # (b, 3) spline-beam triplets s, i, f
    beam_EI: np.ndarray  # N mm^2
    beam_k0: np.ndarray  # 1/mm rest curvature
    beam_w: np.ndarray  # weight (1/2 at a clamp: the other half belongs to the mirrored beam)
    beam_l: np.ndarray  # mm, rest length attributed to the node



def pack(model, rest) -> Fields:
    """The isotropic beams of ``model`` (:meth:`dr.Model.add_beam` without ``EI_strong``), their
    rest curvatures and lengths from the rest positions ``rest.X`` (:class:`dr.model.Rest`)."""
    rows = list(beam_triplets(model, rest.ghost_id, strip=False))
    idx = np.array([r[:3] for r in rows], dtype=np.int64).reshape(-1, 3)
    X = rest.X
    s, i, f = idx.T
    return Fields(
        beam_idx=idx,
        beam_EI=np.array([r[6].EI for r in rows], dtype=float),
        beam_k0=curvatures(X, idx) if rows else np.zeros(0),
        beam_w=np.array([r[3] for r in rows], dtype=float),
        beam_l=0.5 * (np.linalg.norm(X[i] - X[s], axis=1) + np.linalg.norm(X[f] - X[i], axis=1)),
    )


def forces(X: np.ndarray, P, moment: np.ndarray) -> dict[str, np.ndarray]:
    """Adds each triplet's bending moment EI (kappa - kappa_0) (N mm) to ``moment`` (n,) at its
    middle node (ghost triplets' middle is the clamped node); reports nothing of its own."""
    if P.beam_idx.size == 0:
        return {}
    b = P.beam_idx[:, 1]
    kap = curvatures(X, P.beam_idx)
    np.add.at(moment, b[b < P.n], (P.beam_EI * (kap - P.beam_k0))[b < P.n])
    return {}


def edges(P) -> np.ndarray:
    """Node pairs (k, 2) of the triplets' two edges."""
    return np.concatenate([P.beam_idx[:, :2], P.beam_idx[:, 1:]])


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
def strain_energy(X, P):
    """Strain energy (membrane, frame bending, frame torsion, frame axial) of all triplets, N mm:
    bending M^2 L / (2 EI) only."""
    e = 0.0
    for k in range(P.beam_idx.shape[0]):
        kap = curvature(get(X, P.beam_idx[k, 0]), get(X, P.beam_idx[k, 1]), get(X, P.beam_idx[k, 2]))[0]
        dm = kap - P.beam_k0[k]
        e += 0.5 * P.beam_w[k] * P.beam_EI[k] * dm * dm * P.beam_l[k]
    return 0.0, e, 0.0, 0.0


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
