"""Mesh convergence study: observed orders and Richardson-extrapolated reference values.

With three nested levels (element size h, h/2, h/4) and a quantity q converging as
q_h = q* + C h^p, the observed order is p = log2((q_h - q_h/2) / (q_h/2 - q_h/4)), the
extrapolated value q* = q_h/4 + (q_h/4 - q_h/2) / (2^p - 1), and the error estimate of the
finest level is Roache's grid convergence index, Fs |q_h/4 - q_h/2| / (2^p - 1) with Fs = 1.25.
Where the order cannot be observed (two levels, or differences that change sign or give an
order outside [0.5, 4]) the formal order 2 is used with Fs = 3.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from results import ENERGY_KEYS, Result
from scenes import Scene, SceneError

from .solve import solve

FORMAL_ORDER = 2.0  # discrete rod and P1 membrane both converge at h^2 in positions and energy

QUANTITIES = (
    ("bending_angle", "deg"),
    ("apex_x", "mm"),
    ("apex_y", "mm"),
    ("apex_z", "mm"),
    ("mid_height_width", "mm"),
    *((f"energy_{k}", "N mm") for k in ENERGY_KEYS),
)


@dataclass
class Estimate:
    """One quantity over the levels: values, observed order, extrapolated value and its error."""

    name: str
    unit: str
    values: list[float]
    order: float  # observed order (NaN where it cannot be observed)
    extrapolated: float
    error: float  # estimated error of the extrapolated value (and bound on the finest level's)
    observed: bool  # whether the order was observed (else the formal order was assumed)


def richardson(values: Sequence[float], name: str = "", unit: str = "", ratio: float = 2.0,
               formal_order: float = FORMAL_ORDER) -> Estimate:
    """Observed order, extrapolated value and error estimate from values on nested levels
    (coarse to fine, element size divided by ``ratio`` each time).

    >>> est = richardson([1.16, 1.04, 1.01])   # q_h = 1 + 0.16 (h / h0)^2
    >>> round(est.order, 9), round(est.extrapolated, 9), round(est.error, 9)
    (2.0, 1.0, 0.0125)
    """
    q = np.asarray(values, dtype=float)
    if q.size < 2 or not np.all(np.isfinite(q)):
        return Estimate(name, unit, list(q), float("nan"), float("nan"), float("nan"), False)
    d_fine = q[-1] - q[-2]
    p, observed = formal_order, False
    if q.size >= 3:
        d_coarse = q[-2] - q[-3]
        if d_fine == 0.0:
            return Estimate(name, unit, list(q), float("inf"), q[-1], 0.0, True)
        if d_coarse != 0.0 and d_coarse / d_fine > 0:
            p_obs = np.log(d_coarse / d_fine) / np.log(ratio)
            if 0.5 <= p_obs <= 4.0:
                p, observed = float(p_obs), True
    factor = ratio**p - 1.0
    extrapolated = q[-1] + d_fine / factor
    error = (1.25 if observed else 3.0) * abs(d_fine) / factor
    return Estimate(name, unit, list(q), p if observed else float("nan"), float(extrapolated),
                    float(error), observed)


@dataclass
class ConvergenceStudy:
    """States per element and level, the estimates, and the reference (value, error) per quantity."""

    scene: Scene
    prestretch: float
    levels: tuple[int, ...]
    results: dict[str, list[Result]] = field(default_factory=dict)
    estimates: dict[str, dict[str, Estimate]] = field(default_factory=dict)
    reference: dict[str, tuple[float, float, str]] = field(default_factory=dict)

    def table(self) -> str:
        """Plain-text table: per element and quantity, values per level, order, extrapolation."""
        head = f"{'quantity':<30}{'elem':>5}" + "".join(f"{'r' + str(k):>12}" for k in self.levels)
        lines = [f"convergence at lambda = {self.prestretch:g} ({self.scene.frame.model} frame)",
                 head + f"{'order':>8}{'extrapolated':>15}{'+-':>10}"]
        for el, est in self.estimates.items():
            for name, e in est.items():
                vals = "".join(f"{v:12.5g}" for v in e.values) + " " * 12 * (len(self.levels) - len(e.values))
                order = f"{e.order:8.2f}" if e.observed else f"{'(' + format(FORMAL_ORDER, 'g') + ')':>8}"
                lines.append(f"{name + ' [' + e.unit + ']':<30}{el:>5}{vals}{order}"
                             f"{e.extrapolated:15.6g}{e.error:10.2g}")
        return "\n".join(lines)


def convergence_study(scene: Scene, prestretch: float | None = None,
                      levels: Sequence[int] = (0, 1, 2), elements: Sequence[str] = ("P1", "P2")
                      ) -> ConvergenceStudy:
    """Solve ``scene`` at ``prestretch`` on nested meshes and estimate the converged reference.

    Parameters
    ----------
    scene
        The scene (its ``fem.element`` is overridden by ``elements``).
    prestretch
        Pre-stretch ratio (default ``scene.prestretch``).
    levels
        Refinement levels, increasing, consecutive (element size halves each time).
    elements
        'P1' and/or 'P2'.

    Returns
    -------
    ConvergenceStudy
        ``reference[q] = (value, error estimate, element)`` for every quantity q of
        :data:`QUANTITIES`: the extrapolation of the element with the smaller error estimate.
        States that did not converge end the levels of their element.
    """
    levels = tuple(int(k) for k in levels)
    if len(levels) < 2 or any(b != a + 1 for a, b in zip(levels, levels[1:])):
        raise SceneError(f"levels = {levels}: give at least two consecutive refinement levels, e.g. (0, 1, 2)")
    lam = scene.prestretch if prestretch is None else float(prestretch)
    study = ConvergenceStudy(scene, lam, levels)
    for el in elements:
        sc = scene.updated(prestretch=lam, **{"fem.element": el})
        runs: list[Result] = []
        for k in levels:
            res = solve(sc, refinement=k)
            runs.append(res)
            if not res.converged:
                break
        study.results[el] = runs
        good = [r.summary() for r in runs if r.converged]
        study.estimates[el] = {name: richardson([row[name] for row in good], name, unit)
                               for name, unit in QUANTITIES}
    for name, _ in QUANTITIES:
        candidates = [(est[name].error, el, est[name]) for el, est in study.estimates.items()
                      if np.isfinite(est[name].error)]
        if candidates:
            err, el, e = min(candidates, key=lambda c: c[0])
            study.reference[name] = (e.extrapolated, err, el)
    return study
