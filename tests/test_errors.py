"""Bad input gives a clear error naming the field and the fix, never a deep traceback."""

import numpy as np
import pytest

import dr
import scenes


@pytest.mark.parametrize(
    "change, words",
    [
        ({"frame.E": -2600.0}, ["frame.E", "positive"]),
        ({"membrane.thickness": 0.0}, ["membrane.thickness", "positive"]),
        ({"prestretch": 0.9}, ["prestretch", "below 1"]),
        ({"mesh.divisions": 3}, ["mesh.divisions", "at least 4"]),
        ({"frame.corner_radius": 20.0}, ["frame.corner_radius", "too large", "less than"]),
        ({"frame.model": "steel"}, ["frame.model", "'paper'", "'strip'"]),
        ({"frame.thickness": 5.0}, ["frame.thickness", "smaller than frame.width"]),
        ({"perturbation.amplitude": 0.0}, ["perturbation.amplitude", "symmetry"]),
        ({"loading.sweep": [1.0, 0.8]}, ["loading.sweep[1]", "below 1"]),
        ({"frame.outline": "polygon"}, ["frame.vertices"]),
        ({"frame.outline": "polygon", "frame.vertices": [[0, 0], [10, 10], [10, 0], [0, 10]]}, ["cross"]),
    ],
)
def test_bad_scene_fields_are_named(change, words):
    with pytest.raises(scenes.SceneError) as err:
        scenes.load("demes_paper").updated(**change)
    for w in words:
        assert w in str(err.value)


def test_unknown_fields_and_sections_are_named():
    with pytest.raises(scenes.SceneError, match="frame.colour"):
        scenes.Scene.from_dict({"frame": {"colour": "red"}})
    with pytest.raises(scenes.SceneError, match="'framework'"):
        scenes.Scene.from_dict({"framework": {}})


def test_missing_scene_file_lists_the_builtins(tmp_path):
    with pytest.raises(scenes.SceneError, match="demes_paper"):
        scenes.load(tmp_path / "nope.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[frame\nE = 1")
    with pytest.raises(scenes.SceneError, match="not valid TOML"):
        scenes.load(bad)


def test_dr_rejects_a_model_without_supports():
    m = dr.Model([[0, 0, 0], [1, 0, 0]])
    m.add_link(0, 1, EA=1.0)
    with pytest.raises(dr.DRError, match="no supports"):
        dr.relax(m)


@pytest.mark.parametrize(
    "build, words",
    [
        (lambda m: m.add_link(0, 1, EA=-1.0), "EA must be positive"),
        (lambda m: m.add_link(0, 0, EA=1.0), "itself"),
        (lambda m: m.add_link(0, 9, EA=1.0), "not a node"),
        (lambda m: m.add_link(0, 1, EA=1.0, rest_length=0.0), "rest lengths must be positive"),
        (lambda m: m.add_cluster([0], EA=1.0), "at least 2 nodes"),
        (lambda m: m.add_beam([0, 1, 2], EI=0.0), "EI"),
        (lambda m: m.add_beam([0, 1, 0], EI=1.0), "visits a node twice"),
        (lambda m: m.add_beam([0, 1, 2], EI=1.0, EI_strong=2.0), "also needs GJ and orientation"),
        (lambda m: m.clamp(0, (0, 0, 0)), "non-zero"),
        (lambda m: m.support(0, axes="w"), "axes"),
        (lambda m: m.add_load(1, (np.nan, 0, 0)), "finite"),
    ],
)
def test_bad_model_input_is_named(build, words):
    m = dr.Model([[0, 0, 0], [1, 0, 0], [2, 0.1, 0]])
    with pytest.raises(dr.DRError, match=words):
        build(m)


def test_a_loose_node_is_named():
    m = dr.Model([[0, 0, 0], [1, 0, 0], [5, 5, 5]])
    m.support(0)
    m.add_link(0, 1, EA=1.0)
    with pytest.raises(dr.DRError, match="node 2 can move but no element resists it"):
        dr.relax(m)


def test_bad_solver_settings_are_named():
    m = dr.Model([[0, 0, 0], [1, 0, 0]])
    m.support(0)
    m.add_link(0, 1, EA=1.0)
    with pytest.raises(dr.DRError, match="tol"):
        dr.relax(m, tol=-1)
    with pytest.raises(dr.DRError, match="mass_safety"):
        dr.relax(m, mass_safety=0)
    with pytest.raises(dr.DRError, match="x_start"):
        dr.relax(m, x_start=np.zeros((3, 3)))


def small_cantilever() -> dr.Model:
    x = np.zeros((11, 3))
    x[:, 0] = np.arange(11.0)
    m = dr.Model(x)
    m.clamp(0, (1, 0, 0))
    m.add_beam(np.arange(11), EI=1.0, EA=100.0)
    m.add_load(10, (0, 0, -0.01))
    return m


def test_unstable_time_step_is_reported_not_returned_as_nan():
    """Masses far below the stability limit (f = 0.05 << 1): DR must say it diverged, name
    the remedy, and return the last finite state."""
    res = dr.relax(small_cantilever(), mass_safety=0.05, max_iterations=100_000)
    assert res.status == "diverged" and not res.converged
    assert "mass_safety" in res.message
    assert np.all(np.isfinite(res.x))


def test_non_convergence_says_so_with_residual_and_iterations():
    res = dr.relax(small_cantilever(), max_iterations=50)
    assert res.status == "max_iterations" and not res.converged
    assert "50" in res.message and "residual" in res.message


def test_dr_rejects_a_membrane_law_it_does_not_model():
    with pytest.raises(scenes.SceneError, match="neo-hookean"):
        dr.build(scenes.paper_demes(1.2, **{"membrane.law": "neo-hookean"}))
