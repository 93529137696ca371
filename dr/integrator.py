"""Leapfrog time stepping with a damping scheme (``dr.damping``), compiled; dt = 1, masses
scaled to it. The loop works on a named :class:`State` (arrays, changed in place) with named
:class:`Settings`.

Masses are symmetric 3x3 per node, stored as (xx, yy, zz, xy, xz, yz). With ``tensor`` masses
they are built from the direction-dependent stiffness of links and cables (EA/L0 e e^T along,
T/L across) plus an isotropic part for beams; a frame node is then heavy only along the frame,
not across it, which is what limits the step count. They are rebuilt whenever the nodes may
have moved ``drift`` mm since the last rebuild (every step while they move fast): a light
frame node moving across its links turns them by degrees per step, and a stale tensor would
let the axial stiffness leak into the light direction. Without, they are Barnes' scalar
masses f dt^2/2 S, updated every ``mass_every`` steps. With a frame mass
(:mod:`dr.frame_mass`), the frame's nodes share one sparse mass matrix instead, refreshed when
the nodes may have moved ``frame_drift`` mm since its last refresh, when a node's edge frame
has turned ``frame_turn`` rad, and at every restart.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from . import damping as dmp
from . import frame_mass as fmm
from .contact import closest_pair, pairs_within
from .kernels import gradient, stiffness

# why a chunk of steps ended
STEPS_DONE, CONTACT, CONVERGED, NONFINITE, RUNAWAY, LEASHED = range(6)

FORCE_JUMP = 5.0
"""A step after which the largest element force is this many times the last step's (and above
the force floor) went where the masses built before it do not bound the stiffness: it is taken
back, and the motion restarts from rest with masses built where it was. The masses bound the
Hessian at the state they are built at, not a step away: a frame edge's material frame comes
from its bond point, and where the film at the bond line is slack nothing keeps that point off
the frame's centreline; a step across it turns the edge's frame half a turn and its torsion
energy jumps by orders of magnitude (measured: 0.012 -> 893 N mm in one step of 0.3 mm on a
thin-film octagon's 1 mm fillet edge). At 10 a 4-division version of that octagon still crept
up in energy over 20,000 steps; at 3 the paper's clustered DEMES restarted once more than it
needs; at 5 neither, and the paper's DEMES at 1.3 (clustered, triangles) and the wide rectangle take
the same steps as without."""


class State(NamedTuple):
    """The time loop's arrays (changed in place); n free-or-fixed nodes, m with virtual ones."""

    X: np.ndarray  # (m, 3) positions x(t), mm
    V: np.ndarray  # (n, 3) velocities v(t - dt/2), mm per step
    R: np.ndarray  # (n, 3) residual R(t) = loads - dE/dx at free DOFs, N
    G: np.ndarray  # (m, 3) energy gradient (scratch), N
    M: np.ndarray  # (n, 6) masses, N per mm (dt = 1)
    Minv: np.ndarray  # (n, 6) their inverses
    A: np.ndarray  # (n, 3) accelerations M^-1 R(t) at free DOFs, mm per step^2
    S: np.ndarray  # (m,) isotropic stiffness bounds, N/mm
    D: np.ndarray  # (m, 6) directional stiffness blocks ((0, 6) for scalar masses), N/mm
    free: np.ndarray  # (n, 3) 1 at free DOFs, 0 at fixed
    loads: np.ndarray  # (n, 3) N
    watched: np.ndarray  # (n,) bool: nodes the contact check follows
    segments: np.ndarray  # (k, 2) node pairs of the contact chain
    X0: np.ndarray  # (n, 3) positions at the run's start (viscous damping's displacement)
    R_prev: np.ndarray  # (n, 3) residual one step earlier (viscous damping's stiffness estimate)
    scratch: np.ndarray  # (2,) FIRE's mixing and uphill-free step count


class Settings(NamedTuple):
    """The time loop's settings."""

    damping: int  # dr.damping.KINETIC, VISCOUS or FIRE
    half_safety: float  # f/2 of M = f dt^2/2 K
    max_steps: int
    closed: bool  # the contact chain is closed
    contact_distance: float  # mm (0: no contact check)
    tol: float  # relative residual
    force_floor: float  # smallest force scale, N
    runaway: float  # largest step of a stable run, mm
    mass_every: int  # steps between refreshes of the stiffness bounds
    drift: float  # mm the nodes may move before the tensor masses are rebuilt (0: every step)
    frame_drift: float  # mm the nodes may move before the frame mass is refreshed
    frame_turn: float  # rad a node's edge frame may turn before the frame mass is refreshed
    leash: float  # mm a node may get from its start before the run stops (0: no limit)


def new_state(X: np.ndarray, free: np.ndarray, loads: np.ndarray, tensor: bool,
              watched: np.ndarray, segments: np.ndarray) -> State:
    """A state at rest at X with zeroed work arrays."""
    n = free.shape[0]
    return State(X=X, V=np.zeros((n, 3)), R=np.zeros((n, 3)), G=np.zeros_like(X), M=np.zeros((n, 6)),
                 Minv=np.zeros((n, 6)), A=np.zeros((n, 3)), S=np.zeros(X.shape[0]), D=np.zeros((X.shape[0] if tensor else 0, 6)),
                 free=free, loads=loads, watched=watched, segments=segments, X0=X[:n].copy(),
                 R_prev=np.zeros((n, 3)), scratch=np.array([dmp.FIRE_ALPHA0, 0.0]))


@njit(cache=True, error_model="numpy", inline="always")
def _nanmax(a, b):
    """max(a, b) that keeps a NaN (numba's max(a, nan) returns a, which hid NaN states)."""
    return b if (b > a or b != b) else a


@njit(cache=True, error_model="numpy")
def collect(R, G, loads, free, n):
    """R = (loads - G) at free DOFs of the n real nodes. Returns max |R_i|, N."""
    rmax2 = 0.0
    for i in range(n):
        r2 = 0.0
        for c in range(3):
            r = (loads[i, c] - G[i, c]) * free[i, c]
            R[i, c] = r
            r2 += r * r
        rmax2 = _nanmax(rmax2, r2)
    return math.sqrt(rmax2)


@njit(cache=True, error_model="numpy")
def residual(st, P):
    """st.R = (loads - dE/dx) at free DOFs. Returns (largest element force, max |R_i|), N."""
    fmax = gradient(st.X, P, st.G, st.D)
    return fmax, collect(st.R, st.G, st.loads, st.free, P.n)


@njit(cache=True, error_model="numpy")
def build_masses(st, half_safety, frame_pos):
    """M = f/2 (D + S I) per node, decoupled from fixed axes, and its inverse; not at the frame
    mass's nodes (``frame_pos`` >= 0), whose mass is :func:`refresh_frame`'s."""
    D, S, free, M, Minv = st.D, st.S, st.free, st.M, st.Minv
    for i in range(M.shape[0]):
        if frame_pos[i] >= 0:
            continue
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


@njit(cache=True, error_model="numpy")
def refresh_frame(st, P, fm, half_safety):
    """Assemble and factorise the frame mass at st.X (st.D, st.S current); its diagonal goes
    into st.M for the dampings that read a DOF's mass. Returns -1, or the model node that
    nothing resists."""
    bad = fmm.refresh(st.X, P, st.D, st.S, fm, half_safety)
    if bad < 0:
        fmm.diagonal(fm, st.M)
    return bad


@njit(cache=True, error_model="numpy")
def accelerations(st, fm, n):
    """st.A = M^-1 R: node-local 3x3 masses, and the frame mass's nodes by its factor."""
    A, R, Minv, free, pos = st.A, st.R, st.Minv, st.free, fm.pos
    for i in range(n):
        if pos[i] >= 0:
            continue
        a = dmp.mul(Minv, i, R[i, 0], R[i, 1], R[i, 2])
        for c in range(3):
            A[i, c] = a[c] * free[i, c]
    if fm.nodes.shape[0] > 0:
        fmm.solve(fm, R, A, free)


@njit(cache=True, error_model="numpy")
def momentum(st, fm, n):
    """Largest nodal momentum |M v| at free nodes, N (dt = 1)."""
    M, V, pos = st.M, st.V, fm.pos
    best2 = 0.0
    for i in range(n):
        if pos[i] >= 0:
            continue
        m = dmp.mul(M, i, V[i, 0], V[i, 1], V[i, 2])
        best2 = _nanmax(best2, m[0] * m[0] + m[1] * m[1] + m[2] * m[2])
    if fm.nodes.shape[0] > 0:
        best2 = _nanmax(best2, fmm.momentum_max2(fm, V))
    return math.sqrt(best2)


@njit(cache=True, error_model="numpy")
def start(st, P, fm, half_safety):
    """The first half step from rest: v(dt/2) = dt/2 M^-1 R, x(dt), and R, masses and
    accelerations there. Returns -1, or a node the frame mass found unresisted."""
    st.R_prev[:, :] = st.R
    accelerations(st, fm, P.n)
    dmp.accelerate(st.V, st.A, P.n, 0.0, 0.5)
    for i in range(P.n):
        for c in range(3):
            st.X[i, c] += st.V[i, c]
    residual(st, P)
    bad = -1
    if st.D.shape[0] > 0:
        build_masses(st, half_safety, fm.pos)
        bad = refresh_frame(st, P, fm, half_safety)
    accelerations(st, fm, P.n)
    return bad


@njit(cache=True, error_model="numpy")
def _rebuild(st, P, fm, half_safety, bounds):
    """The residual, masses and accelerations at st.X after the nodes were moved for a restart
    (back to a kinetic-energy peak, or a step taken back); with ``bounds`` the stiffness bounds
    are refreshed first, and the masses of every kind with them. Returns -1, or the model node
    the frame mass found unresisted."""
    tensor = st.D.shape[0] > 0
    if bounds:
        stiffness(st.X, P, st.S, not tensor)
    gradient(st.X, P, st.G, st.D)
    collect(st.R, st.G, st.loads, st.free, P.n)
    if tensor or bounds:
        build_masses(st, half_safety, fm.pos)
    bad = refresh_frame(st, P, fm, half_safety) if fm.nodes.shape[0] > 0 else -1
    if bad < 0:
        accelerations(st, fm, P.n)
    return bad


@njit(cache=True, error_model="numpy")
def _farthest2(X, X0, n):
    """The largest squared distance of a real node from its place in X0, mm^2."""
    far = 0.0
    for i in range(n):
        d2 = 0.0
        for c in range(3):
            d = X[i, c] - X0[i, c]
            d2 += d * d
        far = _nanmax(far, d2)
    return far


@njit(cache=True, error_model="numpy")
def run(st, P, cfg, fm):
    """Advance up to ``cfg.max_steps`` leapfrog steps with the damping ``cfg.damping``.

    On entry st.X[:n] is x(t), st.V is v(t - dt/2), st.R is R(t) and st.M, st.Minv the masses
    at x(t). When the damping stops the motion it restarts from rest, v = dt/2 M^-1 R.

    Stops early when (a) the residual and the momentum |M v|/dt are both below ``tol`` times
    the largest element force (at least ``force_floor``), (b) two non-neighbouring
    ``segments`` (node pairs of a chain, ``closed`` or not) come closer than
    ``contact_distance`` mm, (c) a value is not finite, or (d) a node moves more than
    ``runaway`` mm in one step, or (e) a node gets farther than ``leash`` mm (if > 0) from its
    place at the run's start (st.X0), tested whenever the nodes may have moved a tenth of it.
    Contact is tested with a Verlet list: pairs within reach
    d + 2 skin are listed again whenever the ``watched`` nodes may have moved a skin, and the
    listed pairs are tested whenever they may have moved d/4, so nothing passes through
    unseen. The stiffness bounds behind the masses are refreshed every ``mass_every`` steps,
    and tensor masses rebuilt once the nodes may have moved ``cfg.drift`` mm (the sum of the
    largest step of each step) since the last rebuild; the frame mass ``fm``
    (:mod:`dr.frame_mass`, possibly empty) once they may have moved ``cfg.frame_drift`` mm or
    an edge frame has turned ``cfg.frame_turn`` rad (checked at each tensor rebuild), and at
    every restart from a moved-back state.

    Returns (reason, steps, restarts, largest element force, max residual).
    """
    # Records are unpacked here once: a compiled call that takes a record increments the
    # reference count of each of its arrays (atomically) on entry and decrements it on exit
    # unless numba can prove it needless, which costs about 0.5 us per record per call; the
    # per-step calls below take arrays or records that numba prunes (docs/dynamic_relaxation.md, "Reference counting").
    n = P.n
    X, V, R, G, D = st.X, st.V, st.R, st.G, st.D
    loads, free, watched, segments = st.loads, st.free, st.watched, st.segments
    scheme = cfg.damping
    tensor = st.D.shape[0] > 0
    no_blocks = np.zeros((0, 6))  # an empty D: the gradient without the tensor blocks
    contact_distance = cfg.contact_distance
    steps = 0
    restarts = 0
    fmax, rmax = 0.0, 0.0
    check = segments.shape[0] > 0
    skin = 10.0 * contact_distance
    candidates = (pairs_within(X, segments, cfg.closed, contact_distance + 2.0 * skin) if check
                  else np.zeros((0, 2), np.int64))
    moved_list = 0.0
    moved_check = 0.0
    drifted = math.inf  # rebuild at the first step
    frame = fm.nodes.shape[0] > 0
    frame_drifted = 0.0
    fmax_last = math.inf  # no step to compare the first with
    taken_back = False
    leash = cfg.leash
    moved_leash = 0.0
    while steps < cfg.max_steps:
        if taken_back:
            how = dmp.MOVED_BACK  # rebuilt below where the step started, bounds included
        elif scheme == dmp.VISCOUS:
            how = dmp.viscous(st, n)
        elif scheme == dmp.FIRE:
            how = dmp.fire(st, n)
        else:
            how = dmp.kinetic(st, n)
        if how != dmp.GOING:
            restarts += 1
            if how == dmp.MOVED_BACK:
                frame_drifted = 0.0
                if _rebuild(st, P, fm, cfg.half_safety, taken_back) >= 0:
                    return NONFINITE, steps, restarts, fmax, rmax
                taken_back = False
            dmp.accelerate(V, st.A, n, 0.0, 0.5)
        step_max2 = 0.0
        watch_max2 = 0.0
        for i in range(n):
            v2 = 0.0
            for c in range(3):
                X[i, c] += V[i, c]
                v2 += V[i, c] * V[i, c]
            step_max2 = _nanmax(step_max2, v2)
            if watched[i]:
                watch_max2 = _nanmax(watch_max2, v2)
        steps += 1
        refresh = steps % cfg.mass_every == 0
        if refresh:
            stiffness(X, P, st.S, not tensor)
        step_max = math.sqrt(step_max2)
        drifted += step_max
        frame_drifted += step_max
        frame_refresh = frame and frame_drifted > cfg.frame_drift
        rebuild = tensor and (drifted > cfg.drift or frame_refresh)
        if rebuild:
            drifted = 0.0
            if frame and not frame_refresh:
                frame_refresh = fmm.follow(X, fm) > cfg.frame_turn
        fmax = gradient(X, P, G, D if rebuild or not tensor else no_blocks)
        if fmax > FORCE_JUMP * max(fmax_last, cfg.force_floor):
            for i in range(n):  # back to x(t) = x(t+dt) - dt v(t+dt/2)
                for c in range(3):
                    X[i, c] -= V[i, c]
            taken_back = True
            fmax_last = math.inf
            continue
        fmax_last = fmax
        rmax = collect(R, G, loads, free, n)
        if rebuild or refresh:
            build_masses(st, cfg.half_safety, fm.pos)
        if frame_refresh:
            frame_drifted = 0.0
            if refresh_frame(st, P, fm, cfg.half_safety) >= 0:
                return NONFINITE, steps, restarts, fmax, rmax
        accelerations(st, fm, n)
        moved_list += math.sqrt(watch_max2)
        moved_check += math.sqrt(watch_max2)
        if not (math.isfinite(rmax) and math.isfinite(step_max)):
            return NONFINITE, steps, restarts, fmax, rmax
        if step_max > cfg.runaway:
            return RUNAWAY, steps, restarts, fmax, rmax
        if leash > 0.0:
            moved_leash += step_max
            if moved_leash > 0.1 * leash:
                moved_leash = 0.0
                if _farthest2(X, st.X0, n) > leash * leash:
                    return LEASHED, steps, restarts, fmax, rmax
        scale = max(fmax, cfg.force_floor)
        if rmax <= cfg.tol * scale and momentum(st, fm, n) <= cfg.tol * scale:
            return CONVERGED, steps, restarts, fmax, rmax
        if check and moved_check > 0.25 * contact_distance:
            moved_check = 0.0
            if moved_list > skin:
                moved_list = 0.0
                candidates = pairs_within(X, segments, cfg.closed, contact_distance + 2.0 * skin)
            if closest_pair(X, segments, candidates, cfg.closed, contact_distance)[0] < contact_distance:
                return CONTACT, steps, restarts, fmax, rmax
    return STEPS_DONE, steps, restarts, fmax, rmax
