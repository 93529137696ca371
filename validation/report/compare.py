"""The extrapolated FEM reference and the metrics of every state against it (docs/validation.md,
docs/metrics.md).

Metrics per state: frame-curve RMS and max distance / side length, apex position error (mm),
bending-angle difference (deg), energy split and its difference (N mm), iterations, wall time.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from fem_reference import richardson
from results import ENERGY_KEYS, Result, metrics

CURVE_SAMPLES = 256
"""Frame-curve samples (equal reference arc length) of the reference and the shape errors."""

SCALARS = ("bending_angle", "apex_x", "apex_y", "apex_z", "mid_height_width", *(f"energy_{k}" for k in ENERGY_KEYS))


@dataclass
class Reference:
    """The converged FEM state at one pre-stretch, extrapolated from nested levels.

    ``curve`` is the frame centreline at CURVE_SAMPLES equal reference arc lengths (mm) and
    ``curve_error`` its pointwise error estimate; ``values``/``errors`` the scalars of
    :data:`SCALARS`; ``orders`` the observed orders (NaN where the formal order was used).
    """

    prestretch: float
    levels: tuple[int, ...]
    curve: np.ndarray
    curve_error: np.ndarray
    values: dict[str, float]
    errors: dict[str, float]
    orders: dict[str, float]
    level_values: dict[str, list[float]] = field(default_factory=dict)
    length: float = 0.0
    side: float = 1.0

    @property
    def s(self) -> np.ndarray:
        return np.linspace(0.0, self.length, CURVE_SAMPLES, endpoint=False)

    def shape_error(self, res: Result) -> tuple[float, float]:
        """RMS and max frame distance of ``res`` to the reference at equal arc length, / side."""
        x, s, length = res.frame_arc()
        return metrics.shape_error(x, s, self.curve, self.s, length, self.side, CURVE_SAMPLES)

    @property
    def shape_uncertainty(self) -> float:
        """RMS of the reference curve's own error estimate, / side length."""
        return float(np.sqrt(np.mean(np.sum(self.curve_error**2, axis=1))) / self.side)


def build_reference(levels: Sequence[int], states: Sequence[Result]) -> Reference | None:
    """Extrapolate converged states on consecutive levels (coarse to fine); None if < 2."""
    good = [r for r in states if r.converged]
    if len(good) < 2 or len(good) != len(states):
        return None
    outline = good[0].scene.outline
    curves = np.stack([r.frame_curve(CURVE_SAMPLES) for r in good])  # (levels, samples, 3)
    flat = curves.reshape(len(good), -1)
    est = [richardson(flat[:, j]) for j in range(flat.shape[1])]
    curve = np.array([e.extrapolated for e in est]).reshape(CURVE_SAMPLES, 3)
    curve_error = np.array([e.error for e in est]).reshape(CURVE_SAMPLES, 3)
    rows = [r.summary() for r in good]
    values, errors, orders, level_values = {}, {}, {}, {}
    for q in SCALARS:
        e = richardson([row[q] for row in rows], q)
        values[q], errors[q], orders[q] = e.extrapolated, e.error, e.order
        level_values[q] = [row[q] for row in rows]
    return Reference(good[0].prestretch, tuple(levels[: len(good)]), curve, curve_error, values, errors, orders,
                     level_values, outline.length, outline.side_length)


def curve_distance(x: Reference, y: Reference) -> float:
    """RMS distance of two extrapolated frame curves, / side length."""
    return frame_distance(x.curve, y)


def frame_distance(curve: np.ndarray, ref: Reference) -> float:
    """RMS distance (/side) of a frame curve at the reference's arc lengths (CURVE_SAMPLES, 3) to the reference's."""
    return float(np.sqrt(np.mean(np.sum((curve - ref.curve) ** 2, axis=1))) / ref.side)


def state_difference(x: Result | None, y: Result | None) -> tuple[float, float]:
    """Shape RMS (/side) and bending-angle difference (deg) between two states of one scene;
    NaN where either is missing."""
    if x is None or y is None:
        return np.nan, np.nan
    return x.shape_error(y)[0], x.bending_angle - y.bending_angle


def apex_of(ref: Reference) -> np.ndarray:
    return np.array([ref.values["apex_x"], ref.values["apex_y"], ref.values["apex_z"]])


def state_metrics(res: Result, ref: Reference | None) -> dict[str, Any]:
    """One row: the state's summary and, with a reference, its errors against it."""
    row = res.summary()
    row["solver"] = res.solver
    if ref is None or not np.all(np.isfinite(ref.curve)):
        return row
    rms, mx = ref.shape_error(res)
    apex = np.array([row["apex_x"], row["apex_y"], row["apex_z"]])
    row.update(
        shape_rms=rms,
        shape_max=mx,
        apex_error=float(np.linalg.norm(apex - apex_of(ref))),
        bending_angle_diff=row["bending_angle"] - ref.values["bending_angle"],
        **{f"energy_{k}_diff": row[f"energy_{k}"] - ref.values[f"energy_{k}"] for k in ENERGY_KEYS},
    )
    return row


METRIC_UNITS = {
    "shape_rms": "-",
    "shape_max": "-",
    "apex_error": "mm",
    "bending_angle_diff": "deg",
    **{f"energy_{k}_diff": "N mm" for k in ENERGY_KEYS},
    "peak_memory": "MB",
}
"""Units of the comparison columns (shape errors are fractions of the side length)."""
