"""``demes calibrate``: fit scene parameters to the experiment's observations (docs/actuation.md).

Targets (the paper's experiment): flat at about 2.25 kV; a substantial change of shape at about
1 kV; the 200 % physical sample has the shape of the 150 % numerical one.

The flattening voltage of a DEMES is, to within the frame's small buckling tension, the voltage
whose Maxwell stress cancels the flat film's pre-tension T (measured: FEM sweep 6748 V against
the closed form 6749 V for Table I), V_flat = sqrt(T h / (eps0 eps_r)). T is set by the film's
modulus and pre-stretch, which also set the shape at 0 V; so the fit is done in two steps:

1. the film modulus ``membrane.E`` from the flattening voltage (closed form, ``scipy.optimize.brentq``);
2. the frame stiffness ``frame.E`` (all strip stiffnesses in proportion, i.e. the strip's
   effective thickness) so that the bending angle at 0 V stays the one of the scene as given (the
   numerical 150 % state that matched the physical sample). Every law's energy is linear in its
   modulus (film: membrane.E; frame: frame.E through EA, EI, GJ), so at 0 V the equilibria depend
   on the two moduli only through their ratio: scaling frame.E as membrane.E keeps the shape
   exactly (a brentq root search for frame.E on FEM solves lands on it too: 289 MPa for the exact 289.1). The
   check sweep measures the kept angle as a residual.

The fitted scene is then checked by a FEM voltage sweep: its flattening voltage and stroke at
1 kV are the residuals. Sensitivities are d ln(V_flat) / d ln(parameter).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import brentq

from scenes import Scene, SceneError
from scenes.electric import mounted_thickness

from .actuate import PAPER_FLAT_V, PAPER_SUBSTANTIAL_V, Characteristics, characteristics, row
from .electromechanics import equibiaxial_mechanical_stress, flat_film_tension, gent_jm, zero_tension_voltage

PUBLISHED_VHB_MU = (0.013, 0.015)
"""Long-term shear modulus of VHB 4905/4910 in published fits, MPa."""

PHYSICAL_PRESTRETCH = 2.0
"""The physical sample's pre-stretch (200 %)."""

CHECK_VOLTAGES = tuple(float(v) for v in np.arange(0.0, 1.4 * PAPER_FLAT_V + 1, 125.0))
"""Voltages (V) of the check sweep of a fitted scene: past the target flattening voltage."""

VHB_LOCKING_STRETCH = 6.0
"""A published Gent locking stretch of VHB (Jm from it: :func:`gent_jm`)."""


def flattening_voltage(scene: Scene) -> float:
    """Closed-form flattening voltage (V) of a scene: the zero-tension voltage of its flat film,
    pre-stretched equally in every direction (an unequal pair is a SceneError: its film's
    tensions differ along the two axes and vanish at two voltages)."""
    if not scene.prestretch_path.isotropic:
        raise SceneError(f"loading.prestretch = {list(scene.loading.prestretch)}: the closed-form flattening voltage "
                         "(and the calibration on it) is that of a film pre-stretched equally in every direction; "
                         "give one pre-stretch")
    m = scene.membrane
    tension = flat_film_tension(m.law, m.E, m.thickness, scene.prestretch, m.gent_jm)
    return zero_tension_voltage(tension, mounted_thickness(scene), m.permittivity)


def sensitivity(scene: Scene, key: str, rel: float = 1e-4) -> float:
    """d ln(V_flat) / d ln(parameter) of the closed form, by central differences."""
    value = _get(scene, key)
    up = flattening_voltage(scene.updated(**{key: value * (1 + rel)}))
    down = flattening_voltage(scene.updated(**{key: value * (1 - rel)}))
    return float((np.log(up) - np.log(down)) / (np.log1p(rel) - np.log1p(-rel)))


def _get(scene: Scene, key: str) -> float:
    section, name = key.split(".")
    return float(getattr(getattr(scene, section), name))


def fit_membrane_modulus(scene: Scene, target: float = PAPER_FLAT_V) -> float:
    """``membrane.E`` (MPa) that puts the closed-form flattening voltage at ``target`` (V)."""
    if scene.prestretch <= 1.0:
        raise SceneError("loading.prestretch must be above 1 to calibrate: a film without "
                         "pre-stretch has no tension for the voltage to relax")
    f = lambda log_e: np.log(flattening_voltage(scene.updated(**{"membrane.E": float(np.exp(log_e))}))) - np.log(target)  # noqa: E731
    e0 = np.log(scene.membrane.E)
    return float(np.exp(brentq(f, e0 - 12.0, e0 + 12.0, xtol=1e-12)))


@dataclass
class Calibration:
    """Fitted values, sensitivities, residuals and what they imply."""

    membrane_E: float
    frame_E: float
    flat_voltage_closed_form: float
    sensitivities: dict[str, float]
    residuals: dict[str, float] = field(default_factory=dict)
    implications: list[str] = field(default_factory=list)


def implications(scene: Scene, fitted_E: float) -> list[str]:
    """What the fitted film modulus means for VHB and for the 200 % -> 150 % gap."""
    m = scene.membrane
    tension = flat_film_tension(m.law, fitted_E, m.thickness, scene.prestretch, m.gent_jm)
    stress = tension / m.thickness
    table = flat_film_tension(m.law, m.E, m.thickness, scene.prestretch, m.gent_jm) / m.thickness
    lines = [f"the fit puts the flat film's pre-stress at {1000 * stress:.1f} kPa "
             f"(Table I at {scene.prestretch:g}: {1000 * table:.0f} kPa, {table / stress:.1f} times more)"]
    for label, jm in (("neo-Hookean", None), (f"Gent (locking stretch {VHB_LOCKING_STRETCH:g})", gent_jm(VHB_LOCKING_STRETCH))):
        mu = stress / float(equibiaxial_mechanical_stress(PHYSICAL_PRESTRETCH, 1.0, jm))
        lines.append(f"a {label} VHB film mounted at {PHYSICAL_PRESTRETCH:g} (the physical 200 %) has that "
                     f"pre-stress with mu = {1000 * mu:.1f} kPa (published long-term fits: "
                     f"{1000 * PUBLISHED_VHB_MU[0]:.0f}-{1000 * PUBLISHED_VHB_MU[1]:.0f} kPa)")
    return lines


def fit(scene: Scene, refinement: int = 0, progress=print) -> tuple[Scene, Calibration, float]:
    """Fit ``membrane.E`` and ``frame.E`` (see the module docstring): the fitted scene, the
    calibration (no residuals yet) and the scene's own bending angle at 0 V (deg)."""
    from fem_reference import solve

    flattening_voltage(scene)  # a scene it does not hold for is refused before the solve
    base = solve(scene, refinement)
    if not base.converged:
        raise SceneError(f"the scene's own state did not converge: {base.message}")
    progress(f"scene as given: bending angle {base.bending_angle:.2f} deg at 0 V, closed-form "
             f"flattening voltage {flattening_voltage(scene):.0f} V")
    e_film = fit_membrane_modulus(scene)
    progress(f"membrane.E = {e_film:.4g} MPa puts the flattening voltage at {PAPER_FLAT_V:.0f} V")
    e_frame = scene.frame.E * e_film / scene.membrane.E  # the modulus ratio, hence the 0 V shape, kept
    progress(f"frame.E = {e_frame:.4g} MPa keeps the ratio of the moduli, hence the 0 V shape")
    fitted = scene.updated(**{"membrane.E": e_film, "frame.E": e_frame})
    cal = Calibration(e_film, e_frame, flattening_voltage(fitted),
                      {k: sensitivity(fitted, k) for k in ("membrane.E", "loading.prestretch",
                                                           "membrane.thickness", "frame.E")})
    cal.implications = implications(scene, e_film)
    cal.implications.append(
        f"frame.E = {e_frame:.4g} MPa keeps the 0 V shape: the strip's bending stiffness scaled by "
        f"{e_frame / scene.frame.E:.3g}, i.e. an effective thickness "
        f"{scene.frame.thickness * (e_frame / scene.frame.E) ** (1 / 3):.3f} mm for {scene.frame.thickness:g} mm")
    return fitted, cal, base.bending_angle


def residuals(ch: Characteristics, theta_target: float) -> dict[str, float]:
    """Residuals of the targets from the fitted scene's voltage sweep (its characteristics)."""
    return {
        "flat_voltage_V": ch.flat_voltage - PAPER_FLAT_V,
        "bending_angle_0V_deg": ch.theta0 - theta_target,
        "stroke_at_1kV_deg": ch.stroke_at_1kV,
        "stroke_at_1kV_fraction": ch.stroke_at_1kV / ch.theta0 if ch.theta0 else float("nan"),
    }


def calibrate(scene: Scene, refinement: int = 0, voltages: tuple[float, ...] | None = None,
              progress=print) -> Calibration:
    """Fit ``membrane.E`` and ``frame.E`` and check them by a FEM voltage sweep."""
    from fem_reference.actuation import voltage_sweep

    fitted, cal, theta_target = fit(scene, refinement, progress)
    volts = voltages or CHECK_VOLTAGES
    rows, theta0 = [], None
    for res in voltage_sweep(fitted, volts, refinement):
        theta0 = res.bending_angle if theta0 is None else theta0
        rows.append(row(res, theta0))
    cal.residuals = residuals(characteristics(rows), theta_target)
    return cal


def describe(cal: Calibration) -> str:
    """The calibration as text."""
    lines = [f"fitted membrane.E = {cal.membrane_E:.4g} MPa, frame.E = {cal.frame_E:.4g} MPa",
             f"closed-form flattening voltage of the fitted scene: {cal.flat_voltage_closed_form:.0f} V",
             "sensitivities d ln(V_flat) / d ln(p): " + ", ".join(f"{k} {v:+.3f}" for k, v in cal.sensitivities.items()),
             "residuals (FEM sweep of the fitted scene): " + ", ".join(f"{k} {v:+.4g}" for k, v in cal.residuals.items()),
             f"(experiment: flat at {PAPER_FLAT_V:.0f} V, a substantial change at {PAPER_SUBSTANTIAL_V:.0f} V)"]
    lines += [f"  {s}" for s in cal.implications]
    return "\n".join(lines)
