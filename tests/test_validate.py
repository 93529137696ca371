"""demes validate --quick end to end: files, numbers equal to direct solver calls, resume."""

import csv
import json

import numpy as np
import pytest

import dr
import fem_reference
import scenes
from validation.plan import MATCHED, REFERENCE, build_plan
from validation.validate import validate


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    out = tmp_path_factory.mktemp("report")
    files = validate(scenes.load("demes_paper"), out, quick=True, workers=2, progress=False)
    return out, files


def read_csv(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def test_report_files_exist_and_html_is_self_contained(report):
    out, files = report
    for name in ("index.html", "report.md", "states.csv", "headline.csv", "speed.csv", "time_to_error.csv",
                 "error_budget.csv", "hard_cases.csv", "reference.csv", "metrics.json"):
        assert (out / name).stat().st_size > 0, name
    html = (out / "index.html").read_text()
    assert html.count("data:image/png;base64,") >= 5  # figures inline, no external files
    assert "src='figures/" not in html
    for fig in ("bending_angle", "energy_stroke", "convergence", "pareto", "frame_curves", "shapes"):
        assert (out / "figures" / f"{fig}.png").exists()
    assert (out / "runs" / "dr_matched" / "dr_matched.pvd").exists()
    assert (out / "runs" / "fem_r0" / "fem_r0.pvd").exists()


def test_report_numbers_equal_direct_solver_calls(report):
    out, _ = report
    plan = build_plan(quick=True)
    rows = {float(r["prestretch"]): r for r in read_csv(out / "headline.csv")}
    base = scenes.load("demes_paper")
    coarse = {"mesh.divisions": 8}
    direct_dr = list(dr.sweep(base.updated(**coarse, **MATCHED), plan.sweep))
    for res in direct_dr:
        assert float(rows[res.prestretch]["theta_matched [deg]"]) == pytest.approx(res.bending_angle, abs=1e-9)
    direct_fem = {r.prestretch: r for r in fem_reference.sweep(base.updated(**coarse, **REFERENCE), plan.sweep, refinement=0)}
    states = [r for r in read_csv(out / "states.csv") if r["run"] == "fem_r0"]
    for r in states:
        lam = float(r["prestretch"])
        assert float(r["bending_angle [deg]"]) == pytest.approx(direct_fem[lam].bending_angle, abs=1e-6)


def test_reference_is_the_richardson_extrapolation_of_the_levels(report):
    out, _ = report
    rows = [r for r in read_csv(out / "reference.csv") if r["quantity"] == "bending_angle"]
    assert rows
    for r in rows:
        est = fem_reference.richardson([float(r["r0"]), float(r["r1"])])
        assert float(r["extrapolated"]) == pytest.approx(est.extrapolated, rel=1e-9, abs=1e-12)


def test_every_hard_case_has_an_outcome(report):
    out, _ = report
    rows = read_csv(out / "hard_cases.csv")
    cases = {r["case"] for r in rows}
    assert {"zero_prestretch", "stiff_frame", "soft_frame", "coarse_mesh", "asymmetric", "square_frame",
            "mass_safety_1"} <= cases
    for r in rows:
        assert r["status"] and (r["status"] != "converged" or r["iterations"])
    zero = [r for r in rows if r["case"] == "zero_prestretch" and r["solver"] == "dr"][0]
    assert zero["status"] == "converged" and abs(float(zero["bending_angle [deg]"])) < 1e-3


def test_interrupted_validation_redoes_only_what_is_missing(report):
    out, _ = report
    runs = out / "runs"
    stamps = {p.parent.name: p.stat().st_mtime_ns for p in runs.glob("*/run.json")}
    # simulate an interruption inside one DR sweep: its record and its last state are gone
    victim = runs / "dr_matched"
    (victim / "run.json").unlink()
    last = sorted(victim.glob("*.npz"))[-1]
    kept = sorted(victim.glob("*.npz"))[:-1]
    kept_stamps = {p.name: p.stat().st_mtime_ns for p in kept}
    last.unlink()
    validate(scenes.load("demes_paper"), out, quick=True, workers=1, progress=False)
    for name, stamp in stamps.items():
        if name != "dr_matched":
            assert (runs / name / "run.json").stat().st_mtime_ns == stamp, name
    assert json.loads((victim / "run.json").read_text())["complete"]
    assert last.exists()
    for name, stamp in kept_stamps.items():  # finished states were not solved again
        assert (victim / name).stat().st_mtime_ns == stamp
    assert np.isfinite(float(read_csv(out / "headline.csv")[-1]["theta_matched [deg]"]))


def test_csv_has_a_column_for_every_key_of_every_row(tmp_path):
    from validation.tables import write_csv

    rows = [{"prestretch": 1.0, "r0": 0.0, "r1": 0.0}, {"prestretch": 1.1, "r0": 48.9, "r1": 48.7, "r2": 48.698}]
    write_csv(tmp_path / "t.csv", rows)
    back = read_csv(tmp_path / "t.csv")
    assert back[1]["r2"] == "48.698" and back[0]["r2"] == ""
