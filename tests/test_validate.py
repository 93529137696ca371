"""demes validate --quick end to end: files, numbers equal to direct solver calls, resume."""

import csv
import json
import shutil
from dataclasses import replace

import numpy as np
import pytest

import dr
import fem_reference
import scenes
import validation.report.validate
from results import load_result, save_result
from validation.cli import main
from validation.common.document import Section
from validation.common.tables import write_csv
from validation.report.study import Study
from validation.report.plan import MATCHED, REFERENCE, Run
from validation.report.verdicts import Verdict
from validation.report.runner import computation_key
from validation.report.analysis import Analysis, analyse
from validation.report.studies import scene_mesh
from validation.report.validate import STUDIES, validate, validation_plan
from validation.report.writing import _run_notes


def read_csv(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def test_report_files_exist_and_html_is_self_contained(report):
    out, files, _ = report
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


def test_the_report_leads_with_verdicts_that_restate_its_tables(report):
    """The first section is the verdict table, one row per claim (the experiment's from its
    study); each verdict follows from the numbers in the detailed tables."""
    out, _, _ = report
    md = (out / "report.md").read_text()
    assert md.split("\n## ")[1].startswith("Verdicts")
    rows = {r["claim"]: r for r in read_csv(out / "verdicts.csv")}
    assert len(rows) == 7 and all(r["measured"] and r["verdict"] for r in rows.values())
    scene_mesh_rows = read_csv(out / "scene_mesh.csv")
    coarse = next(r for c, r in rows.items() if "scene's own mesh" in c)
    all_same = all(r["same_state"] == "yes" for r in scene_mesh_rows)
    assert (coarse["verdict"] == "holds") == all_same and coarse["verdict"].startswith(("holds", "does not hold at"))
    low_cost = next(r for c, r in rows.items() if "low-cost" in c)
    ratios = [float(r["ratio_fem_over_dr"]) for r in read_csv(out / "time_to_error.csv")
              if np.isfinite(float(r["ratio_fem_over_dr"]))]
    expected = ("not measured" if not ratios else "holds" if min(ratios) > 1 else "does not hold" if max(ratios) < 1
                else f"holds at {sum(x > 1 for x in ratios)} of {len(ratios)} accuracies")
    assert low_cost["verdict"] == expected
    limits = [r for r in read_csv(out / "limits.csv") if r.get("agree")]
    agree = sum(r["agree"] == "yes" for r in limits)
    one_problem = next(r for c, r in rows.items() if "FEM's limit" in c)
    assert f"at {agree} of {len(limits)} pre-stretch levels" in one_problem["measured"]
    experiment = next(r for c, r in rows.items() if "experiment" in c)
    flats = [float(r["flat_voltage [V]"]) for r in read_csv(out / "experiment_summary.csv")]
    assert all(f"{v:.0f} V" in experiment["measured"] for v in flats if np.isfinite(v))


def test_report_numbers_equal_direct_solver_calls(report):
    out, _, _ = report
    plan = validation_plan(quick=True)
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
    out, _, _ = report
    rows = [r for r in read_csv(out / "reference.csv") if r["quantity"] == "bending_angle"]
    assert rows
    for r in rows:
        est = fem_reference.richardson([float(r["r0"]), float(r["r1"])])
        assert float(r["extrapolated"]) == pytest.approx(est.extrapolated, rel=1e-9, abs=1e-12)


def test_reference_table_and_level_costs_restate_the_levels(report):
    out, _, _ = report
    long = {(float(r["prestretch"]), r["quantity"]): r for r in read_csv(out / "reference.csv")}
    table = read_csv(out / "reference_table.csv")
    assert table
    for row in table:
        lam = float(row["prestretch"])
        for q, unit in (("bending_angle", "deg"), ("apex_z", "mm"), ("energy_total", "N mm")):
            assert float(row[f"{q} [{unit}]"]) == float(long[(lam, q)]["extrapolated"])
            assert float(row[f"{q}_error [{unit}]"]) == float(long[(lam, q)]["error"])
    fem = {r["run"]: r for r in read_csv(out / "states.csv") if r["run"].startswith("fem_r")}
    levels = read_csv(out / "fem_levels.csv")
    assert [int(r["level"]) for r in levels] == [0, 1]
    assert int(levels[1]["free_dofs"]) > 3 * int(levels[0]["free_dofs"])  # halving h: ~4x the nodes
    assert all(f"fem_r{r['level']}" in fem for r in levels)


def test_dr_limit_is_the_extrapolation_of_its_own_refinement(report):
    out, _, _ = report
    states = read_csv(out / "states.csv")
    chain = [r.label for r in validation_plan(quick=True).by_group("drconv")]
    limits = read_csv(out / "limits.csv")
    assert [float(r["prestretch"]) for r in limits] == list(validation_plan(quick=True).sweep)
    for row in limits:
        lam = float(row["prestretch"])
        angles = [float(next(s for s in states if s["run"] == label and float(s["prestretch"]) == lam)["bending_angle [deg]"])
                  for label in chain]
        assert float(row["theta_dr [deg]"]) == pytest.approx(fem_reference.richardson(angles).extrapolated, abs=1e-9)


def test_the_nets_refined_limits_are_model_form_rows(report):
    out, _, _ = report
    rows = [r for r in read_csv(out / "error_budget.csv") if "each extrapolated" in r["what"]]
    assert {r["what"].split()[0] for r in rows} == {"links", "clustered"}
    assert all(np.isfinite(float(r["bending_angle_diff [deg]"])) for r in rows)


def test_every_hard_case_has_an_outcome(report):
    out, _, _ = report
    rows = read_csv(out / "hard_cases.csv")
    cases = {r["case"] for r in rows}
    assert {"zero_prestretch", "stiff_frame", "soft_frame", "coarse_mesh", "asymmetric", "square_frame",
            "mass_safety_1"} <= cases
    for r in rows:
        assert r["status"] and (r["status"] != "converged" or r["iterations"])
    zero = [r for r in rows if r["case"] == "zero_prestretch" and r["solver"] == "dr"][0]
    assert zero["status"] == "converged" and abs(float(zero["bending_angle [deg]"])) < 1e-3


def test_interrupted_validation_redoes_only_what_is_missing(report):
    out, _, _ = report
    runs = out / "runs"
    stamps = {p.parent.name: p.stat().st_mtime_ns for p in runs.glob("*/run.json")}
    # simulate an interruption inside one DR sweep (one with no twin in the plan): its record
    # and its last state are gone; and a twin (drconv_n8 computes dr_matched) lost its record
    victim, twin = runs / "dr_paper", runs / "drconv_n8"
    (victim / "run.json").unlink()
    (twin / "run.json").unlink()
    last = sorted(victim.glob("*.npz"))[-1]
    kept = sorted(victim.glob("*.npz"))[:-1] + sorted(twin.glob("*.npz"))
    kept_stamps = {p: p.stat().st_mtime_ns for p in kept}
    last.unlink()
    # --report-only solves nothing and names the unfinished runs
    assert main(["validate", "--quick", "--out", str(out), "--report-only", "--no-progress"]) == 0
    assert not last.exists()
    findings = (out / "report.md").read_text().split("## Findings")[1].split("\n## ")[0]
    assert "Runs not finished" in findings and "dr_paper" in findings and "drconv_n8" in findings
    validate(scenes.load("demes_paper"), out, quick=True, workers=1, progress=False)
    for name, stamp in stamps.items():
        if name not in ("dr_paper", "drconv_n8"):
            assert (runs / name / "run.json").stat().st_mtime_ns == stamp, name
    assert json.loads((victim / "run.json").read_text())["complete"]
    assert json.loads((twin / "run.json").read_text())["same_as"] == "dr_matched"
    assert last.exists()
    for path, stamp in kept_stamps.items():  # finished states were not solved again
        assert path.stat().st_mtime_ns == stamp, path
    assert np.isfinite(float(read_csv(out / "headline.csv")[-1]["theta_matched [deg]"]))


def test_runs_that_compute_the_same_are_solved_once(report):
    """The quick plan's twins (one computation under two labels) hold the same states, one
    record names the other, and a one-level DR sweep is the cold solve the key takes it for."""
    out, _, _ = report
    plan = validation_plan(quick=True)
    same = {}
    for run in plan.runs:
        same.setdefault(computation_key(run, scenes.load("demes_paper").to_dict()), []).append(run)
    twins = [runs for runs in same.values() if len(runs) > 1]
    assert {frozenset(r.label for r in runs) for runs in twins} >= {
        frozenset({"dr_matched", "drconv_n8"}), frozenset({"dr_links_strip", "netconv_links_n8"})}
    for runs in twins:
        dirs = [out / "runs" / r.label for r in runs]
        records = [json.loads((d / "run.json").read_text()) for d in dirs]
        assert sum("same_as" in rec for rec in records) == len(runs) - 1
        for a, b in zip(sorted(dirs[0].glob("*.npz")), sorted(dirs[1].glob("*.npz")), strict=True):
            assert a.name == b.name and a.read_bytes() == b.read_bytes()
    sweep_run = next(r for r in plan.runs if r.label == "netconv_links_n8")
    cold = dr.solve(scenes.load("demes_paper").updated(**sweep_run.changes), sweep_run.prestretches[0])
    stored = load_result(out / "runs" / "netconv_links_n8" / f"{sweep_run.prestretches[0]:.4f}.npz")
    assert cold.iterations == stored.iterations and np.array_equal(cold.x, stored.x)


def test_report_only_needs_runs(tmp_path, capsys):
    assert main(["validate", "--quick", "--out", str(tmp_path / "empty"), "--report-only"]) == 2
    assert "holds no runs" in capsys.readouterr().err


def test_csv_has_a_column_for_every_key_of_every_row(tmp_path):
    
    rows = [{"prestretch": 1.0, "r0": 0.0, "r1": 0.0}, {"prestretch": 1.1, "r0": 48.9, "r1": 48.7, "r2": 48.698}]
    write_csv(tmp_path / "t.csv", rows)
    back = read_csv(tmp_path / "t.csv")
    assert back[1]["r2"] == "48.698" and back[0]["r2"] == ""


class _State:
    """The few fields of a Result that the branch check reads: a frame curve offset by ``move``."""

    def __init__(self, move: float, stable: bool = True):
        self.prestretch, self.converged = 1.5, True
        self.info = {"stable": stable, "lowest_eigenvalue_N_per_mm3": 1e-5 if stable else -1e-5}
        self.move = move
        self.scene = scenes.load("demes_paper")

    def frame_curve(self, samples):
        return np.column_stack([np.linspace(0, 1, samples), np.zeros(samples), np.full(samples, self.move)])


def test_branch_check_reports_a_level_that_jumps_and_one_that_is_unstable():
    from validation.report.analysis import branch_check

    side = scenes.load("demes_paper").outline.side_length
    converging = [_State(0.0), _State(4.0), _State(5.0), _State(5.25)]  # moves 4, 1, 0.25 mm
    assert [r["branch"] for r in branch_check(converging, (0, 1, 2, 3))] == ["first", "same", "same", "same"]
    assert branch_check(converging, (0, 1, 2, 3))[2]["move"] == pytest.approx(1.0 / side)
    jumped = [_State(0.0), _State(4.0), _State(5.0), _State(-20.0)]
    assert branch_check(jumped, (0, 1, 2, 3))[-1]["branch"] == "jump"
    unstable = [_State(0.0), _State(4.0, stable=False)]
    assert branch_check(unstable, (0, 1))[-1]["branch"] == "unstable"


def test_first_contact_extrapolates_the_levels_brackets():
    from types import SimpleNamespace

    from validation.report.analysis import first_contact

    exact, levels = 1.9, (0, 1, 2)
    states = {}
    for k in levels:  # contact converging at second order, each bracketed to 1e-3
        mid = exact + 0.08 * 4.0**-k
        states[f"fem_r{k}"] = {1.5: SimpleNamespace(info={}),
                               2.0: SimpleNamespace(info={"first_contact_prestretch": (mid - 5e-4, mid + 5e-4)})}
    plan = SimpleNamespace(reference_levels=levels)
    rows = first_contact(plan, states)
    assert [r["level"] for r in rows] == ["r0", "r1", "r2", "extrapolated"]
    assert rows[-1]["value"] == pytest.approx(exact, abs=1e-12)
    assert rows[-1]["order"] == pytest.approx(2.0)
    assert rows[-1]["error"] >= 5e-4


def test_report_is_against_the_experiment_with_its_csv(report):
    """The voltage runs: every sweep in experiment.csv, one summary row per run; the swept
    flattening voltage is the closed form's (the frame's buckling tension is small), the
    calibrated film's closed form is the experiment's 2.25 kV, and the stroke grows with V."""
    out, _, _ = report
    md = (out / "report.md").read_text()
    assert "## Against the experiment" in md
    summary = {r["run"]: r for r in read_csv(out / "experiment_summary.csv")}
    assert set(summary) == {"exp_fem_table1", "exp_dr_table1", "exp_fem_calibrated"}
    fem = summary["exp_fem_table1"]
    assert float(fem["flat_voltage [V]"]) == pytest.approx(float(fem["flat_closed_form [V]"]), rel=0.01)
    assert float(summary["exp_fem_calibrated"]["flat_closed_form [V]"]) == pytest.approx(2250.0, rel=1e-9)
    states = read_csv(out / "experiment.csv")
    for label in summary:
        rows = [r for r in states if r["run"] == label]
        assert float(rows[0]["voltage [V]"]) == 0.0 and len(rows) >= 3
        stroke = [float(r["stroke [deg]"]) for r in rows]
        assert stroke[0] == 0.0 and all(b >= a - 1e-6 for a, b in zip(stroke, stroke[1:]))
    for name in ("experiment_stroke_voltage", "experiment_energy_stroke"):
        assert (out / "figures" / f"{name}.png").exists()
    assert (out / "runs" / "exp_fem_table1" / "exp_fem_table1.pvd").exists()


def test_second_states_are_polished_by_the_fem_on_the_same_mesh(report):
    """The at-once search: every DR state it found is polished by the FEM's Newton on the same
    discrete problem, so the two angles agree to the solvers' tolerances (DR at 1e-6), and a
    state is called stable exactly when its lowest eigenvalue is not negative."""
    out = report[0]
    rows = read_csv(out / "second_states.csv")
    assert [float(r["prestretch"]) for r in rows] == list(validation_plan(quick=True).get("second_states").prestretches)
    scene = scenes.load("demes_paper")
    neutral = 1e-6 * scene.membrane.E * scene.membrane.thickness / scene.outline.side_length**2
    for r in rows:
        assert r["status"] == "converged", r
        assert abs(float(r["theta_found [deg]"]) - float(r["theta_dr_at_once [deg]"])) < 0.05
        assert (r["stable"] == "yes") == (float(r["lowest_eigenvalue [N/mm^3]"]) > -neutral)
        assert (r["second_state"] == "yes") == (r["stable"] == "yes" and float(r["shape_distance"]) > 1e-3)
    assert "## Second stable states" in (out / "report.md").read_text()


def test_graded_speed_rows_are_on_the_graded_mesh(report):
    """The quick plan's graded speed rows: DR triangles and the FEM (P1) on one graded mesh, with
    its free DOFs (more than the uniform mesh of the same divisions has)."""
    out, _, _ = report
    rows = {r["run"]: r for r in read_csv(out / "speed.csv")}
    fem, dr_row = rows["speed_fem_P1_n6_g2_r0"], rows["speed_dr_n6_g2_tol1e-06"]
    assert float(fem["grading"]) == float(dr_row["grading"]) == 2.0
    scene = scenes.paper_demes(1.3, **{"fem.element": "P1", "mesh.divisions": 6, "mesh.grading": 2.0})
    from fem_reference.model import DemesProblem

    graded = DemesProblem(scene, 0, "P1")
    uniform = DemesProblem(scene.updated(**{"mesh.grading": 1.0}), 0, "P1")
    assert int(float(fem["free_dofs"])) == int(float(dr_row["free_dofs"])) == graded.free.size > uniform.free.size
    assert fem["status"] == dr_row["status"] == "converged"


def _toy_runs(settings):
    return [Run("toy_flat", "dr", {"mesh.divisions": 6, "dr.membrane_net": "triangles"}, prestretches=(1.1,),
                group="toy", title="toy: DR at 1.1 on 6 divisions")]


def _toy_execute(run, scene, run_dir):
    res = dr.solve(scene, run.prestretches[0])
    save_result(run_dir / "state.npz", res)
    return {run.prestretches[0]: res}


def _toy_analyse(a, out_dir):
    path = out_dir / "runs" / "toy_flat" / "state.npz"
    return load_result(path) if path.exists() else None


TOY = Study(
    name="toy", runs=_toy_runs, analyse=_toy_analyse,
    section=lambda res, figs: Section("Toy study", [f"theta {res.bending_angle:.3f} deg"]),
    tables=lambda res: {"toy": [{"bending_angle": res.bending_angle}]},
    group="toy", execute=_toy_execute,
    verdicts=lambda res: [Verdict("The toy curls at 1.1", f"{res.bending_angle:.3f} deg",
                                  "holds" if res.bending_angle > 1 else "does not hold")])


def test_a_report_study_is_one_module_and_one_registry_line(report, tmp_path, monkeypatch):
    """A study beside the validation is a :class:`validation.report.study.Study` (here built in
    this module) and its line in ``validation.report.validate.STUDIES``: the plan gets its run, the
    runner hands it to its ``execute``, the report gets its section, table and verdict row, and
    the runs already on disk are not solved again."""
    out = tmp_path / "with_toy"
    shutil.copytree(report[0], out)
    before = {p.parent.name: p.stat().st_mtime_ns for p in (out / "runs").glob("*/run.json")}
    monkeypatch.setattr(validation.report.validate, "STUDIES", (*validation.report.validate.STUDIES, TOY))
    validate(scenes.load("demes_paper"), out, quick=True, workers=1, progress=False)
    direct = dr.solve(scenes.load("demes_paper").updated(**{"mesh.divisions": 6, "dr.membrane_net": "triangles"}), 1.1)
    md = (out / "report.md").read_text()
    assert f"## Toy study\n\ntheta {direct.bending_angle:.3f} deg" in md
    assert float(read_csv(out / "toy.csv")[0]["bending_angle [deg]"]) == direct.bending_angle
    assert json.loads((out / "metrics.json").read_text())["toy"] == [{"bending_angle": direct.bending_angle}]
    rows = read_csv(out / "verdicts.csv")
    assert rows[-1] == {"claim": "The toy curls at 1.1", "measured": f"{direct.bending_angle:.3f} deg",
                        "verdict": "holds"}
    after = {p.parent.name: p.stat().st_mtime_ns for p in (out / "runs").glob("*/run.json")}
    assert {name: after[name] for name in before} == before and "toy_flat" in after


def test_the_scene_mesh_check_finds_the_coarse_state_and_tells_its_mirror_image_apart(report):
    """The quick plan's coarse mesh (8 divisions) against the scene's own (28): the paper DEMES
    curls into the same state on both, each state is a direct FEM sweep on the scene's mesh,
    and the same state curled the other way (its mirror image in the flat plane, another
    branch of the same energy) is told apart at every curled level."""
    out = report[0]
    rows = read_csv(out / "scene_mesh.csv")
    plan = validation_plan(quick=True)
    assert [float(r["prestretch"]) for r in rows] == list(plan.sweep)
    assert all(r["same_state"] == "yes" and int(r["divisions"]) == 28 for r in rows)
    base = scenes.load("demes_paper")
    for res in fem_reference.sweep(base.updated(**REFERENCE, **{"fem.element": "P1"}), plan.sweep, refinement=0):
        row = next(r for r in rows if float(r["prestretch"]) == res.prestretch)
        assert float(row["theta_scene_mesh [deg]"]) == pytest.approx(res.bending_angle, abs=1e-6)
    a = analyse(plan, out, studies=STUDIES)
    mirrored = {lam: replace(r, x=r.x * np.array([1.0, 1.0, -1.0])) for lam, r in a.states[scene_mesh.LABEL].items()}
    a.states[scene_mesh.LABEL] = mirrored
    verdict = {r["prestretch"]: (r["same_state"], r.get("relation")) for r in scene_mesh.analyse(a, out)}
    assert verdict == {lam: (True, None) if lam == 1.0 else (False, "mirror image through the flat plane")
                       for lam in plan.sweep}
    assert "## The scene's own mesh" in (out / "report.md").read_text()


def test_a_run_that_stopped_on_an_error_is_named_with_it_not_called_unfinished():
    """A run the solver refused (its record holds the error) is reported with that error; a run
    with no record is unfinished (interrupted or not started); complete runs are neither."""
    plan = validation_plan(quick=True)
    labels = [r.label for r in plan.runs]
    error = "scene error: a voltage (1000 V) with dr.membrane_net = 'clustered'"
    records = {label: {"complete": True, "error": None} for label in labels[2:]}
    records[labels[0]] = {"complete": False, "error": error}
    a = Analysis(plan, {}, records, {}, {})
    assert a.failed == {labels[0]: error} and a.unfinished == [labels[1]]
    sentences = _run_notes(a)
    assert any(f"{labels[0]} ({error})" in s and "stopped on an error" in s for s in sentences)
    assert any(s.startswith("Runs not finished") and labels[1] in s and labels[0] not in s for s in sentences)
