"""Voltage sweep of a DEMES by dynamic relaxation, warm-started from its pre-stretched state.

The pre-stretched equilibrium at 0 V comes from :func:`dr.solve` (the quasi-static pre-stretch
path). The voltage is then raised along the requested list, each state relaxed from the one
before. A relaxation that fails (no convergence, divergence, a fold) is retried from the last
good state with the voltage step halved, ``BISECTIONS`` times; if it still fails, the path stops
with the voltages that bracket the failure: status ``pull_in`` (an electromechanical instability)
when no equilibrium was found there, or the relaxation's own status for a fold or a contact. A
step whose relaxed state jumped off the branch the path followed is halved until the jump is
located (:data:`LOCATE_VOLTS`), so that the path, like the FEM's, follows its branch to its end. The sweep also stops once the frame is flat (bending angle below ``FLAT_DEG``).
"""

from __future__ import annotations

import dataclasses
from typing import Iterator, Sequence

import numpy as np

from results import Result
from results.path import jumped, largest_move
from scenes import Scene
from scenes.electric import (FLAT_DEG, check_voltages, driven_at, electrode_coverage, film_coefficients,
                             highest_voltage, mounted_thickness, path_end)

from .demes import solve
from .saddles import relax_settings, settle
from .demes_model import build, check_voltage_net
from .film_cells import film_surface
from .relax import relax

BISECTIONS = 4
"""Halvings of a failed voltage step before the path counts as ended (pull-in)."""

STEP_MOVE = 0.02
"""Largest nodal move of a voltage step, as a fraction of the side length, at the rate (per V^2)
of the branch followed: a requested step that would move the state more is taken in parts, so
that a relaxation starts near the state it should reach (a long one relaxed past a snap into
another stable state: the gripper at 3 kV, from 2.25 kV)."""

LOCATE_VOLTS = 2.0
"""A relaxed state that left the branch the path followed (:func:`results.path.jumped`, in V^2)
is accepted only once the step is this short (V): a longer one is halved, so that the path
stays on its branch up to where the branch ends, as the FEM's continuation does, instead of
relaxing into whichever state a long step lands it in."""


def voltage_sweep(scene: Scene, voltages: Sequence[float], progress: bool = False,
                  electrodes: Sequence[str] | None = None) -> Iterator[Result]:
    """States of the pre-stretched DEMES at increasing voltages (V), one warm-started path.

    The voltages drive the named ``electrodes`` (default: all; the whole film where the scene
    has no ``[[electrodes]]``); the others hold their own voltage from the pre-stretched state on.

    Yields one :class:`Result` per voltage until the frame is flat (that state is yielded with
    ``info['flat'] = True``) or the path stops (pull-in, contact, no convergence; the last good
    state is yielded with that status, and nothing after it). ``info`` holds ``voltage_V``,
    ``capacitor_energy`` and ``electrostatic_energy`` (N mm), ``film_area_mm2`` and
    ``film_thickness_mm`` (mean current thickness).
    """
    volts = check_voltages(voltages)
    check_voltage_net(scene, max(volts[-1], highest_voltage(scene)))
    scene = driven_at(scene, 0.0, electrodes)
    state = solve(scene, progress=progress)
    dm = build(scene)
    model, st = dm.model, scene.dr
    cover = electrode_coverage(scene, model.nodes[model.dielectric_triangles])
    at = lambda v: driven_at(scene, v, electrodes)  # noqa: E731
    flat_area = model.dielectric_energy(dm.model.nodes)[1]
    prestretched = state.converged  # the path reached the scene's pre-stretch
    v_now, stop = 0.0, None if prestretched else (state.status, "the pre-stretched state: " + state.message)

    settings = relax_settings(scene, dm)

    def relax_at(v: float, x: np.ndarray) -> Result:
        model.dielectric_coefficient = film_coefficients(at(v), cover)
        return relax(model, tol=st.tolerance, x_start=x, **settings)

    side = scene.outline.side_length
    rate, jumps = None, []  # mm per V^2 of the branch followed (None: not known yet), located jumps
    for v in volts:
        iterations, wall, cap = 0, 0.0, v
        while stop is None and v_now < v:
            # a step moves the state about STEP_MOVE of the side at the branch's rate, at most
            trial = min(cap, v if not rate else float(np.sqrt(v_now**2 + STEP_MOVE * side / rate)))
            bad = None
            for _ in range(BISECTIONS + 1):
                res = relax_at(trial, state.x)
                iterations, wall = iterations + res.iterations, wall + res.wall_time
                if res.converged:
                    break
                bad, trial = (trial, res), 0.5 * (v_now + trial)
            if not res.converged:
                stop = _stop(bad[1], v_now, bad[0])
                continue
            # the energy is linear in V^2: a branch moves at a steady rate per V^2
            step, move = trial**2 - v_now**2, largest_move(res.x, state.x)
            left_branch = jumped(move, step, rate, side)
            if left_branch and trial - v_now > LOCATE_VOLTS:
                cap = 0.5 * (v_now + trial)  # the state left its branch within the step: locate where
                continue
            if left_branch:
                jumps.append((v_now, trial))
            rate = None if left_branch else move / step
            state, v_now, cap = res, trial, v
        if stop is None and v_now > 0.0:  # checked for stability and moved to the equilibrium, as the path's states
            model.dielectric_coefficient = film_coefficients(at(v_now), cover)
            settled = settle(at(v_now), dm, state)
            state = settled if settled.converged else state
        out = _finish(state, at(v_now), dm, v_now, flat_area, cover)
        out.iterations, out.wall_time = iterations, wall
        out.info["requested_voltage_V"] = v
        out.info["voltage_jumps"] = list(jumps)
        if stop is not None:
            out.status, out.converged, out.message = path_end(out.bending_angle, v_now, v, *stop,
                                                              prestretched=prestretched)
            out.info["flat"] = out.status == "flat"
            yield out
            return
        out.info["flat"] = abs(out.bending_angle) < FLAT_DEG
        yield out
        if out.info["flat"]:
            return


GEOMETRIC_STOPS = ("membrane_fold", "self_contact")
"""Relaxation stops that are a geometric event, not a loss of equilibrium."""


def _stop(failed: Result, v_good: float, v_bad: float) -> tuple[str, str]:
    """(status, detail) of a path that cannot pass ``v_bad``: a fold or a contact keeps its own
    status; a relaxation that found no equilibrium there is a pull-in."""
    where = f"between V = {v_good:.1f} V and {v_bad:.1f} V"
    if failed.status in GEOMETRIC_STOPS:
        detail = f"{failed.status} {where}: {failed.message}"
        return failed.status, detail
    return "pull_in", (f"electromechanical instability (pull-in) {where}: no equilibrium found "
                       f"there ({failed.status}: {failed.message})")


def _finish(res: Result, scene: Scene, dm, voltage: float, flat_area: float, cover: np.ndarray) -> Result:
    """A copy of the state with its scene (at the state's voltages), frame and actuation measures."""
    res = dataclasses.replace(res, info=dict(res.info))
    res.scene, res.prestretch = scene, scene.prestretch
    res.frame_nodes, res.frame_s = dm.frame_nodes, dm.frame_s
    dm.model.dielectric_coefficient = film_coefficients(scene, cover)
    e_el, area = dm.model.dielectric_energy(res.x)
    res.blocks = {**res.blocks, "membrane_surface": film_surface(dm.model, res.x, scene)}
    res.info.update(voltage_V=voltage, capacitor_energy=-e_el + 0.0, electrostatic_energy=e_el,
                    film_area_mm2=area, film_thickness_mm=mounted_thickness(scene) * flat_area / area)
    res.message = f"V = {voltage:g} V: {res.message}"
    res.check_crossings(dm.model.triangles, contact_checked=dm.contact is not None)
    return res
