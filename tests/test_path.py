"""The path rules both solvers share (results.path), and the path on a rectangle: the FEM's state
at a pre-stretch does not depend on the levels asked for, the lift's sign only mirrors it, and
DR follows the same path."""

import numpy as np
import pytest

import dr
import fem_reference
import scenes
from dr.symmetry import kept_by, restore
from results.path import JUMP_FLOOR, LOCATE, STRAY, jumped, planar, side_of_mode, strayed

RECT = {"frame.outline": "polygon", "frame.vertices": [[-20.0, 0.0], [20.0, 0.0], [20.0, 60.0], [-20.0, 60.0]],
        "frame.corner_radius": 4.0, "mesh.divisions": 8}


def _modes():
    nodes = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0], [5.0, 10.0]])
    lift = np.zeros((5, 3))
    lift[:, 2] = 0.5 * (nodes[:, 1] / 10.0) ** 2
    return nodes, lift


def test_the_apex_goes_to_the_lifts_side_and_a_twist_follows_the_lift():
    nodes, lift = _modes()
    apex = 4
    curl_down = np.zeros((5, 3))
    curl_down[:, 2] = -lift[:, 2] / lift[:, 2].max()
    flat = np.zeros((5, 3))
    flat[:, :2] = nodes - [5.0, 0.0]  # symmetric about x = 0
    assert side_of_mode(curl_down, apex=apex, lift=lift, up=1.0, flat=flat) == -1.0  # flipped: the apex goes up
    assert side_of_mode(curl_down, apex=apex, lift=lift, up=-1.0, flat=flat) == 1.0
    twist = np.zeros((5, 3))
    twist[[2, 3], 2] = [1.0, -1.0]  # the apex stays in the plane
    tilted = lift.copy()
    tilted[2, 2] -= 0.1  # the scene's asymmetry leans the lift to node 3
    assert side_of_mode(twist, apex=apex, lift=tilted, up=1.0, flat=flat) == -1.0
    # a lift symmetric about x = 0 does not see a twist: the side x > 0 goes to the lift's side
    assert side_of_mode(twist, apex=apex, lift=lift, up=1.0, flat=flat) == 1.0
    assert side_of_mode(-twist, apex=apex, lift=lift, up=1.0, flat=flat) == -1.0
    assert side_of_mode(twist, apex=apex, lift=lift, up=-1.0, flat=flat) == -1.0


def test_a_jump_is_a_move_far_beyond_the_paths_rate():
    side = 40.0
    assert not jumped(30.0, 0.01, None, side)  # no rate yet: never a jump
    assert not jumped(1.0, 0.01, 100.0, side)  # as the rate predicts
    assert not jumped(0.5 * JUMP_FLOOR * side, 0.01, 1.0, side)  # 50x the rate, but below the floor
    assert jumped(10.0, 0.01, 100.0, side)
    flat = np.zeros((3, 3))
    assert planar(flat + [1.0, 2.0, 0.0], flat, side) and not planar(flat + [0.0, 0.0, 1e-3], flat, side)


def test_a_step_that_ends_far_from_the_secants_prediction_strayed():
    """The secant predicts a step's move from the last one scaled to the step; a state that
    stopped short of it, along the branch (a nearer stable state) or off its direction, is a
    jump; one beyond it is left to the rate test (a branch accelerates off a bifurcation)."""
    side, rng = 40.0, np.random.default_rng(1)
    last = rng.standard_normal((30, 3))
    last *= 2.0 / np.linalg.norm(last, axis=1).max()  # 2 mm in a step of 0.01: rate 200 mm per unit
    rate, step = 200.0, 0.02
    predicted = 2.0 * last
    assert not strayed(predicted, last, rate, step, side)
    assert not strayed((1.0 - 0.9 * STRAY) * predicted, last, rate, step, side)  # a branch that slows
    assert strayed((1.0 - 1.1 * STRAY) * predicted, last, rate, step, side)  # stopped short of it
    assert not strayed(3.0 * predicted, last, rate, step, side)  # beyond it: the rate test's
    assert strayed(0.9 * predicted[::-1], last, rate, step, side)  # short of it and another way
    assert not strayed(predicted, None, rate, step, side) and not strayed(predicted, last, None, step, side)
    tiny = 0.1 * JUMP_FLOOR * side / 4.0
    assert not strayed(tiny * predicted[::-1], tiny * last, rate * tiny, step, side)  # within the floor


@pytest.fixture(scope="module")
def rectangle():
    return scenes.load("square").updated(**RECT)


def test_the_fem_state_at_a_prestretch_does_not_depend_on_the_levels_asked_for(rectangle):
    direct = list(fem_reference.sweep(rectangle, [1.3]))[-1]
    stepped = list(fem_reference.sweep(rectangle, [1.1, 1.3]))[-1]
    assert direct.converged and stepped.converged
    assert stepped.bending_angle == pytest.approx(direct.bending_angle, abs=1e-3)
    assert stepped.energy["total"] == pytest.approx(direct.energy["total"], rel=1e-8)
    assert stepped.info["stable"] and direct.info["stable"]


def test_the_lifts_sign_mirrors_the_fem_state_through_the_plane(rectangle):
    up = fem_reference.solve(rectangle.updated(prestretch=1.1))
    down = fem_reference.solve(rectangle.updated(prestretch=1.1, **{"perturbation.amplitude": -0.5}))
    assert up.branch == "up" and down.branch == "down"
    assert down.bending_angle == pytest.approx(-up.bending_angle, abs=1e-3)
    assert down.energy["total"] == pytest.approx(up.energy["total"], rel=1e-8)


def test_dr_follows_the_fems_path_through_the_twist_to_the_curl(rectangle):
    """The rectangle's flat state buckles into a twist, which turns into the curl near 1.019
    (a symmetric state, kept to round-off by Newton, to its tolerance's drift by DR): DR
    locates both events where the FEM does and leaves each on the lift's side, so it ends on
    the FEM's state, not its mirror image (same energy either way)."""
    scene = rectangle.updated(**{"dr.membrane_net": "triangles", "fem.element": "P1"})
    d = list(dr.sweep(scene, [1.1]))[-1]
    f = list(fem_reference.sweep(scene, [1.1]))[-1]
    assert d.converged and f.converged and d.info["stable"] and f.info["stable"]
    assert d.branch == f.branch == "up"
    assert d.bending_angle == pytest.approx(f.bending_angle, abs=0.1)
    assert d.energy["total"] == pytest.approx(f.energy["total"], rel=1e-5)
    assert len(d.info["snaps"]) == len(f.info["snaps"]) == 2
    for (d0, d1), (f0, f1) in zip(d.info["snaps"], f.info["snaps"]):
        assert d0 - 2 * LOCATE <= f1 and f0 - 2 * LOCATE <= d1  # the same event, located to LOCATE


def test_the_symmetries_dr_restores_are_the_models_own(rectangle):
    """The mirror where mesh and supports have it, the flip z -> -z, their product; an outline
    with no mirror keeps the flip only; a restored state keeps its symmetries exactly."""
    def names(scene):
        return {g.name for g in dr.build(scene.updated(**{"dr.membrane_net": "triangles"})).symmetries}

    assert names(rectangle) == {"flip", "mirror", "mirror_flip"}
    assert names(scenes.load("asymmetric_quadrilateral").updated(**{"mesh.divisions": 8})) == {"flip"}
    built = dr.build(rectangle.updated(**{"dr.membrane_net": "triangles"}))
    twist = built.model.nodes.copy()
    twist[:, 2] = 1e-3 * twist[:, 0] * twist[:, 1] + 1e-3  # a twist plus some drift
    (product,) = [g for g in built.symmetries if g.name == "mirror_flip"]
    assert kept_by(twist, [product], 40.0) == [product]
    restored = restore(twist, [product])
    assert np.abs(product.apply(restored) - restored).max() < 1e-12
    assert np.abs(restored[:, 2] - 1e-3 * twist[:, 0] * twist[:, 1]).max() < 1e-12


def test_a_relaxation_on_a_leash_stops_once_a_node_is_that_far_from_its_start():
    """A cantilever bent by a tip load: on a leash of half the tip's deflection the run stops,
    'too_far', with the tip just past the leash and short of its equilibrium; without one it
    reaches the equilibrium."""
    n_seg, length = 20, 80.0
    x = np.zeros((n_seg + 1, 3))
    x[:, 0] = np.linspace(0.0, length, n_seg + 1)
    m = dr.Model(x)
    m.clamp(0, (1.0, 0.0, 0.0))
    m.add_beam(np.arange(n_seg + 1), EI=0.78, EA=1300.0)
    m.add_load(n_seg, (0.0, 0.0, -3.0 * 0.78 / length**2))
    free = dr.relax(m, tol=1e-8)
    assert free.converged
    deflection = float(np.linalg.norm(free.x[-1] - x[-1]))
    leashed = dr.relax(m, tol=1e-8, leash=0.5 * deflection)
    assert leashed.status == "too_far" and not leashed.converged
    farthest = float(np.linalg.norm(leashed.x - x, axis=1).max())
    assert 0.5 * deflection < farthest < 0.75 * deflection
    assert leashed.iterations < free.iterations


def test_a_fem_path_whose_newton_solves_are_all_slow_still_reaches_its_target(monkeypatch):
    """The FEM's step shrinks after a slow Newton solve, but not below MIN_STEP: a path on which
    every solve is slow (a soft mode near round-off, at any step) reaches its target in a
    bounded number of steps instead of stalling with a vanishing step."""
    from types import SimpleNamespace

    from fem_reference.model import DemesProblem
    from fem_reference.solve import MIN_STEP, Continuation

    path = Continuation(DemesProblem(scenes.paper_demes(1.2, **{"mesh.divisions": 6}), 0, "P1"))
    slow = SimpleNamespace(converged=True, iterations=20, history=[], status="converged", y=path.y)
    monkeypatch.setattr(path, "solve_at", lambda lam, start, max_iterations=0: (slow, 0, None))
    monkeypatch.setattr(path, "_flat_saddle", lambda lam: False)
    monkeypatch.setattr(path, "_predictor", lambda lam: path.y)
    out = path.advance(1.2)
    assert out.status == "converged" and path.lam == 1.2
    assert len(out.records) <= 0.2 / MIN_STEP + 20
