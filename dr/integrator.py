"""Leapfrog time stepping with kinetic damping (Barnes), compiled; dt = 1, masses scaled to it.

Masses are symmetric 3x3 per node, stored as (xx, yy, zz, xy, xz, yz). With ``tensor`` masses
they are built from the direction-dependent stiffness of links and cables (EA/L0 e e^T along,
T/L across) plus an isotropic part for beams; a frame node is then heavy only along the frame,
not across it, which is what limits the step count. They are rebuilt every step: a light
frame node moving across its links turns them by degrees per step, and a stale tensor would
let the axial stiffness leak into the light direction. The kinetic-energy peak is therefore
detected from the change of kinetic energy over one step measured with that step's masses,
dKE = (v(t-dt/2) + dt/2 M^-1 R(t)) . R(t) dt, which stays meaningful when masses change.
Without, they are Barnes' scalar masses f dt^2/2 S, updated by the caller between chunks.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .contact import closest_pair, pairs_within
from .kernels import Packed, gradient, stiffness

# why a chunk of steps ended
STEPS_DONE, CONTACT, CONVERGED, NONFINITE, RUNAWAY = range(5)


@njit(cache=True, error_model="numpy", inline="always")
def _nanmax(a, b):
    """max(a, b) that keeps a NaN (numba's max(a, nan) returns a, which hid NaN states)."""
    return b if (b > a or b != b) else a


@njit(cache=True, error_model="numpy")
def residual(X, P, G, D, loads, free, R):
    """R = (loads - dE/dx) at free DOFs. Returns (largest element force, max |R_i|), N."""
    fmax = gradient(X, P, G, D)
    rmax2 = 0.0
    for i in range(P.n):
        r2 = 0.0
        for c in range(3):
            r = (loads[i, c] - G[i, c]) * free[i, c]
            R[i, c] = r
            r2 += r * r
        rmax2 = _nanmax(rmax2, r2)
    return fmax, math.sqrt(rmax2)


@njit(cache=True, error_model="numpy")
def build_masses(D, S, free, half_safety, M, Minv):
    """M = f/2 (D + S I) per node, decoupled from fixed axes, and its inverse."""
    for i in range(M.shape[0]):
        s = S[i]
        if D.shape[0] > 0:
            # a direction without stiffness (a slack planar net, out of its plane) gets a
            # sliver of the node's mass rather than none
            s += 1e-6 * (D[i, 0] + D[i, 1] + D[i, 2])
            a, b, c = D[i, 0] + s, D[i, 1] + s, D[i, 2] + s
            d = D[i, 3] * free[i, 0] * free[i, 1]
            e = D[i, 4] * free[i, 0] * free[i, 2]
            f = D[i, 5] * free[i, 1] * free[i, 2]
        else:
            a, b, c, d, e, f = s, s, s, 0.0, 0.0, 0.0
        a, b, c, d, e, f = (half_safety * a, half_safety * b, half_safety * c,
                            half_safety * d, half_safety * e, half_safety * f)
        if a <= 0.0 or b <= 0.0 or c <= 0.0:
            a, b, c, d, e, f = 1.0, 1.0, 1.0, 0.0, 0.0, 0.0  # a fixed node without elements
        M[i, 0], M[i, 1], M[i, 2], M[i, 3], M[i, 4], M[i, 5] = a, b, c, d, e, f
        ca, cb, cc = b * c - f * f, a * c - e * e, a * b - d * d
        cd, ce, cf = e * f - c * d, d * f - b * e, d * e - a * f
        det = a * ca + d * cd + e * ce
        Minv[i, 0], Minv[i, 1], Minv[i, 2] = ca / det, cb / det, cc / det
        Minv[i, 3], Minv[i, 4], Minv[i, 5] = cd / det, ce / det, cf / det


@njit(cache=True, error_model="numpy", inline="always")
def _mul(A, i, v0, v1, v2):
    return (A[i, 0] * v0 + A[i, 3] * v1 + A[i, 4] * v2,
            A[i, 3] * v0 + A[i, 1] * v1 + A[i, 5] * v2,
            A[i, 4] * v0 + A[i, 5] * v1 + A[i, 2] * v2)


@njit(cache=True, error_model="numpy")
def _accelerate(V, R, Minv, free, n, factor):
    """V = factor * V + Minv R at free DOFs."""
    for i in range(n):
        a = _mul(Minv, i, R[i, 0], R[i, 1], R[i, 2])
        for c in range(3):
            V[i, c] = (factor * V[i, c] + a[c]) * free[i, c]


@njit(cache=True, error_model="numpy")
def run(X, V, R, M, Minv, S, D, free, loads, P: Packed, G, half_safety, max_steps,
        segments, closed, contact_distance, watched, tol, force_floor, runaway, mass_every):
    """Advance up to ``max_steps`` leapfrog steps with kinetic damping.

    On entry X[:n] is x(t), V is v(t - dt/2), R is R(t) and M, Minv the masses at x(t). When
    the kinetic energy falls (a peak has passed) the nodes go back to the estimated peak,
    x* = x(t+dt) - 1.5 dt v(t+dt/2) + dt^2/2 M^-1 R(t), velocities are zeroed and the motion
    restarts with v = dt/2 M^-1 R(x*).

    Stops early when (a) the residual and the momentum |M v|/dt are both below ``tol`` times
    the largest element force (at least ``force_floor``), (b) two non-neighbouring
    ``segments`` (node pairs of a chain, ``closed`` or not) come closer than
    ``contact_distance`` mm, (c) a value is not finite, or (d) a node moves more than
    ``runaway`` mm in one step. Contact is tested with a Verlet list: pairs within reach
    d + 2 skin are listed again whenever the ``watched`` nodes (bool, (n,)) may have moved a
    skin, and the listed pairs are tested whenever they may have moved d/4, so nothing passes
    through unseen. The stiffness bounds behind the masses are refreshed every
    ``mass_every`` steps.

    Returns (reason, steps, peaks, largest element force, max residual).
    """
    n = P.n
    tensor = D.shape[0] > 0
    steps = 0
    peaks = 0
    fmax, rmax = 0.0, 0.0
    check = segments.shape[0] > 0
    skin = 10.0 * contact_distance
    candidates = pairs_within(X, segments, closed, contact_distance + 2.0 * skin) if check else np.zeros((0, 2), np.int64)
    moved_list = 0.0
    moved_check = 0.0
    while steps < max_steps:
        dke = 0.0
        for i in range(n):
            a = _mul(Minv, i, R[i, 0], R[i, 1], R[i, 2])
            for c in range(3):
                dke += (V[i, c] + 0.5 * a[c]) * R[i, c]
        _accelerate(V, R, Minv, free, n, 1.0)
        if dke < 0.0:
            peaks += 1
            for i in range(n):
                a = _mul(Minv, i, R[i, 0], R[i, 1], R[i, 2])
                for c in range(3):
                    X[i, c] += -0.5 * V[i, c] + 0.5 * a[c] * free[i, c]
            residual(X, P, G, D, loads, free, R)
            if tensor:
                build_masses(D, S, free, half_safety, M, Minv)
            _accelerate(V, R, Minv, free, n, 0.0)
            for i in range(n):
                for c in range(3):
                    V[i, c] *= 0.5
        step_max2 = 0.0
        watch_max2 = 0.0
        mom_max2 = 0.0
        for i in range(n):
            v2 = 0.0
            for c in range(3):
                X[i, c] += V[i, c]
                v2 += V[i, c] * V[i, c]
            step_max2 = _nanmax(step_max2, v2)
            if watched[i]:
                watch_max2 = _nanmax(watch_max2, v2)
            m = _mul(M, i, V[i, 0], V[i, 1], V[i, 2])
            mom_max2 = _nanmax(mom_max2, m[0] * m[0] + m[1] * m[1] + m[2] * m[2])
        steps += 1
        refresh = steps % mass_every == 0
        if refresh:
            stiffness(X, P, S, not tensor)
        fmax, rmax = residual(X, P, G, D, loads, free, R)
        if tensor or refresh:
            build_masses(D, S, free, half_safety, M, Minv)
        step_max = math.sqrt(step_max2)
        moved_list += math.sqrt(watch_max2)
        moved_check += math.sqrt(watch_max2)
        if not (math.isfinite(rmax) and math.isfinite(step_max) and math.isfinite(mom_max2)):
            return NONFINITE, steps, peaks, fmax, rmax
        if step_max > runaway:
            return RUNAWAY, steps, peaks, fmax, rmax
        scale = max(fmax, force_floor)
        if rmax <= tol * scale and math.sqrt(mom_max2) <= tol * scale:
            return CONVERGED, steps, peaks, fmax, rmax
        if check and moved_check > 0.25 * contact_distance:
            moved_check = 0.0
            if moved_list > skin:
                moved_list = 0.0
                candidates = pairs_within(X, segments, closed, contact_distance + 2.0 * skin)
            if closest_pair(X, segments, candidates)[0] < contact_distance:
                return CONTACT, steps, peaks, fmax, rmax
    return STEPS_DONE, steps, peaks, fmax, rmax
