"""Which way a state curled (its branch) and whether its bending angle can be read: built
shapes with known angles, a mirror image, a film and a frame through themselves, and both
solvers on a scene lifted down."""

from __future__ import annotations

import numpy as np
import pytest

import scenes
from results import Result
from scenes.mesh import membrane_mesh


def curl_profile(flat: float, radius: float, turn: float):
    """A midline profile: flat (in the plane) for reference heights Y < ``flat`` mm, then on a
    circle of ``radius`` mm through ``turn`` rad (up for turn > 0), then straight."""

    def profile(Y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        u = np.clip(Y - flat, 0.0, None)
        bent = np.minimum(u, abs(turn) * radius)
        psi = np.sign(turn) * bent / radius
        y = flat + radius * np.sin(np.abs(psi)) + (u - bent) * np.cos(turn)
        z = np.sign(turn) * radius * (1.0 - np.cos(psi)) + (u - bent) * np.sin(turn)
        return np.where(Y < flat, Y, y), np.where(Y < flat, 0.0, z)

    return profile


def shaped_state(scene: scenes.Scene, profile) -> tuple[Result, float]:
    """The scene's film and frame (its refinement-0 mesh) with every point at flat (X, Y) moved
    to (X, y(Y), z(Y)); and the closed-form bending angle of the apex, deg (-180, 180]."""
    mesh = membrane_mesh(scene, 0)
    y, z = profile(mesh.nodes[:, 1])
    x = np.column_stack([mesh.nodes[:, 0], y, z])
    flat = np.column_stack([mesh.nodes, np.zeros(len(mesh.nodes))])
    res = Result(solver="test", x=x, x0=flat, converged=True, status="converged", message="made",
                 iterations=0, residual=0.0, wall_time=0.0, energy={}, frame_nodes=mesh.frame_nodes,
                 frame_s=mesh.frame_s, scene=scene)
    res.check_crossings(mesh.triangles, contact_checked=False)
    ya, za = profile(np.array([scene.outline.height()]))
    return res, float(np.degrees(np.arctan2(za[0], ya[0])))


SCENE = scenes.paper_demes(1.3, "strip", **{"mesh.divisions": 16})


@pytest.mark.parametrize("turn", [40.0, 150.0])
def test_a_curl_up_reads_its_angle_and_its_mirror_the_negative(turn):
    """A frame curled up on a circle reads the closed-form angle of its apex, branch 'up'; its
    mirror image in the flat plane (z -> -z), the same shape curled down, reads minus that
    angle, branch 'down'. Neither passes through itself."""
    up, closed_form = shaped_state(SCENE, curl_profile(3.0, 20.0, np.radians(turn)))
    assert closed_form > 0.0
    assert up.bending_angle == pytest.approx(closed_form, abs=0.5)
    assert (up.branch, up.info["branch"], up.status, up.converged) == ("up", "up", "converged", True)
    assert up.info["angle_unreadable"] is None and up.info["crossing"] is None
    down, _ = shaped_state(SCENE, curl_profile(3.0, 20.0, -np.radians(turn)))
    mirror = up.x * [1.0, 1.0, -1.0]
    assert np.allclose(down.x, mirror, atol=1e-9)
    assert down.bending_angle == pytest.approx(-up.bending_angle, abs=1e-9)
    assert down.branch == "down" and down.converged
    # the scene lifts the apex up: a state that went down says so
    assert "the apex went down, against the scene's lift" in down.message
    assert "against" not in up.message
    row = down.summary()
    assert row["branch"] == "down" and row["angle_unreadable"] == "" and row["contact_checked"] is False


@pytest.mark.parametrize("radius, turn", [(20.0, 40.0), (8.0, 150.0), (6.0, 250.0)])
def test_an_outline_without_mirror_symmetry_reads_its_apex_angle(radius, turn):
    """On a quadrilateral whose apex is not above the base midpoint (the two sides from the base
    to the apex are 67 and 93 mm long), curls up to past half a turn read the closed-form angle of the
    line base midpoint -> apex."""
    scene = scenes.load("asymmetric_quadrilateral")
    o = scene.outline
    assert abs(2 * o.apex_arc_length() - o.length) > 10.0
    res, closed_form = shaped_state(scene, curl_profile(3.0, radius, np.radians(turn)))
    assert res.info["crossing"] is None and res.branch == "up"
    assert res.bending_angle % 360.0 == pytest.approx(closed_form % 360.0, abs=1e-6)
    assert ("curled past half a turn" in res.message) == (res.bending_angle > 180.0)


def test_a_flat_state_is_on_the_flat_branch():
    flat, closed_form = shaped_state(SCENE, lambda Y: (Y, 0.0 * Y))
    assert closed_form == 0.0 and flat.bending_angle == pytest.approx(0.0, abs=1e-9)
    assert flat.branch == "flat" and flat.converged


def test_a_film_through_itself_is_unreadable():
    """Flat for 10 mm, then a 5 mm circle through 300 deg: the straight rest comes back down
    through the flat film at y = 10 - 5 tan 30 = 7.1 mm. That state cannot be built; its angle
    (about 330 deg) is not reported: NaN, status 'unreadable', the reason named."""
    res, _ = shaped_state(SCENE, curl_profile(10.0, 5.0, np.radians(300.0)))
    assert np.isnan(res.bending_angle)
    assert res.info["crossing"] == "film_crossing" and res.info["angle_unreadable"] == "film_crossing"
    assert (res.status, res.converged) == ("unreadable", False)
    assert "the bending angle cannot be read" in res.message and "passes through" in res.message
    assert res.branch == "up"  # which way it went is still known
    row = res.summary()
    assert np.isnan(row["bending_angle"]) and row["angle_unreadable"] == "film_crossing"
    assert row["converged"] is False
    # the same curl without the flat run turns 300 deg clear of the film: readable
    clear, closed_form = shaped_state(SCENE, curl_profile(0.5, 5.0, np.radians(300.0)))
    assert clear.info["crossing"] is None and clear.converged
    assert clear.bending_angle % 360.0 == pytest.approx(closed_form % 360.0, abs=1.0)
    assert 180.0 < clear.bending_angle < 360.0
    # past half a turn the apex is behind the base, below the plane: named, not a bare number
    half = "curled past half a turn: the apex is behind the base and below the flat plane"
    assert half in clear.message and any(half in r for r in clear.remarks)
    assert "curled past half a turn" not in res.message  # an angle not read is not described


def test_a_frame_collapsed_through_its_base_is_unreadable():
    """A flat frame whose apex was pulled in the plane past the base (y = Y - c Y^2 brings it to
    y = -3 mm), as the Table I frame collapses: its sides cross the base, and the angle of a
    flat frame with the apex behind the base (atan2(0, -3) = 180 deg) says nothing."""
    height = SCENE.outline.height()
    c = (height + 3.0) / height**2
    res, closed_form = shaped_state(SCENE, lambda Y: (Y - c * Y**2, 0.0 * Y))
    assert abs(closed_form) == pytest.approx(180.0)
    assert res.info["crossing"] == "frame_crossing"
    assert np.isnan(res.bending_angle) and res.status == "unreadable"
    assert "the frame passes through itself" in res.message
    assert res.branch == "flat"  # it never left the plane


def test_a_reading_past_a_whole_turn_is_unreadable_and_a_sweep_can_read_it_again():
    """Continued from a previous state at 480 deg, a 100 deg curl reads 460: past a whole turn,
    not read. Read again as the continuation of 90 deg, it is the converged 100 deg state."""
    res, closed_form = shaped_state(SCENE, curl_profile(3.0, 20.0, np.radians(180.0)))
    theta = res.bending_angle
    assert theta == pytest.approx(closed_form, abs=0.5)
    res.continue_from(theta + 360.0)
    assert np.isnan(res.bending_angle) and res.info["angle_unreadable"] == "over_a_turn"
    assert (res.status, res.converged) == ("unreadable", False)
    assert "whole turn" in res.message
    res.continue_from(theta - 10.0)
    assert res.bending_angle == pytest.approx(theta, abs=1e-9)
    assert (res.status, res.converged, res.message) == ("converged", True, "made")


LIFTED_DOWN = scenes.paper_demes(1.2, "strip", **{"mesh.divisions": 6, "perturbation.amplitude": -0.5})


@pytest.mark.parametrize("solver", ["dr", "fem"])
def test_a_scene_lifted_down_curls_down_in_both_solvers(solver):
    """The model is symmetric in the flat plane (the film on the strip's centreline): lifted
    down, the frame curls down by the angle it curls up when lifted up, and says 'down'."""
    import dr
    import fem_reference

    solve = dr.solve if solver == "dr" else fem_reference.solve
    down = solve(LIFTED_DOWN)
    up = solve(LIFTED_DOWN.updated(**{"perturbation.amplitude": 0.5}))
    assert down.converged and up.converged
    assert up.branch == "up" and up.bending_angle > 30.0  # curled, not flat
    assert down.info["branch"] == "down" and down.bending_angle < 0.0
    assert down.bending_angle == pytest.approx(-up.bending_angle, abs=0.05)
    assert down.info["contact_checked"] is True and down.info["angle_unreadable"] is None
