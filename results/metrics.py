"""Measures of a DEMES state, defined once for every solver (docs/metrics.md).

All take frame-centreline data: node positions (k, 3) in mm ordered along the closed frame, and
their reference (flat) arc lengths s (k,) in mm, starting at the base midpoint.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline


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


def bending_angle(apex: np.ndarray, base_mid: np.ndarray) -> float:
    """Angle (deg) of the line base midpoint -> apex above the flat plane, in the symmetry plane.

    The symmetry plane is x = 0 (the base lies on the x axis, the flat frame in z = 0, the apex
    at y > 0), so the angle is atan2(dz, dy): 0 when flat, 90 when the apex is straight above
    the base, above 90 once it curls past vertical. A DEMES curls up past vertical (and a
    curled frame past 180 deg, apex below the base plane behind it) or dips a little down,
    so angles are given in [-90, 270) deg rather than wrapping at 180.

    >>> bending_angle(apex=[0.0, 0.0, 10.0], base_mid=[0.0, 0.0, 0.0])        # straight up
    90.0
    >>> round(bending_angle(apex=[0.0, -5.0, -1.0], base_mid=[0.0, 0.0, 0.0]), 1)  # curled over
    191.3
    """
    d = np.asarray(apex, float) - np.asarray(base_mid, float)
    theta = float(np.degrees(np.arctan2(d[2], d[1])))
    return theta + 360.0 if theta < -90.0 else theta


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
