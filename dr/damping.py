"""Damping schemes of the DR time loop, one compiled unit each, all with the same signature.

Each takes the loop's :class:`dr.integrator.State` at x(t) (positions, v(t - dt/2), the
residual R(t), the masses there and the accelerations A = M^-1 R(t) they give) and the number n of real nodes (not the element record,
whose reference counting would cost more than a small model's step, see
:func:`dr.integrator.run`), and sets V to v(t + dt/2); dt = 1, masses scaled to it. It
returns GOING (no reset), RESTART (the motion stops: the loop restarts it from rest at x,
v = dt/2 A) or MOVED_BACK (the same after moving the nodes: R and the masses are
recomputed first).

- ``kinetic`` (Barnes): undamped motion, stopped at every kinetic-energy peak, where the
  nodes go back to the estimated peak and restart from rest.
- ``viscous`` (Underwood 1983): v(t+dt/2) = (2 - c)/(2 + c) v(t-dt/2) + 2/(2 + c) M^-1 R(t),
  with the critical coefficient c = 2 sqrt(x^T K x / x^T M x) of the current mode, the
  displacement x since the run started, K the diagonal of the stiffness estimated from the
  change of the residual over the last step, -dR/dx.
- ``fire`` (Bitzek et al. 2006): undamped steps whose velocity is turned towards the
  acceleration M^-1 R, v = (1 - a) v + a |v| a_hat, with a mixing a that decays while the
  power R.v stays positive; motion stopped when it turns negative.
"""

from __future__ import annotations

import math

from numba import njit

KINETIC, VISCOUS, FIRE = range(3)
SCHEMES = {"kinetic": KINETIC, "viscous": VISCOUS, "fire": FIRE}

FIRE_ALPHA0, FIRE_F_ALPHA, FIRE_N_MIN = 0.1, 0.99, 5
"""FIRE's mixing at a restart, its decay per uphill-free step, and the steps before it decays
(Bitzek et al.'s values)."""

VISCOUS_C_MAX = 1.9
"""Upper bound of Underwood's coefficient (c = 2 stops the motion dead)."""

GOING, RESTART, MOVED_BACK = range(3)

# scratch slots kept between steps and chunks
ALPHA, CALM = 0, 1


@njit(cache=True, error_model="numpy", inline="always")
def mul(A, i, v0, v1, v2):
    """The symmetric 3x3 block i of A, stored (xx, yy, zz, xy, xz, yz), times v."""
    return (A[i, 0] * v0 + A[i, 3] * v1 + A[i, 4] * v2,
            A[i, 3] * v0 + A[i, 1] * v1 + A[i, 5] * v2,
            A[i, 4] * v0 + A[i, 5] * v1 + A[i, 2] * v2)


@njit(cache=True, error_model="numpy")
def accelerate(V, A, n, factor, gain):
    """V = factor V + gain A (A = M^-1 R, zero at fixed DOFs)."""
    for i in range(n):
        for c in range(3):
            V[i, c] = factor * V[i, c] + gain * A[i, c]


@njit(cache=True, error_model="numpy")
def kinetic(st, n):
    """Barnes' kinetic damping. The peak is detected from the change of kinetic energy over
    the step measured with this step's masses, dKE = (v(t-dt/2) + dt/2 M^-1 R(t)) . R(t) dt,
    which stays meaningful when the masses change (and holds for any SPD mass matrix). At a
    peak the nodes go back to x* = x(t+dt) - 1.5 dt v(t+dt/2) + dt^2/2 M^-1 R(t) (and restart
    from rest there)."""
    X, V, R, A = st.X, st.V, st.R, st.A
    dke = 0.0
    for i in range(n):
        for c in range(3):
            dke += (V[i, c] + 0.5 * A[i, c]) * R[i, c]
    accelerate(V, A, n, 1.0, 1.0)
    if dke >= 0.0:
        return GOING
    for i in range(n):
        for c in range(3):
            X[i, c] += -0.5 * V[i, c] + 0.5 * A[i, c]
    return MOVED_BACK


@njit(cache=True, error_model="numpy")
def viscous(st, n):
    """Underwood's adaptive viscous damping (module docstring); the mass of a DOF is the
    diagonal of its mass matrix (at the frame mass's nodes, the diagonal of M_F)."""
    X, V, R, M, free, R_prev, X0 = st.X, st.V, st.R, st.M, st.free, st.R_prev, st.X0
    xkx, xmx = 0.0, 0.0
    for i in range(n):
        for c in range(3):
            if free[i, c] == 0.0:
                continue
            u = X[i, c] - X0[i, c]
            if V[i, c] != 0.0:
                xkx += u * u * (R_prev[i, c] - R[i, c]) / V[i, c]
            xmx += u * u * M[i, c]
    c_crit = 0.0
    if xkx > 0.0 and xmx > 0.0:
        c_crit = min(2.0 * math.sqrt(xkx / xmx), VISCOUS_C_MAX)
    R_prev[:, :] = R
    accelerate(V, st.A, n, (2.0 - c_crit) / (2.0 + c_crit), 2.0 / (2.0 + c_crit))
    return GOING


@njit(cache=True, error_model="numpy")
def fire(st, n):
    """FIRE at a fixed step (the masses already sit at the stability bound of dt = 1)."""
    V, R, A, scratch = st.V, st.R, st.A, st.scratch
    accelerate(V, A, n, 1.0, 1.0)
    power, v2, a2 = 0.0, 0.0, 0.0
    for i in range(n):
        for c in range(3):
            power += R[i, c] * V[i, c]
            v2 += V[i, c] * V[i, c]
            a2 += A[i, c] * A[i, c]
    if power <= 0.0:
        scratch[ALPHA], scratch[CALM] = FIRE_ALPHA0, 0.0
        return RESTART
    alpha = scratch[ALPHA]
    if a2 > 0.0:
        k = alpha * math.sqrt(v2 / a2)
        accelerate(V, A, n, 1.0 - alpha, k)
    scratch[CALM] += 1.0
    if scratch[CALM] > FIRE_N_MIN:
        scratch[ALPHA] = alpha * FIRE_F_ALPHA
    return GOING
