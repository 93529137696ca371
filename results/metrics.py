"""Measures of a DEMES state, defined once for every solver (docs/metrics.md).

All take frame-centreline data: node positions (k, 3) in mm ordered along the closed frame, and
their reference (flat) arc lengths s (k,) in mm, starting at the base midpoint.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline
from typing import Sequence


def frame_at(x: np.ndarray, s: np.ndarray, length: float, s_query: np.ndarray) -> np.ndarray:
    """Positions (m, 3) at reference arc lengths ``s_query`` (mm) along the closed frame.

    A periodic cubic spline through the frame nodes in reference arc length: the frame is a
    smooth bending-stiff curve, and straight chords between nodes would differ between two
    discretisations of one curve by their sagitta (0.8 mm for a 5.8 mm chord on a 5 mm
    fillet), which is not a difference of shape.
    """
    order = np.argsort(s)
    s_sorted, x_sorted = s[order], x[order]
    knots = np.append(s_sorted, s_sorted[0] + length)
    values = np.vstack([x_sorted, x_sorted[:1]])
    spline = CubicSpline(knots, values, bc_type="periodic", axis=0)
    q = s_sorted[0] + np.mod(np.atleast_1d(s_query) - s_sorted[0], length)
    return spline(q)


def bending_angle(x: np.ndarray, s: np.ndarray, length: float, s_apex: float, size: float,
                  samples: int = 256) -> float:
    """Angle (deg) of the line base midpoint -> apex above the flat plane, seen along the base,
    counted continuously from the flat state.

    The base lies on the x axis, the flat frame in z = 0, the apex at y > 0, so the angle is
    atan2(dz, dy) modulo 360 (in the symmetry plane x = 0 of a mirror-symmetric outline): 0
    when flat, 90 when the apex is straight above the base, 180 curled over flat behind it,
    281 for a curl past that (not -79). Which turn is meant is read off the state itself: the
    midpoint of the two sides at equal fractions of their arc lengths from the base midpoint
    to the apex (equal arc lengths on a mirror-symmetric outline) runs from the base to the
    apex, its direction
    turns continuously from the flat base (unwrapped along it), and the angle is the turn of
    atan2 nearest the mean of that direction (a chord is a mean of the directions along it).
    Steps shorter than a tenth of the median step (along the held base the midline stands
    still, up to the spline's wiggle, and it slows to a stop at the apex) are skipped, and so
    are the steps before the midline first leaves the flat plane (by 1e-2 of ``size``): there
    the taped base's chords can make it step back near the corners, a reversal that unwrapping
    reads as a half turn (it read 390 deg for a 30 deg curl at 6 divisions, and 410 for 50 at 4,
    where the coarse base dipped 0.3 mm and rose 0.06 mm while stepping back).
    """
    mid, step, w, off_plane = _midline(x, s, length, s_apex, size, samples)
    chord = mid[-1] - mid[0]
    theta = float(np.degrees(np.arctan2(chord[2], chord[1])))
    keep = (w > 0.1 * np.median(w)) & (w > 1e-9 * size) & off_plane
    if not keep.any():
        return theta
    psi = np.degrees(np.unwrap(np.arctan2(step[keep, 1], step[keep, 0])))
    return nearest_turn(theta, float(np.average(psi, weights=w[keep])))


def _midline(x: np.ndarray, s: np.ndarray, length: float, s_apex: float, size: float, samples: int
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The frame's midline (:func:`bending_angle`) at ``samples`` equal fractions t of the way
    from the base midpoint to the apex (samples, 3) mm; its steps in the y-z plane (samples - 1,
    2) mm, their lengths, and whether the midline has left the flat plane (by 1e-2 of ``size``)
    by each step's end."""
    t = np.linspace(0.0, 1.0, samples)
    mid = 0.5 * (frame_at(x, s, length, t * s_apex) + frame_at(x, s, length, -t * (length - s_apex)))
    step = np.diff(mid[:, 1:], axis=0)
    return mid, step, np.hypot(step[:, 0], step[:, 1]), np.cumsum(np.abs(mid[1:, 2]) > 1e-2 * size) > 0


def segment_turns(x: np.ndarray, s: np.ndarray, length: float, s_apex: float, size: float,
                  bounds: Sequence[float], samples: int = 512) -> np.ndarray:
    """Turn (deg) of the frame's midline along each segment of a frame with windows in a row.

    The midline is :func:`bending_angle`'s, its direction psi(t) read in the y-z plane
    (atan2(dz, dy), 0 along the flat taped base, continuous from it). ``bounds`` are the
    fractions t of the way from the base to the apex where the members cross the midline, so the
    segments are the windows from the base to the apex, and segment k turns by
    psi(t_k+1) - psi(t_k) (t_0 = 0, the last t = 1): its own bending, whatever the segments
    below it did. The turns add up to the midline's whole turn, base to apex; a frame bent to a
    circular arc turns twice its bending angle.

    """
    _, step, w, off_plane = _midline(x, s, length, s_apex, size, samples)
    t_step = (np.arange(w.size) + 0.5) / w.size
    # where the midline stands still (along the taped base, at a flat top) its few moving steps
    # are the spline's wiggle, which may step back (a half turn): a direction is read from steps
    # of at least half the median step
    keep = (w > 0.5 * np.median(w)) & (w > 1e-9 * size) & off_plane
    if not keep.any():
        return np.zeros(len(bounds) + 1)
    psi = np.degrees(np.unwrap(np.arctan2(step[keep, 1], step[keep, 0])))
    t = np.concatenate([[0.0], np.sort(np.asarray(bounds, float)), [1.0]])
    # flat (0) before the midline leaves the plane; the direction at the ends from the end steps
    direction = np.interp(t, np.concatenate([[0.0], t_step[keep]]), np.concatenate([[0.0], psi]))
    return np.diff(direction)


def outline_bending_angle(x: np.ndarray, s: np.ndarray, outline) -> float:
    """:func:`bending_angle` of frame nodes x (k, 3) mm at reference arc lengths s on ``outline``
    (a ``scenes`` outline: its length, apex and side length)."""
    return bending_angle(x, s, outline.length, outline.apex_arc_length(), outline.side_length)


FLAT_ANGLE = 0.01
"""deg: a bending angle within this of 0 is the flat branch (the apex 8 um off the plane for the
paper's 45 mm height), far below any curl and far above the round-off of a relaxed flat state."""

FLAT_LIFT = 1e-4
"""A frame nowhere farther than this fraction of its side from the flat plane is on the flat
branch whatever its angle reads (a frame collapsed in its plane with the apex pulled behind
the base reads atan2(0, -y) = 180 deg)."""

WHOLE_TURN = 360.0
"""deg: bending angles are read in (-WHOLE_TURN, WHOLE_TURN). The line base -> apex of a frame of
constant curvature has turned half the frame's turn; at a whole turn the frame has come round
onto its own base. A reading beyond counts the turns of a path, not where the apex is."""

HALF_TURN = 180.0
"""deg: past half a turn the apex has gone over the base, behind it, to the other side of the flat
plane (below it on the up branch)."""


def past_half_turn(theta: float) -> str | None:
    """The words for a curl past half a turn (:data:`HALF_TURN` < |theta| < :data:`WHOLE_TURN`,
    deg, continuous from flat), None for any other angle: a reader who sees 253 deg is told
    where the apex is.

    >>> past_half_turn(253.24)
    'curled past half a turn: the apex is behind the base and below the flat plane (253.2 deg = 180 + 73.2)'
    >>> past_half_turn(-200.0), past_half_turn(179.0)
    ('curled past half a turn: the apex is behind the base and above the flat plane (-200.0 deg = -180 - 20.0)', None)
    """
    if not (np.isfinite(theta) and HALF_TURN < abs(theta) < WHOLE_TURN):
        return None
    side, half = ("below", "180 +") if theta > 0 else ("above", "-180 -")
    return (f"curled past half a turn: the apex is behind the base and {side} the flat plane "
            f"({theta:.1f} deg = {half} {abs(theta) - HALF_TURN:.1f})")


BRANCHES = ("up", "down", "flat", "twisted")
"""The branch names: the side of the flat plane the apex went to from the flat state; the flat
state; a frame out of its plane whose apex did not tilt (a twist)."""


def branch(theta: float, lift: float = 1.0) -> str:
    """The branch of a state of bending angle ``theta`` (deg, counted continuously from flat)
    whose frame is at most ``lift`` (a fraction of the side) from the flat plane: 'up' (the
    apex went to +z from the flat state, theta > 0), 'down' (to -z, theta < 0), 'flat'
    (:data:`FLAT_LIFT`) or 'twisted' (out of the plane, the angle within :data:`FLAT_ANGLE`
    of 0); 'unknown' for a NaN angle.

    The sign of the continuous angle, not of the apex height: a curl past 180 deg has the apex
    below the plane behind the base, and it is still the branch that went up.

    >>> branch(200.0), branch(-30.0), branch(0.0, lift=0.0), branch(-180.0, lift=0.0), branch(0.0, lift=0.2)
    ('up', 'down', 'flat', 'flat', 'twisted')
    """
    if not np.isfinite(theta):
        return "unknown"
    if lift < FLAT_LIFT:
        return "flat"
    if abs(theta) < FLAT_ANGLE:
        return "twisted"
    return "up" if theta > 0 else "down"


UNREADABLE = {
    "not_finite": "the frame's position is not finite",
    "frame_crossing": "the frame passes through itself",
    "film_crossing": "the film passes through itself or the frame through the film",
    "over_a_turn": "the line base -> apex has turned a whole turn or more from flat",
}
"""The named reasons a bending angle cannot be read, in words."""


def unreadable_angle(theta: float, crossing: str | None = None) -> str | None:
    """The name (a key of :data:`UNREADABLE`) of why a bending angle ``theta`` (deg, continuous
    from flat) cannot be read, or None if it can.

    The angle of a state whose frame or film has passed through itself (``crossing``:
    'frame_crossing' or 'film_crossing', see :mod:`results.crossing`) is not a shape the
    structure can take, and a turn of a whole turn or more (:data:`WHOLE_TURN`) is no angle of
    the apex: the turn counted is then an artefact of the path.

    >>> unreadable_angle(365.7), unreadable_angle(-120.0), unreadable_angle(-180.0, "frame_crossing")
    ('over_a_turn', None, 'frame_crossing')
    """
    if not np.isfinite(theta):
        return "not_finite"
    if crossing:
        return crossing
    if abs(theta) >= WHOLE_TURN:
        return "over_a_turn"
    return None


def nearest_turn(angle: float, previous: float) -> float:
    """``angle`` (deg) plus the whole turns that bring it nearest ``previous``: a sweep's next
    state is read as the continuation of the one before.

    >>> nearest_turn(-79.0, previous=266.8)        # a curl past 270 deg, not a dip
    281.0
    >>> nearest_turn(10.0, previous=-20.0)
    10.0
    """
    return float(angle + 360.0 * np.round((previous - angle) / 360.0))


def shape_error(
    x_a: np.ndarray,
    s_a: np.ndarray,
    x_b: np.ndarray,
    s_b: np.ndarray,
    length: float,
    side_length: float,
    samples: int = 512,
) -> tuple[float, float]:
    """RMS and max distance between two frame curves at equal reference arc length, / side length."""
    s = np.linspace(0.0, length, samples, endpoint=False)
    d = np.linalg.norm(frame_at(x_a, s_a, length, s) - frame_at(x_b, s_b, length, s), axis=1)
    return float(np.sqrt(np.mean(d**2)) / side_length), float(d.max() / side_length)


def resample(x: np.ndarray, s: np.ndarray, length: float, samples: int) -> np.ndarray:
    """Frame curve (samples, 3) at equally spaced reference arc lengths from the base midpoint."""
    return frame_at(x, s, length, np.linspace(0.0, length, samples, endpoint=False))
