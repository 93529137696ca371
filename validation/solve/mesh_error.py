"""Discretisation error of each state a sweep prints: the same path on nested meshes, each
halving the element size, and Richardson extrapolation with the observed order
(:func:`fem_reference.richardson`, as the report's FEM reference is made).

With three levels whose differences shrink at an order in [0.5, 4] the error estimate is Roache's
grid convergence index (factor 1.25); with two levels, or an order that cannot be observed, the
formal order 2 with a factor 3, which is no bound where the coarse meshes are outside the
asymptotic range (the note says so). One level, or fewer than two converged ones, gives no
estimate, and the note says why.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Iterator, Sequence

import numpy as np

from fem_reference import Estimate, richardson
from results import Result
from scenes import Scene, SceneError

QUANTITIES = (
    ("bending_angle", "deg"),
    ("apex_y", "mm"),
    ("apex_z", "mm"),
    ("energy_total", "N mm"),
)
"""The quantities given an extrapolated value and an error estimate."""

FEM_LEVELS = (20, 40, 80)
"""The main job's FEM meshes (mesh.divisions): at 150 % an error estimate of 0.6 deg in 43 s of
CPU (docs/performance.md)."""

RATIO = 2  # element size ratio of consecutive levels


@dataclass
class MeshError:
    """A state on the finest mesh with its discretisation error estimates.

    Attributes
    ----------
    state
        The finest level's state (written to the VTK files and the table).
    divisions
        mesh.divisions of the converged levels the estimates rest on, coarse to fine.
    estimates
        Per quantity of :data:`QUANTITIES`, the Richardson estimate (absent: none made).
    note
        What the estimate rests on, or why there is none.
    """

    state: Result
    divisions: list[int]
    estimates: dict[str, Estimate] = field(default_factory=dict)
    note: str = ""

    def columns(self) -> dict[str, Any]:
        """The CSV/table columns: ``<q>_extrapolated``, ``<q>_error``, ``<q>_order`` per quantity
        (NaN where no estimate), ``mesh_levels`` and ``mesh_error``."""
        row: dict[str, Any] = {}
        for name, _ in QUANTITIES:
            e = self.estimates.get(name)
            row[f"{name}_extrapolated"] = e.extrapolated if e else np.nan
            row[f"{name}_error"] = e.error if e else np.nan
            row[f"{name}_order"] = e.order if e else np.nan
        row["mesh_levels"] = " ".join(map(str, self.divisions))
        row["mesh_error"] = self.note
        return row


UNITS = {**{f"{n}_{s}": u for n, u in QUANTITIES for s in ("extrapolated", "error")},
         **{f"{n}_order": "-" for n, _ in QUANTITIES}}
"""Units of :meth:`MeshError.columns`, for the CSV header."""


def check_levels(divisions: Sequence[int]) -> list[int]:
    """``divisions`` as mesh levels: increasing, each twice the one before.

    Raises
    ------
    SceneError
        If they are not.
    """
    levels = [int(d) for d in divisions]
    if not levels or any(b != RATIO * a for a, b in zip(levels, levels[1:])):
        raise SceneError(f"--mesh-levels {' '.join(map(str, divisions))}: give mesh.divisions that double "
                         "from each level to the next, e.g. 20 40 80 (one value: no error estimate)")
    return levels


def fem_default_levels(scene: Scene, divisions_set: bool) -> list[int]:
    """The FEM's meshes: :data:`FEM_LEVELS`, or from mesh.divisions d when it was set: d, 2d, 4d."""
    d = scene.mesh.divisions
    return [d, RATIO * d, RATIO**2 * d] if divisions_set else list(FEM_LEVELS)


def dr_default_levels(scene: Scene) -> list[int]:
    """DR's meshes: the scene's mesh.divisions and up to two halvings of it."""
    d = scene.mesh.divisions
    levels = [d]
    while len(levels) < 3 and levels[0] % RATIO == 0 and levels[0] // RATIO >= 4:
        levels.insert(0, levels[0] // RATIO)
    return levels


def estimate(states: Sequence[Result | None], divisions: Sequence[int]) -> MeshError:
    """The finest state (last of ``states``) with the estimates from the converged levels.

    Parameters
    ----------
    states
        One state per level (None: that level's path stopped earlier), coarse to fine, at the
        same pre-stretch.
    divisions
        Their mesh.divisions.
    """
    finest = states[-1]
    if finest is None:
        raise ValueError("the finest level has no state")
    if len(states) == 1:
        return MeshError(finest, [divisions[-1]], note="one mesh: no error estimate")
    if not finest.converged:
        return MeshError(finest, [divisions[-1]], note="the finest level did not converge: no error estimate")
    # the levels must be consecutive down from the finest: a gap changes the ratio
    kept: list[int] = []
    for i in range(len(states) - 1, -1, -1):
        s = states[i]
        if s is None or not s.converged or abs(s.prestretch - finest.prestretch) > 1e-12:
            break
        kept.insert(0, i)
    if len(kept) < 2:
        return MeshError(finest, [divisions[-1]], note="the coarser level did not converge: no error estimate")
    rows = [states[i].summary() for i in kept]
    est = {name: richardson([r[name] for r in rows], name, unit, ratio=RATIO) for name, unit in QUANTITIES}
    theta = est["bending_angle"]
    if len(kept) == 2:
        note = "2 meshes, order 2 assumed"
    elif theta.observed:
        note = f"{len(kept)} meshes, order observed"
    else:
        note = "order not observed, 2 assumed (no bound)"
    return MeshError(finest, [divisions[i] for i in kept], est, note)


def fem_levels(scene: Scene, prestretches: Sequence[float], divisions: Sequence[int]
               ) -> Iterator[MeshError]:
    """The FEM sweep on nested meshes (one path, each level started from the one below)."""
    import fem_reference

    levels = check_levels(divisions)
    base = scene.updated(**{"mesh.divisions": levels[0]})
    for states in fem_reference.sweep_levels(base, prestretches, refinement=len(levels) - 1):
        by_level: list[Result | None] = [None] * len(levels)
        for s in states:
            by_level[s.info["refinement"]] = s
        yield estimate(by_level, levels)


def dr_levels(scene: Scene, prestretches: Sequence[float], divisions: Sequence[int]
              ) -> Iterator[MeshError]:
    """DR sweeps at each mesh.divisions (each its own path from flat), state by state."""
    import dr

    levels = check_levels(divisions)
    paths = [dr.sweep(scene.updated(**{"mesh.divisions": d}), prestretches) for d in levels]
    coarse, finest = paths[:-1], paths[-1]
    alive = [True] * len(coarse)
    for state in finest:
        by_level: list[Result | None] = []
        for i, path in enumerate(coarse):
            s = next(path, None) if alive[i] else None
            alive[i] = s is not None and s.converged
            by_level.append(s)
        yield estimate([*by_level, state], levels)
