"""The ideal dielectric film: permittivity, electrical thickness and the voltage coupling.

Units: V, mm, N, MPa. The vacuum permittivity in N/V^2 (= F/m = C/(V m) = J/(V^2 m)) does not
depend on the length unit, so eps0 (V/h)^2 with V in volts and h in mm is a stress in N/mm^2 = MPa.
At a fixed voltage the film's free energy gains -(eps0 eps_r V^2 / 2) times the integral of 1/h
over its current area; with an incompressible film h = h_m / J, where h_m is the mounted
(pre-stretched, flat) thickness and J the area ratio current/flat, so per unit flat area it is
-c J^2 with c = eps0 eps_r V^2 / (2 h_m) (N/mm). See docs/actuation.md.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from .electrodes import coverage
from .errors import SceneError
from .scene import Scene

FLAT_DEG = 1.0
"""Bending angle (deg) below which an actuated DEMES counts as flat."""

EPSILON_0 = 8.8541878128e-12
"""Vacuum permittivity, N/V^2 (numerically F/m; with V in volts and mm lengths eps0 E^2 is in MPa)."""


def mounted_thickness(scene: Scene) -> float:
    """Electrical thickness of the flat, pre-stretched film, mm: H / (l1 l2) (incompressible;
    H / prestretch^2 where isotropic).

    Without ``membrane.unstretched_thickness`` it is ``membrane.thickness``.
    """
    H = scene.membrane.unstretched_thickness
    return scene.membrane.thickness if H is None else H / scene.prestretch_path.area_stretch(scene.prestretch)


def dielectric_coefficient(scene: Scene, voltage: float | None = None) -> float:
    """c (N/mm) of the dielectric energy -c J^2 per unit flat area at ``voltage`` (V; default
    ``scene.loading.voltage``): c = eps0 eps_r V^2 / (2 h_m)."""
    v = scene.loading.voltage if voltage is None else voltage
    return EPSILON_0 * scene.membrane.permittivity * v * v / (2.0 * mounted_thickness(scene))


def electrode_coverage(scene: Scene, corners: np.ndarray) -> np.ndarray:
    """Fraction (t, e) of each flat triangle (corners (t, 3, 2+) mm) under each of the scene's
    electrodes; one column of ones where the scene has one electrode over the whole film."""
    if not scene.electrodes:
        return np.ones((len(corners), 1))
    return coverage(scene.electrodes, corners)


def electrode_voltages(scene: Scene) -> np.ndarray:
    """Voltage (V) of each column of :func:`electrode_coverage`."""
    if not scene.electrodes:
        return np.array([scene.loading.voltage])
    return np.array([e.voltage for e in scene.electrodes])


def film_coefficients(scene: Scene, cover: np.ndarray) -> np.ndarray:
    """c (N/mm) of each triangle's dielectric energy -c J^2 per unit flat area, from its
    ``cover`` (:func:`electrode_coverage`): eps0 eps_r / (2 h_m) times the sum over electrodes
    of the covered fraction times V^2."""
    return dielectric_coefficient(scene, 1.0) * _mean_square_voltage(scene, cover)


def effective_voltage(scene: Scene, cover: np.ndarray) -> np.ndarray:
    """Voltage (V) per triangle whose Maxwell stress on the whole triangle equals the mean over
    its area: sqrt(sum of covered fraction times V^2)."""
    return np.sqrt(_mean_square_voltage(scene, cover))


def _mean_square_voltage(scene: Scene, cover: np.ndarray) -> np.ndarray:
    """V^2 (V^2) per triangle averaged over its area: sum of covered fraction times V_e^2."""
    return cover @ electrode_voltages(scene) ** 2


def highest_voltage(scene: Scene) -> float:
    """The largest voltage (V) on any of the scene's electrodes."""
    return float(electrode_voltages(scene).max())


def driven_at(scene: Scene, voltage: float, electrodes: Sequence[str] | None = None) -> Scene:
    """The scene with ``voltage`` (V) on the named ``electrodes`` (default: every electrode, or
    the whole film's ``loading.voltage``); the others keep theirs."""
    if not scene.electrodes:
        if electrodes:
            raise SceneError(f"--electrode {electrodes[0]}: the scene has no [[electrodes]]; its one "
                             "electrode covers the whole film, and a voltage sweep drives it")
        return scene.updated(**{"loading.voltage": voltage})
    names = [e.name for e in scene.electrodes]
    for n in electrodes or ():
        if n not in names:
            raise SceneError(f"--electrode {n}: no such electrode; the scene's are {', '.join(names)}")
    chosen = set(electrodes or names)
    return scene.updated(electrodes=[{**e.to_dict(), "voltage": voltage if e.name in chosen else e.voltage}
                                     for e in scene.electrodes])


def check_voltages(voltages: Sequence[float]) -> list[float]:
    """Voltages (V) as floats, finite, >= 0 and increasing; a clear SceneError otherwise."""
    try:
        values = [float(v) for v in voltages]
    except (TypeError, ValueError):
        raise SceneError("voltages must be numbers in volts, e.g. 0:3000:100") from None
    if not values:
        raise SceneError("the voltage list is empty: give e.g. --voltage 0:3000:100")
    for v in values:
        if not math.isfinite(v) or v < 0:
            raise SceneError(f"voltage {v!r} V must be a finite number >= 0")
    if any(b <= a for a, b in zip(values, values[1:])):
        raise SceneError("voltages must increase: the sweep is one warm-started path from 0 V")
    return values


def path_end(bending_angle: float, voltage: float, requested: float, status: str, detail: str, *,
             prestretched: bool = True) -> tuple[str, bool, str]:
    """(status, converged, message) of the last state of a voltage path that could go no
    further. A flat state is a regular end (status 'flat'): past it the film has no tension left
    and no stable state (it would wrinkle). Otherwise, and wherever the pre-stretch path itself
    stopped short (``prestretched`` False: its state is no pre-stretched DEMES, flat or not),
    the solver's ``status`` and ``detail``."""
    if prestretched and abs(bending_angle) < FLAT_DEG:
        return "flat", True, (f"V = {voltage:g} V: flat; no stable state at higher voltage (the film "
                              f"has no tension left); requested V = {requested:g} V not reached")
    return status, False, f"V = {voltage:g} V: {detail}; requested V = {requested:g} V not reached"
