"""Mass-bound helpers shared by the element modules: 3x3 stiffness blocks per node.

Blocks are symmetric and stored as (xx, yy, zz, xy, xz, yz) rows of D (n_total, 6).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .vec import dot

_SLOT = ((0, 3, 4), (3, 1, 5), (4, 5, 2))


@njit(cache=True, error_model="numpy", inline="always")
def add_block(D, i, e, k_axial, k_geo):
    """D[i] += k_axial e e^T + k_geo (I - e e^T), e a unit vector."""
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
def gershgorin(H, idx, S):
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
