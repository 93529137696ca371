"""Voltage continuation of the FEM DEMES from its pre-stretched equilibrium, with pull-in stops.

The pre-stretched state is found as in :func:`fem_reference.sweep` (continuation in pre-stretch
from the flat state, at zero voltage). The voltage is then raised in steps, each Newton solve
starting from a secant predictor in V^2 (the energy is linear in V^2). A state is accepted only
if it is stable: the tangent is positive definite (its Cholesky factor exists), or its lowest eigenvalue is neutral
(a slack film). A step that fails is halved; when the step in V falls below ``MIN_STEP_V`` the
branch has ended at a limit point: a long Newton solve looks for a stable state to snap to (it
is reported), and if there is none the path stops with status ``pull_in`` and the voltage
interval that brackets the electromechanical instability. A branch that ends at a flat frame is
not searched: past it the film has no tension left and no stable state. The sweep also stops once the frame is
flat (bending angle below ``FLAT_DEG``): past that the film would be in compression.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable, Iterator, Sequence

import numpy as np

from results import Result
from results.metrics import outline_bending_angle
from results.path import neutral_stiffness
from scenes import Scene
from scenes.electric import (FLAT_DEG, check_voltages, driven_at, film_coefficients, mounted_thickness,
                             path_end)

from .model import DemesProblem
from .newton import NewtonResult, NotFactorizable, newton
from .solve import SNAP_ITERATIONS, TOLERANCE, Continuation, refinement_level
from .stability import lowest_free_mode
from .state import Outcome, StepRecord, make_result

MIN_STEP_V = 0.5
"""Smallest voltage step (V): a branch that cannot be followed in smaller steps has ended."""

STEP_ITERATIONS = 15
"""Newton iterations of one voltage step (from the secant predictor it needs a handful)."""


@dataclass
class VoltageStop:
    """Why a voltage path ended early: ``status`` ('pull_in', 'diverged', ...) and a sentence."""

    status: str
    detail: str


class VoltagePath:
    """Follows a stable equilibrium in voltage.

    Parameters
    ----------
    problem
        A Newton problem with a ``dielectric`` term (:class:`DemesProblem`, or a lone film).
    y
        Its equilibrium at 0 V (3 nn,).
    coefficient
        The dielectric coefficient c (N/mm; one, or one per element) at a voltage (V).
    neutral
        Eigenvalues (N/mm^3) above minus this count as neutral, not unstable.
    snap_iterations
        Newton iterations spent looking for a state to snap to where the branch ends.
    flat
        Whether a state (3 nn,) is one past which no stable state exists (a flat frame: the film
        has no tension left); a branch that ends at such a state is not searched for a snap.
    """

    def __init__(self, problem, y: np.ndarray, coefficient: Callable[[float], float | np.ndarray],
                 neutral: float, snap_iterations: int = SNAP_ITERATIONS,
                 flat: Callable[[np.ndarray], bool] | None = None):
        self.problem = problem
        self.coefficient = coefficient
        self.neutral = neutral
        self.snap_iterations = snap_iterations
        self.flat = flat
        self.lam = getattr(problem, "lam", 1.0)  # the pre-stretch, for the step records
        self.voltage = 0.0
        self.y = y
        self.previous: tuple[float, np.ndarray] | None = None
        self.snaps: list[tuple[float, float]] = []

    def _set(self, voltage: float) -> None:
        self.problem.dielectric.coefficient = self.coefficient(voltage)

    def _stable(self, nr: NewtonResult) -> bool:
        if not nr.converged:
            return False
        if nr.positive_definite:
            return True
        try:
            return lowest_free_mode(self.problem, nr.y)[0] > -self.neutral
        except NotFactorizable:
            return False

    def _predictor(self, voltage: float) -> np.ndarray:
        if self.previous is None:
            return self.y
        v0, y0 = self.previous
        t = (voltage**2 - self.voltage**2) / (self.voltage**2 - v0**2)
        return self.y + (self.y - y0) * t

    def _accept(self, voltage: float, y: np.ndarray) -> None:
        self.previous, self.voltage, self.y = (self.voltage, self.y), voltage, y

    def advance(self, target: float, step: float) -> tuple[list[StepRecord], VoltageStop | None]:
        """Raise the voltage to ``target`` (V) in steps of at most ``step``; the Newton records
        and, if the path ended before ``target``, why."""
        records: list[StepRecord] = []
        while self.voltage < target:
            v = min(self.voltage + step, target)
            self._set(v)
            nr = newton(self.problem, self._predictor(v), tol=TOLERANCE, max_iterations=STEP_ITERATIONS)
            records.append(StepRecord(self.lam, nr.iterations, nr.history, 0))
            if self._stable(nr):
                self._accept(v, nr.y)
                continue
            if step > MIN_STEP_V:
                step *= 0.5
                continue
            if self.flat is not None and self.flat(self.y):
                self._set(self.voltage)
                return records, VoltageStop("flat", f"flat at V = {self.voltage:.1f} V")
            # the branch ends here: is there a stable state to snap to?
            snap = newton(self.problem, self.y, tol=TOLERANCE, max_iterations=self.snap_iterations)
            records.append(StepRecord(self.lam, snap.iterations, snap.history, 0))
            if self._stable(snap):
                self.snaps.append((self.voltage, v))
                self.previous, self.voltage, self.y = None, v, snap.y
                continue
            self._set(self.voltage)
            return records, VoltageStop(
                "pull_in",
                f"electromechanical instability (pull-in) between V = {self.voltage:.1f} V and "
                f"{v:.1f} V: no stable equilibrium beyond (Newton: {nr.status}; snap: {snap.status})")
        return records, None


def _actuation_info(problem: DemesProblem, y: np.ndarray, voltage: float) -> dict:
    """Voltage, E_cap, film area and mean current thickness of a state."""
    xm = problem.film_positions(y)
    area = problem.dielectric.current_area(xm)
    flat_area = problem.dielectric.current_area(problem.X)
    return {
        "voltage_V": voltage,
        "film_area_mm2": area,
        "film_thickness_mm": mounted_thickness(problem.scene) * flat_area / area,
        "capacitor_energy": problem.dielectric.capacitor_energy(xm),
        "electrostatic_energy": problem.dielectric.energy(xm),
    }


def voltage_sweep(scene: Scene, voltages: Sequence[float], refinement: int | None = None,
                  step: float | None = None, electrodes: Sequence[str] | None = None) -> Iterator[Result]:
    """States of the pre-stretched DEMES at increasing voltages, one warm-started path.

    Parameters
    ----------
    scene
        The DEMES scene at its pre-stretch (the driven electrodes' voltage is ignored).
    voltages
        Increasing voltages (V, >= 0).
    refinement
        Times the element size is halved (default ``scene.fem.refinement``).
    step
        Largest voltage step (V) between solves (default: the smallest gap of ``voltages``, at
        most 100 V).
    electrodes
        Names of the electrodes the voltages drive (default: all; the whole film where the
        scene has no ``[[electrodes]]``); the others hold their own voltage throughout.

    Yields
    ------
    Result
        One per voltage until the frame is flat (bending angle below ``FLAT_DEG``; the flat state
        is yielded with ``info['flat'] = True``) or the path stops (pull-in, no convergence):
        the last stable state is yielded with that status and nothing after it. ``info`` holds
        ``voltage_V``, ``capacitor_energy`` (N mm), ``film_area_mm2``, ``film_thickness_mm``.
    """
    volts = check_voltages(voltages)
    level = refinement_level(scene, refinement)
    scene = driven_at(scene, 0.0, electrodes)
    at = lambda v: driven_at(scene, v, electrodes)  # noqa: E731
    problem = DemesProblem(scene, level, scene.fem.element)
    t0 = time.perf_counter()
    pre = Continuation(problem).advance(scene.prestretch)
    gaps = np.diff([0.0] + volts)
    dv = step if step is not None else min(100.0, float(gaps[gaps > 0].min()) if np.any(gaps > 0) else 100.0)
    mesh = problem.mesh

    def flat(y: np.ndarray) -> bool:  # as path_end reads the state (a 600-iteration snap search saved)
        return abs(outline_bending_angle(y.reshape(-1, 3)[mesh.frame_nodes], mesh.frame_s, scene.outline)) < FLAT_DEG

    path = VoltagePath(problem, pre.y, lambda v: film_coefficients(at(v), problem.electrode_cover),
                       neutral_stiffness(scene), flat=flat)
    stop = None if pre.converged else VoltageStop(pre.status, "the pre-stretched state: " + pre.detail)
    records = list(pre.records)
    steps = 0
    for v in volts:
        if stop is None:
            snapped = len(path.snaps)
            new, stop = path.advance(v, dv)
            records += new
        out = Outcome(path.y, problem.lam, "converged", "", records)
        out.snaps = path.snaps[snapped:] if stop is None else []
        steps += len(records)
        res = make_result(problem, out, problem.lam, 0.0, steps, at(path.voltage))
        res.info.update(_actuation_info(problem, path.y, path.voltage))
        res.info["requested_voltage_V"] = v
        res.wall_time = time.perf_counter() - t0
        t0, records = time.perf_counter(), []
        if stop is not None:
            res.status, res.converged, res.message = path_end(
                res.bending_angle, path.voltage, v, stop.status, stop.detail, prestretched=pre.converged)
            res.info["flat"] = res.status == "flat"
            yield res
            return
        res.message = f"V = {v:g} V, " + res.message
        res.info["flat"] = abs(res.bending_angle) < FLAT_DEG
        yield res
        if res.info["flat"]:
            return
