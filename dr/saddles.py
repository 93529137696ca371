"""A DR state's stability step: a converged state's lowest mode, the steps off a saddle along it
(apex to the lift's side, docs/path.md), and the Newton steps that move a stable state to the
discrete equilibrium; with the settings every relaxation of a DEMES path shares."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from results import Result
from results.path import largest_move, side_of_mode
from scenes import Scene

from . import stability
from .demes_model import DemesModel
from .kernels import gradient
from .relax import relax
from .symmetry import kept_by, restore, restore_mode

SADDLE_STEP = 0.05
"""The step off a saddle along its lowest mode, as a fraction of the side length, at the node
that moves most (halved until the energy drops), as the FEM's continuation steps."""

PUSHED_TOLERANCE = 1e-2
"""The relaxation from a step off a saddle is to this fraction of ``dr.tolerance``."""

MIN_TOLERANCE = 1e-12
"""The tightest relaxation a step off a saddle asks for (near the round-off of the stiffest link)."""

MAX_SADDLE_STEPS = 5
"""Steps off saddles at one pre-stretch after which the state is reported 'unstable'."""

HILLTOP_ITERATIONS = 8
"""Newton steps that locate the hilltop along a saddle's mode before it is left."""


def relax_settings(scene: Scene, dm: DemesModel) -> dict:
    """The settings of every :func:`dr.relax` call of a path but its tolerance and start."""
    st = scene.dr
    force_scale = 0.01 * scene.membrane.E * dm.cable_area  # a cable at 1 % strain
    return dict(mass_safety=st.mass_safety, max_iterations=st.max_iterations, contact=dm.contact,
                final_checks=dm.final_checks, force_scale=force_scale, damping=st.damping, masses=st.masses)


def settle(scene: Scene, dm: DemesModel, res: Result) -> Result:
    """The stable equilibrium DR reports from ``res``, a converged relaxation of ``dm`` under the
    scene's loads, as it reports a pre-stretch state: off any saddle along its lowest mode, then
    moved to the discrete equilibrium by Newton steps, with ``info['stable']``, the lowest
    eigenvalue and the last Newton step's length."""
    settings = relax_settings(scene, dm)
    return off_saddles(scene, dm, res, [res], relax_with=settings, mode=lowest_mode(dm, res, settings), polish=True)


def lowest_mode(dm: DemesModel, res: Result, relax_with: dict) -> stability.Mode:
    """The lowest mode of the state ``res`` with DR's masses (the lift as Lanczos' start)."""
    return stability.lowest_mode(dm.model, res.x, masses=relax_with["masses"], guess=dm.start - dm.model.nodes)


def off_saddles(scene: Scene, dm: DemesModel, res: Result, runs: list[Result], *, relax_with: dict,
                mode: stability.Mode, unstable: bool = False, polish: bool = False) -> Result:
    """A stable equilibrium from the converged state ``res``: while its lowest
    mode (:func:`dr.stability.lowest_mode`) has a negative stiffness, step along it, apex to
    the side the scene's perturbation asks for, and relax again (each relaxation appended to
    ``runs``); ``mode``: the lowest mode of ``res``; ``unstable``: ``res`` is known to be
    unstable (a relaxation fell off it), so any negative stiffness, even within the neutral
    band, is stepped along. The state returned, which is also put as ``runs``' last entry, carries
    ``info['saddle_steps']``, ``info['lowest_eigenvalue']`` and ``info['stable']`` (None where
    the lowest mode was not found); a state that stays a saddle has the status 'unstable'. With
    ``polish``, a stable state is then moved to the discrete equilibrium (:func:`_to_equilibrium`)."""
    apex = dm.frame_nodes[scene.outline.nearest_to_apex(dm.frame_s)]
    up = np.sign(scene.perturbation.amplitude) or 1.0
    lift = dm.start - dm.model.nodes
    steps = 0
    while True:
        if steps:
            mode = lowest_mode(dm, res, relax_with)
        checked = {**res.info, "saddle_steps": steps, "lowest_eigenvalue": mode.eigenvalue,
                   "lowest_eigenvalue_N_per_mm3": mode.per_area, "stable": not stability.is_saddle(mode, dm.neutral),
                   "newton_step_mm": (float(np.linalg.norm(mode.newton_step, axis=1).max())
                                      if mode.newton_step is not None else float("nan"))}
        if not np.isfinite(mode.eigenvalue):
            runs[-1] = replace(res, info={**checked, "stable": None},
                               message=f"{res.message}; its stability is unknown (the lowest mode was not found)")
            return runs[-1]
        if checked["stable"] and not (unstable and steps == 0 and stability.is_negative(mode)):
            runs[-1] = replace(res, info=checked)
            return _to_equilibrium(scene, dm, runs, mode, relax_with) if polish else runs[-1]
        # from the symmetric state the saddle is, not from the drift a relaxation left along its mode
        kept = kept_by(res.x, dm.symmetries, scene.outline.side_length)
        saddle = restore(res.x, kept, dm.model.fixed)
        mode = mode._replace(shape=restore_mode(mode.shape, kept))
        sign = side_of_mode(mode.shape, apex=apex, lift=lift, up=up, flat=dm.model.nodes)
        pushed = (leave_saddle(dm.model, saddle, mode, sign=sign, size=SADDLE_STEP * scene.outline.side_length)
                  if steps < MAX_SADDLE_STEPS else None)
        if pushed is None:
            runs[-1] = replace(res, converged=False, status="unstable", info=checked, message=(
                f"{res.message}; a saddle: its lowest mode has stiffness {mode.eigenvalue:.3g} (in units of the "
                f"masses) after {steps} steps along it"))
            return runs[-1]
        steps += 1
        # tighter: the residual of a state a step off a soft saddle is small before its
        # unstable mode has grown (measured on a square at 1.009: at 1e-6 DR stops 0.05 mm off
        # the saddle, at 1e-8 on the curled state 1.27 mm away)
        tol = max(PUSHED_TOLERANCE * scene.dr.tolerance, MIN_TOLERANCE)
        res = relax(dm.model, tol=tol, x_start=pushed, **relax_with)
        # off a weak saddle the pushed state's residual can already be below the tolerance:
        # relax on, tighter, until the relaxation has moved by more than the push
        while (res.converged and tol > MIN_TOLERANCE
               and largest_move(res.x, pushed) < largest_move(pushed, saddle)):
            tol = max(PUSHED_TOLERANCE * tol, MIN_TOLERANCE)
            res = relax(dm.model, tol=tol, x_start=res.x, **relax_with)
        runs.append(res)
        if not res.converged:
            runs[-1] = replace(res, info={**res.info, "saddle_steps": steps})
            return runs[-1]


def leave_saddle(model, x: np.ndarray, mode: stability.Mode, *, sign: float, size: float) -> np.ndarray | None:
    """Positions off the saddle near ``x`` along ``mode`` where the potential energy is lower.

    A relaxation stops within its tolerance, which along a mode this soft can leave the state
    on one side of the saddle already (on a square's twisted state, 3e-4 of the side off it):
    the hilltop along the mode is found first (Newton on the energy's slope along it). From
    there the step is ``size`` mm at the node that moves most, halved until the energy drops
    (at most 30 times), on the side ``sign`` (+1 or -1) first, then, where the energy rises
    that way, on the other; then doubled while the energy still drops (up to 16 ``size``), so
    that the relaxation starts down the slope rather than creeping back to the saddle. None if
    the energy never drops."""
    P = model.pack()
    X = np.zeros((P.n_total, 3))
    free = ~model.fixed[: P.n]

    def energy_at(step: float) -> float:
        X[: P.n] = x + step * mode.shape
        return stability.potential_energy(X, P, model.loads)

    def slope_at(step: float) -> float:
        X[: P.n] = x + step * mode.shape
        G = np.zeros_like(X)
        gradient(X, P, G, np.zeros((0, 6)))
        return float(np.sum((G[: P.n] - model.loads) * mode.shape * free))

    top, h = 0.0, 1e-4 * size
    for _ in range(HILLTOP_ITERATIONS):
        curvature = (slope_at(top + h) - slope_at(top - h)) / (2.0 * h)
        if not curvature < 0.0:
            break  # no hilltop along the mode here
        move = -slope_at(top) / curvature
        if not abs(top + move) < size:
            top = 0.0  # the hilltop is not near: step from the state itself
            break
        top += move
        if abs(move) < 1e-6 * size:
            break
    e0 = energy_at(top)
    for side in (sign, -sign):
        step = side * size
        for _ in range(30):
            e = energy_at(top + step)
            if e < e0 - 1e-12 * abs(e0):
                for _ in range(4):
                    e_further = energy_at(top + 2.0 * step)
                    if not e_further < e:
                        break
                    step, e = 2.0 * step, e_further
                return x + (top + step) * mode.shape
            step *= 0.5
    return None


def _to_equilibrium(scene: Scene, dm: DemesModel, runs: list[Result], mode: stability.Mode,
                    relax_with: dict) -> Result:
    """The stable state ``runs[-1]`` (lowest mode ``mode``) moved to the discrete equilibrium by
    Newton steps K^-1 r on its assembled stiffness: each step's end is relaxed (to the
    tolerance, then on to a hundredth of it where its own Newton step is not yet halved: at the
    tolerance the gripper's state at 1.1 drifted 0.59 mm back along its soft mode) and kept
    only where it is a stable state whose own Newton step is at most half this one, up to
    :data:`NEWTON_STEPS` times or until the step is below :data:`AT_EQUILIBRIUM` of the side. A residual tolerance stops DR r / w from the
    equilibrium along a soft mode (w its stiffness); the Newton step removes that error where
    the quadratic model holds, and the guard keeps the relaxed state where it does not. Kept
    states are appended to ``runs``; ``info['newton_steps']`` counts them."""
    res = runs[-1] = replace(runs[-1], info={**runs[-1].info, "newton_steps": 0})
    for k in range(1, NEWTON_STEPS + 1):
        if mode.newton_step is None:
            break
        length = float(np.linalg.norm(mode.newton_step, axis=1).max())
        if length <= AT_EQUILIBRIUM * scene.outline.side_length:
            break
        x_start, trial_length = res.x + mode.newton_step, float("inf")
        for tol in (scene.dr.tolerance, max(PUSHED_TOLERANCE * scene.dr.tolerance, MIN_TOLERANCE)):
            # relaxed to the tolerance first; where that drifted back along the soft mode (its own
            # step not halved), on to a hundredth of it
            trial = relax(dm.model, tol=tol, x_start=x_start, **relax_with)
            if not trial.converged:
                break
            trial_mode = lowest_mode(dm, trial, relax_with)
            if stability.is_saddle(trial_mode, dm.neutral) or trial_mode.newton_step is None:
                break
            trial_length = float(np.linalg.norm(trial_mode.newton_step, axis=1).max())
            if trial_length <= 0.5 * length:
                break
            x_start = trial.x
        if trial_length > 0.5 * length:
            break
        runs.append(replace(trial, info={
            **res.info, **trial.info, "newton_steps": k, "lowest_eigenvalue": trial_mode.eigenvalue,
            "lowest_eigenvalue_N_per_mm3": trial_mode.per_area, "newton_step_mm": trial_length}))
        res, mode = runs[-1], trial_mode
    return res


NEWTON_STEPS = 3
"""Most Newton steps from a relaxed state to the discrete equilibrium."""

AT_EQUILIBRIUM = 1e-6
"""A state whose Newton step is below this fraction of the side length is at the discrete
equilibrium (DR and the FEM then agree to it)."""
