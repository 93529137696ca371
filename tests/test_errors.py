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


@pytest.mark.parametrize(
    "change, words",
    [
        ({"dr.tolerance": 5e-324}, ["dr.tolerance", "1e-12"]),
        ({"dr.tolerance": 1.0}, ["dr.tolerance", "0.1"]),
        ({"dr.mass_safety": 0.5}, ["dr.mass_safety", "unstable"]),
        ({"dr.prestretch_step": 1e-9}, ["dr.prestretch_step", "0.001"]),
        ({"dr.prestretch_step": 5e-324}, ["dr.prestretch_step"]),
        ({"dr.prestretch_step_max": 0.01}, ["dr.prestretch_step_max", "dr.prestretch_step = 0.025"]),
        ({"dr.prestretch_step_max": 11.0}, ["dr.prestretch_step_max", "10"]),
        ({"dr.coarse_start": 1}, ["dr.coarse_start", "true or false"]),
        ({"mesh.divisions": 10**30}, ["mesh.divisions", "at most 400"]),
        ({"mesh.divisions": 1e9}, ["mesh.divisions", "whole number"]),
        ({"frame.side_length": 1e160}, ["frame.side_length", "100000"]),
        ({"frame.corner_radius": 0.0}, ["frame.corner_radius", "half the strip width"]),
        ({"frame.outline": "polygon", "frame.vertices": 0}, ["frame.vertices", "list of 3 to 256"]),
        ({"frame.outline": "polygon", "frame.vertices": [{"x": 1}, {"x": 2}, {"x": 3}]}, ["frame.vertices[0]"]),
        ({"frame.outline": "polygon", "frame.vertices": [[float(k), float(k * k)] for k in range(10_000)]},
         ["frame.vertices", "256"]),
        ({"prestretch": float("nan")}, ["loading.prestretch", "finite"]),
        ({"prestretch": 1e9}, ["loading.prestretch", "above 10"]),
        ({"perturbation.amplitude": 1e300}, ["perturbation.amplitude", "larger than"]),
        ({"fem.refinement": 4, "mesh.divisions": 100}, ["fem.refinement", "800"]),
        ({"name": "../x"}, ["name", "output folder"]),
    ],
)
def test_every_size_and_setting_is_bounded_before_work_starts(change, words):
    with pytest.raises(scenes.SceneError) as err:
        scenes.load("demes_paper").updated(**change)
    for w in words:
        assert w in str(err.value)


@pytest.mark.parametrize("outline", [
    [[0, 0], [40, 0], [40, 40], [0, 40]],                      # square
    [[0, 0], [40, 0], [40, 20], [20, 20], [20, 40], [0, 40]],  # L-shaped
    [[0, 0], [40, 0], [0, 40]],                                # right triangle
])
def test_sharp_cornered_frames_are_refused(outline):
    """corner_radius = 0 with a taped base would solve to 'converged' with all-NaN positions: refused."""
    with pytest.raises(scenes.SceneError, match="frame.corner_radius"):
        scenes.load("demes_paper").updated(**{"frame.outline": "polygon", "frame.vertices": outline,
                                               "frame.corner_radius": 0.0})


@pytest.mark.parametrize("content, words", [
    (b"\xff\xfe[frame]\n", "not UTF-8"),
    (b"x = " + b"[" * 5000 + b"]" * 5000, "nested too deeply"),
    (b"[frame]\nvertices = 0\noutline = 'polygon'\n", "frame.vertices"),
    (b"[mesh]\ndivisions = " + b"7" * 5000 + b"\n", "mesh.divisions is an integer too long"),
    (b"mesh = { divisions = " + b"7" * 5000 + b" }\n", "a field is an integer too long"),
])
def test_bad_scene_files_are_named(tmp_path, content, words):
    path = tmp_path / "bad.toml"
    path.write_bytes(content)
    with pytest.raises(scenes.SceneError, match=words):
        scenes.load(path)
    with pytest.raises(scenes.SceneError, match="not found"):
        scenes.load(tmp_path)  # a folder
    with pytest.raises(scenes.SceneError):
        scenes.load(tmp_path / ("x" * 5000))  # a name too long for the file system


def test_project_errors_share_one_base_class():
    from fem_reference import FEMError

    for error in (scenes.SceneError, dr.DRError, FEMError):
        assert issubclass(error, scenes.DemesError)


def test_a_prestretch_path_with_nan_is_refused_by_both_solvers():
    import fem_reference

    scene = scenes.paper_demes(1.2, **{"mesh.divisions": 4})
    for bad in (float("nan"), float("inf"), 0.5):
        with pytest.raises(scenes.SceneError):
            list(dr.sweep(scene, [bad]))
        with pytest.raises(scenes.SceneError):
            list(fem_reference.sweep(scene, [bad]))


def test_the_fem_time_limit_is_checked_inside_newton():
    """A deadline already passed stops Newton after its first evaluation, not at the end of a
    continuation step."""
    import time

    from fem_reference.model import DemesProblem
    from fem_reference.newton import newton

    pb = DemesProblem(scenes.paper_demes(1.2, "strip", **{"mesh.divisions": 6}), 0, "P1")
    pb.lam = 1.2
    out = newton(pb, pb.initial_guess(), max_iterations=50, deadline=time.perf_counter() - 1.0)
    assert out.status == "time_limit" and out.iterations == 0 and not out.converged
