"""The gallery's fast subset: one scene through `demes gallery`, both solvers on one discrete
problem, its table, CSV and picture."""

import csv

from validation.cli import main
from validation.solve.gallery import GALLERY, gallery_scene


def test_every_gallery_scene_loads_with_a_polygon_or_triangle_frame():
    for name in GALLERY:
        scene = gallery_scene(name)
        assert scene.dr.membrane_net == "triangles" and scene.fem.element == "P1"
        assert 20.0 <= scene.outline.side_length <= 100.0


def test_the_gallery_agrees_on_a_thick_film_triangle(tmp_path, capsys):
    code = main(["gallery", "--scenes", "thick_film_triangle", "--prestretch", "1.1", "--divisions", "8",
                 "--workers", "1", "--out", str(tmp_path), "--no-progress"])
    printed = capsys.readouterr().out
    with open(tmp_path / "gallery.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 1
    row = rows[0]
    assert row["dr_status"] == row["fem_status"] == "converged"
    # DR and the FEM minimise one discrete energy: one state, on the lift's side
    assert float(row["angle_difference [deg]"]) < 0.1 and float(row["energy_difference"]) < 1e-4
    assert row["dr_branch"] == row["fem_branch"] == "up"
    assert code == 0 and "1 of 1 states agree" in printed
    assert (tmp_path / "gallery.md").read_text().count("| thick_film_triangle |") == 1


def test_an_unknown_gallery_scene_is_named_before_any_work(tmp_path, capsys):
    assert main(["gallery", "--scenes", "no_such_scene", "--out", str(tmp_path), "--workers", "1"]) == 2
    assert "no_such_scene" in capsys.readouterr().err
