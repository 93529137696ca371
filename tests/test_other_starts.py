"""Other stable states at a state's pre-stretch (validation.solve.other_starts): a film bonded on one
face of the strip breaks the flip symmetry, and the state curled the other way has a lower
energy than the one the path curled to; a model with the flip symmetry has none lower from its
mirror start, whose energy is the path's."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import dr
import fem_reference
import scenes
from validation.cli import main
from validation.solve import other_starts

ONE_FACE = {"mesh.divisions": 8, "frame.film_offset": True, "fem.element": "P1"}


@pytest.fixture(scope="module")
def one_face_state():
    scene = scenes.paper_demes(1.2, "strip", **ONE_FACE)
    state = list(fem_reference.sweep(scene, [1.2]))[-1]
    assert state.converged and state.branch == "up"
    return state


def test_the_film_on_one_face_the_mirror_start_finds_the_curl_of_lower_energy(one_face_state):
    """The film on the strip's top face pulls the frame's top edge in: the two curls are not
    mirror images, and their energies differ. The path went up (the lift); the state reached
    from its mirror image curls down, is stable (the FEM's tangent), lower in energy, and is
    named on the path's state, in its message and remarks."""
    state = one_face_state
    energy = state.energy["total"]
    found = other_starts.search(state)
    assert found is not None and found.converged and found.info["stable"]
    assert found.branch == "down" and found.energy["total"] < energy * (1 - other_starts.LOWER)
    # a state of its own, not the path's within its tolerance
    assert found.shape_error(state)[0] > other_starts.SECOND_STATE
    lower = state.info["lower_state"]
    assert lower["branch"] == "down" and lower["energy_total"] == found.energy["total"]
    assert lower["start"] == other_starts.MIRROR
    words = "a stable state of lower energy was found from its mirror image in the flat plane"
    assert words in state.message and any(words in r for r in state.remarks)
    assert state.converged  # the path's state is still the path's answer


def test_a_model_with_the_flip_symmetry_has_no_lower_mirror():
    """Film on the centreline: the mirror image of DR's state is an equilibrium of the same
    energy, curled the other way; it is not named."""
    scene = scenes.paper_demes(1.2, "strip", **{"mesh.divisions": 8, "dr.membrane_net": "triangles"})
    state = list(dr.sweep(scene, [1.2]))[-1]
    mirror = other_starts.from_mirror(state)
    assert mirror.converged and mirror.branch != state.branch
    assert mirror.bending_angle == pytest.approx(-state.bending_angle, abs=1e-3)
    assert mirror.energy["total"] == pytest.approx(state.energy["total"], rel=1e-8)
    assert np.allclose(mirror.x, state.x * [1.0, 1.0, -1.0], atol=1e-4 * scene.outline.side_length)


def test_a_state_against_the_lift_names_its_mirror_image_of_the_same_energy():
    """Where the path's state is against the scene's lift (here: DR's up curl read under a
    scene whose lift is down), its mirror image through the flat plane, a stable state of the
    same energy on the lift's side, is named on it; a state on the lift's side solves nothing."""
    scene = scenes.paper_demes(1.2, "strip", **{"mesh.divisions": 8, "dr.membrane_net": "triangles"})
    state = list(dr.sweep(scene, [1.2]))[-1]
    assert state.branch == "up" and other_starts.mirror_state(state) is None
    assert "mirror_state" not in state.info
    against = replace(state, scene=scene.updated(**{"perturbation.amplitude": -0.5}), info=dict(state.info))
    assert other_starts.against_the_lift(against)
    mirror = other_starts.mirror_state(against)
    assert mirror is not None and mirror.branch == "down" and mirror.info["stable"]
    assert mirror.bending_angle == pytest.approx(-state.bending_angle, abs=1e-3)
    noted = against.info["mirror_state"]
    assert noted["branch"] == "down" and noted["energy_total"] == pytest.approx(state.energy["total"], rel=1e-6)
    words = "its mirror image through the flat plane is a stable state of the same energy on the lift's side"
    assert words in against.message and any(words in r for r in against.remarks)


def test_demes_solve_other_starts_names_the_lower_state_under_the_table(tmp_path, capsys):
    code = main(["solve", "--mesh-levels", "8", "--element", "P1", "--prestretch", "1.2", "--other-starts",
                 "--set", "frame.film_offset=true", "--frame-model", "strip", "--out", str(tmp_path),
                 "--no-progress"])
    assert code == 0
    printed = capsys.readouterr().out
    notes = [line for line in printed.splitlines() if line.startswith("  1.2: ")]
    assert len(notes) == 1 and "a stable state of lower energy was found from its mirror image" in notes[0]
