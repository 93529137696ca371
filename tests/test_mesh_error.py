"""The discretisation error each state of ``demes solve`` carries (validation/solve/mesh_error.py)."""

import csv
import math

import pytest

import dr
import fem_reference
import scenes
from validation.solve import mesh_error
from validation.cli import main


def test_the_csv_carries_the_richardson_estimate_of_the_fem_levels(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["solve", "--prestretch", "1.1", "--mesh-levels", "6", "12", "24", "--out", str(out),
                 "--no-progress"]) == 0
    printed = capsys.readouterr().out
    assert "theta*[deg]" in printed and "+-[deg]" in printed and "3 meshes, order observed" in printed
    with open(out / "fem_strip.csv") as f:
        (row,) = list(csv.DictReader(f))
    scene = scenes.load("demes_paper").updated(**{"mesh.divisions": 6, "fem.element": "P2"})
    (levels,) = list(fem_reference.sweep_levels(scene, [1.1], refinement=2))
    assert [s.info["refinement"] for s in levels] == [0, 1, 2]
    # two runs of the same path agree to Newton's tolerance (1e-8 of the force scale), not bit for bit
    assert float(row["bending_angle [deg]"]) == pytest.approx(levels[-1].bending_angle, abs=1e-6)  # the finest's
    for name, unit in mesh_error.QUANTITIES:
        est = fem_reference.richardson([s.summary()[name] for s in levels])
        assert est.observed
        assert float(row[f"{name}_extrapolated [{unit}]"]) == pytest.approx(est.extrapolated, rel=1e-6)
        assert float(row[f"{name}_error [{unit}]"]) == pytest.approx(est.error, rel=1e-5)
    assert row["mesh_levels"] == "6 12 24" and row["converged"] == "yes"


def test_two_dr_meshes_give_the_formal_order_and_a_factor_of_three():
    scene = scenes.load("demes_paper").updated(**{"dr.membrane_net": "links"})
    (me,) = list(mesh_error.dr_levels(scene, [1.1], [6, 12]))
    coarse = next(iter(dr.sweep(scene.updated(**{"mesh.divisions": 6}), [1.1])))
    q_h, q_h2 = coarse.bending_angle, me.state.bending_angle
    est = me.estimates["bending_angle"]
    # q* = q_h/2 + (q_h/2 - q_h) / (2^2 - 1), error 3 |q_h/2 - q_h| / (2^2 - 1)
    assert est.extrapolated == pytest.approx(q_h2 + (q_h2 - q_h) / 3, rel=1e-12)
    assert est.error == pytest.approx(abs(q_h2 - q_h), rel=1e-12)
    assert me.note == "2 meshes, order 2 assumed" and me.divisions == [6, 12]


def test_a_state_without_an_estimate_says_why(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["solve", "--solver", "dr", "--prestretch", "1.1", "--mesh-levels", "6", "--out", str(out),
                 "--no-progress"]) == 0
    assert "one mesh: no error estimate" in capsys.readouterr().out
    with open(out / "dr_strip.csv") as f:
        (row,) = list(csv.DictReader(f))
    assert math.isnan(float(row["bending_angle_error [deg]"])) and row["mesh_error"] == "one mesh: no error estimate"
    fine = next(iter(fem_reference.sweep(scenes.paper_demes(1.1, **{"mesh.divisions": 6}), [1.1], refinement=0)))
    assert mesh_error.estimate([None, fine], [3, 6]).note == "the coarser level did not converge: no error estimate"
    assert mesh_error.estimate([fine, None, fine], [3, 6, 12]).estimates == {}


def test_mesh_levels_must_double():
    with pytest.raises(scenes.SceneError, match="double"):
        mesh_error.check_levels([10, 15])
    assert mesh_error.dr_default_levels(scenes.load("demes_paper")) == [7, 14, 28]
    assert mesh_error.dr_default_levels(scenes.load("demes_paper").updated(**{"mesh.divisions": 10})) == [5, 10]
