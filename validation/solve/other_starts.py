"""Other stable states at a state's pre-stretch: two other starts, polished by the state's own
solver on its own discrete problem, and a stable state of lower energy named if one is found.

The path gives one state per pre-stretch, the one its branch leads to. A DEMES can hold others:
the paper applied the pre-stretch at once, and its transient can land elsewhere. The starts are
the state's mirror image in the flat plane (z -> -z: where the model has that symmetry, the same
state curled the other way, of the same energy) and the pre-stretch applied at once from the
lifted flat state, by DR's transient (for an FEM state then polished by the FEM's Newton). A
state found is named on the path's state (:meth:`results.Result.note_lower_state`) when it is
stable, lower in energy by more than :data:`LOWER` and farther than :data:`SECOND_STATE` from
the path's state (docs/path.md).
"""

from __future__ import annotations

import numpy as np

from results import Result
from scenes import SceneError
from scenes.mesh import membrane_mesh
from scenes.transfer import transfer_linear

SECOND_STATE = 1e-3
"""Frame-curve RMS distance (/side) from the path's state above which a found state is another."""

LOWER = 1e-6
"""A state found is lower than the path's if its energy is below by more than this fraction of
the path's: far above both solvers' converged energy error (residual 1e-6 gives 1e-10 or
less), far below any difference between two shapes."""

MIRROR, AT_ONCE = "its mirror image in the flat plane", "the pre-stretch applied at once from the lift"
"""The other starts, in the words the state's message uses."""


def from_mirror(state: Result) -> Result:
    """The state ``state``'s solver reaches at its pre-stretch on its discrete problem from its
    mirror image in the flat plane, with no path (DR relaxes, the FEM's Newton steps off
    saddles)."""
    return _relaxed(state, state.x * [1.0, 1.0, -1.0])


def at_once(state: Result) -> Result | None:
    """The state reached with ``state``'s pre-stretch applied at once from the lifted flat state
    (the paper's way): DR's transient (a Newton from that far off does not converge: measured
    100 iterations at residual 4 on a pentagon); for an FEM state, DR's triangles on the
    scene's refinement-0 mesh, their state interpolated onto the FEM's nodes
    (:func:`scenes.transfer.transfer_linear`) and polished there by the FEM's Newton. None where
    DR does not model the scene (a film on the strip's face)."""
    import dr

    lam = state.prestretch
    if state.solver == "dr":
        return dr.solve(state.scene.updated(prestretch=lam, **{"dr.prestretch_step": 0.0}), lam)
    coarse = state.scene.updated(prestretch=lam, **{"dr.membrane_net": "triangles", "dr.prestretch_step": 0.0,
                                                    "fem.refinement": 0})
    try:
        found = dr.solve(coarse, lam)
    except SceneError:
        return None
    if not found.converged:
        return found
    mesh = membrane_mesh(coarse, 0)
    return _relaxed(state, transfer_linear(mesh, found.x[: len(mesh.nodes)], state.x0[:, :2]))


def _relaxed(state: Result, x_start: np.ndarray) -> Result:
    """The state ``state``'s solver reaches from ``x_start`` at its pre-stretch, no path."""
    scene = state.scene.updated(prestretch=state.prestretch)
    if state.solver == "dr":
        import dr

        return dr.solve(scene, state.prestretch, x_start=x_start, from_prestretch=state.prestretch)
    import fem_reference

    return fem_reference.solve_from(scene, x_start, refinement=state.info.get("refinement"))


def distinct(found: Result, state: Result) -> bool:
    """Whether ``found`` is farther than :data:`SECOND_STATE` (RMS over the frame, / side) from
    ``state``. (Its mirror image, where the model has the flip symmetry, has the same energy
    and is never lower.)"""
    return found.shape_error(state)[0] > SECOND_STATE


def against_the_lift(state: Result) -> bool:
    """Whether ``state``'s apex went to the other side of the flat plane than its scene's lift."""
    lift = state.scene.perturbation.amplitude
    return bool(lift) and state.branch in ("up", "down") and state.branch != ("up" if lift > 0 else "down")


def mirror_state(state: Result) -> Result | None:
    """For a converged ``state`` against its scene's lift (:func:`against_the_lift`): the stable
    state its solver reaches from its mirror image in the flat plane, if that is on the lift's
    side with the same energy (within :data:`LOWER`), noted on ``state`` (its message,
    ``info['mirror_state']``); None otherwise. Where the model has the flip symmetry the path's
    side was set where it left a symmetric state, not by the lift (docs/path.md): this names
    the state the lift asked for, which the path did not reach."""
    if not (state.converged and against_the_lift(state)):
        return None
    found = from_mirror(state)
    same = abs(found.energy.get("total", np.inf) - state.energy["total"]) <= LOWER * abs(state.energy["total"])
    if not (found.converged and found.info.get("stable") and same and not against_the_lift(found)):
        return None
    state.note_mirror_state(found)
    return found


def search(state: Result) -> Result | None:
    """Relax the other starts of a converged ``state`` (:func:`from_mirror`, :func:`at_once`) and return the stable state of
    lowest energy found if it is lower than ``state``'s (by :data:`LOWER`) and
    :func:`distinct`, noted on ``state`` (its message, ``info['lower_state']``); None otherwise
    (also for a state that did not converge)."""
    if not state.converged:
        return None
    best = None
    for words, start in ((MIRROR, from_mirror), (AT_ONCE, at_once)):
        found = start(state)
        if found is None:
            continue
        lower = found.energy.get("total", np.inf) < state.energy["total"] - LOWER * abs(state.energy["total"])
        if found.converged and found.info.get("stable") and lower and distinct(found, state):
            if best is None or found.energy["total"] < best[1].energy["total"]:
                best = (words, found)
    if best is None:
        mirror_state(state)
        return None
    state.note_lower_state(best[1], best[0])
    return best[1]
