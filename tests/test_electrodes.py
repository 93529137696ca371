"""Electrodes over parts of the film ([[electrodes]]): the scene's checks, the film's energy
under a region against its closed form, a whole-film region against the one-electrode film, a
mirror law, and DR against the FEM on one discrete problem with half the film electroded."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import dr
import fem_reference
import scenes
from dr.demes_model import build
from fem_reference.actuation import voltage_sweep as fem_voltage_sweep
from fem_reference.model import DemesProblem
from scenes import SceneError
from scenes.electric import dielectric_coefficient, driven_at, electrode_coverage
from validation.cli import main
from validation.design.grid import GridError, grid_from_dict

LEFT = [[-60.0, -10.0], [0.0, -10.0], [0.0, 80.0], [-60.0, 80.0]]
RIGHT = [[0.0, -10.0], [60.0, -10.0], [60.0, 80.0], [0.0, 80.0]]
EVERYWHERE = [[-60.0, -10.0], [60.0, -10.0], [60.0, 80.0], [-60.0, 80.0]]
HALVES = [{"name": "left", "region": LEFT}, {"name": "right", "region": RIGHT}]


@pytest.fixture(scope="module")
def scene():
    """The paper's outline, coarse, on DR's triangles: DR and the FEM's P1 on one mesh."""
    return scenes.load("demes_paper").updated(
        **{"mesh.divisions": 8, "dr.membrane_net": "triangles", "loading.prestretch": 1.2})


@pytest.mark.parametrize("electrodes, words", [
    ([{"region": LEFT}, {"region": LEFT}], "overlap"),
    ([{"name": "a", "region": LEFT}, {"name": "a", "region": RIGHT}], "used twice"),
    ([{"region": [[100, 100], [120, 100], [120, 120]]}], "electrodes[0].region ('e1') covers no film"),
    ([{"region": [[0, 0], [10, 10], [10, 0], [0, 10]]}], "not a simple polygon"),
    ([{"region": LEFT, "voltage": -5}], "electrodes[0].voltage"),
    ([{"region": LEFT}, {"voltage": 100}], "electrodes[1].region is missing"),
    ([{"region": LEFT, "volts": 100}], "unknown field electrodes[0].volts"),
    ([{"name": "a.b", "region": LEFT}], "electrodes[0].name"),
    ({"region": LEFT}, "list of tables"),
])
def test_bad_electrodes_are_named(scene, electrodes, words):
    with pytest.raises(SceneError) as err:
        scene.updated(electrodes=electrodes)
    assert words in str(err.value)


def test_electrodes_beside_a_whole_film_voltage_are_refused(scene):
    with pytest.raises(SceneError, match="loading.voltage = 100 V"):
        scene.updated(**{"loading.voltage": 100.0}).updated(electrodes=HALVES)


def test_electrodes_round_trip_and_change_by_name(scene):
    two = scene.updated(electrodes=HALVES)
    assert scenes.Scene.from_dict(two.to_dict()) == two
    assert [e.voltage for e in two.updated(**{"electrodes.right.voltage": 900}).electrodes] == [0.0, 900.0]
    assert [e.voltage for e in driven_at(two, 500.0, ["left"]).electrodes] == [500.0, 0.0]
    with pytest.raises(SceneError, match="no such electrode"):
        driven_at(two, 500.0, ["middle"])
    with pytest.raises(SceneError, match="no \\[\\[electrodes\\]\\]"):
        driven_at(scene, 500.0, ["left"])


def test_a_design_grid_sweeps_an_electrode_by_name(scene, tmp_path):
    path = tmp_path / "two.toml"
    path.write_text('[mesh]\ndivisions = 8\n[[electrodes]]\nname = "left"\n'
                    'region = [[-60, -10], [0, -10], [0, 80], [-60, 80]]\n')
    grid = grid_from_dict({"scene": str(path), "prestretch": [1.2],
                           "product": {"electrodes.left.voltage": [0, 1500]}}, base_dir=Path("/"))
    assert [f.fields for f in grid.families] == [{"electrodes.left.voltage": v} for v in (0.0, 1500.0)]
    with pytest.raises(GridError, match="no electrode named 'mid'"):
        grid_from_dict({"scene": str(path), "product": {"electrodes.mid.voltage": [0, 1]}}, base_dir=Path("/"))


corner = st.tuples(st.floats(-40, 40), st.floats(-10, 60))


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.tuples(corner, corner), min_size=1, max_size=3))
def test_hostile_rectangles_are_refused_or_share_the_film(scene, boxes):
    # random rectangles: overlapping, outside, degenerate; either a named SceneError or
    # electrodes whose shares of every triangle add up to at most 1
    electrodes = [{"region": [[a[0], a[1]], [b[0], a[1]], [b[0], b[1]], [a[0], b[1]]], "voltage": 1000.0}
                  for a, b in boxes]
    try:
        built = scene.updated(electrodes=electrodes)
    except SceneError as err:
        assert "electrodes" in str(err)
        return
    model = build(built).model
    cover = electrode_coverage(built, model.nodes[model.dielectric_triangles])
    assert np.all(cover >= 0) and np.all(cover.sum(axis=1) <= 1 + 1e-9) and cover.sum() > 0
    assert np.isfinite(model.dielectric_energy(model.nodes)[0])


def test_flat_film_energy_under_a_region_is_minus_c_times_its_area(scene):
    # a 12 x 9 mm rectangle inside the film, its edges across the mesh's triangles: the flat
    # film's energy -c J^2 dA with J = 1 is -c times the rectangle's area in both solvers
    voltage = 2000.0
    region = [[-7.0, 6.3], [5.0, 6.3], [5.0, 15.3], [-7.0, 15.3]]
    patch = scene.updated(electrodes=[{"region": region, "voltage": voltage}])
    expected = -dielectric_coefficient(patch, voltage) * 12.0 * 9.0
    model = build(patch).model
    assert model.dielectric_energy(model.nodes)[0] == pytest.approx(expected, rel=1e-12)
    fem = DemesProblem(patch, 0, "P2")
    assert fem.dielectric.energy(fem.X) == pytest.approx(expected, rel=1e-12)
    # and only the triangles under it are in DR's model
    assert 0 < len(model.pack().diel_idx) < len(model.dielectric_triangles) / 4


def test_one_electrode_over_the_whole_film_is_the_whole_film_electrode(scene):
    volts = [0.0, 1500.0]
    whole = list(dr.voltage_sweep(scene, volts))[-1]
    region = list(dr.voltage_sweep(scene.updated(electrodes=[{"region": EVERYWHERE}]), volts))[-1]
    assert np.abs(whole.x - region.x).max() < 1e-9
    assert region.info["capacitor_energy"] == pytest.approx(whole.info["capacitor_energy"], rel=1e-12)


@pytest.mark.slow
def test_one_half_electroded_mirrors_the_other_and_dr_agrees_with_the_fem(scene):
    two = scene.updated(electrodes=HALVES)
    volts = [0.0, 1000.0, 2000.0]
    left = list(dr.voltage_sweep(two, volts, electrodes=["left"]))
    right = list(dr.voltage_sweep(two, volts, electrodes=["right"]))
    fem = list(fem_voltage_sweep(two, volts, electrodes=["left"]))
    assert [r.info["voltage_V"] for r in left] == volts and all(r.converged for r in left + right + fem)
    # half the film actuated uncurls the frame, less than the whole film would
    whole = list(dr.voltage_sweep(scene, volts))
    assert left[0].bending_angle > left[-1].bending_angle > whole[-1].bending_angle
    assert left[-1].scene.electrodes[0].voltage == 2000.0 and left[-1].scene.electrodes[1].voltage == 0.0
    for a, b, f in zip(left, right, fem):
        # the scene is mirror-symmetric: the right half driven gives the mirror image
        assert b.bending_angle == pytest.approx(a.bending_angle, abs=0.01)
        assert b.energy["total"] == pytest.approx(a.energy["total"], rel=1e-5)
        # one discrete problem: DR triangles and the FEM's P1
        assert a.bending_angle == pytest.approx(f.bending_angle, abs=0.1)
        assert a.energy["total"] == pytest.approx(f.energy["total"], rel=1e-4)
        assert a.info["capacitor_energy"] == pytest.approx(f.info["capacitor_energy"], rel=1e-4)
    # the Maxwell pressure acts under the driven electrode only
    pressure = left[-1].blocks["membrane_surface"].cell_data["maxwell_pressure_MPa"]
    assert pressure.max() > 0 and np.count_nonzero(pressure == 0) > len(pressure) / 3


def test_actuate_names_an_unknown_electrode(scene, tmp_path, capsys):
    code = main(["actuate", "--electrode", "middle", "--set", "mesh.divisions=6", "--out", str(tmp_path),
                 "--no-progress"])
    assert code == 2
    err = capsys.readouterr().err
    assert "--electrode middle" in err and "Traceback" not in err


def test_the_fem_solves_the_state_at_no_pre_stretch_with_a_voltage_on_instead_of_taking_the_flat_one():
    """Without pre-stretch the flat film is stress-free only at 0 V: with a voltage on, its
    Maxwell stress compresses it, the flat state is no equilibrium (a force remains) and the
    film buckles. The FEM path solves that state: a stable equilibrium of lower energy than the
    flat film's, said to be one; at 0 V the state at lambda = 1 stays the flat one."""
    from fem_reference.model import DemesProblem

    base = scenes.load("demes_paper").updated(**{"mesh.divisions": 6, "fem.element": "P1", "frame.model": "strip"})
    flat_state = next(fem_reference.sweep(base, [1.0]))
    assert flat_state.converged and "the flat state" in flat_state.message and not np.any(flat_state.x[:, 2])
    driven = base.updated(**{"loading.voltage": 1000.0})
    problem = DemesProblem(driven, 0, "P1")
    problem.lam = 1.0
    flat = problem.initial_guess(lift=False)
    assert np.abs(problem.evaluate(flat, 1).gradient[problem.free]).max() > 1e-4  # N: no equilibrium
    state = next(fem_reference.sweep(driven, [1.0]))
    assert state.converged and state.info["stable"] and "the flat state" not in state.message
    assert state.residual < 1e-8
    assert problem.energy(state.x.reshape(-1)) < problem.energy(flat)
