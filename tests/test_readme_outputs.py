"""The command outputs the README shows are what the commands print now, and the main job's
error band holds the committed FEM reference.

A README block marked ``<!-- output of: demes ARGS -->`` is compared with what ``demes ARGS``
prints, run in a fresh folder (so the paths it prints are the README's), every column but the
wall times.
"""

import contextlib
import csv
import io
import re
import shlex
from pathlib import Path

import pytest

import scenes
from validation.cli import main

ROOT = Path(__file__).resolve().parent.parent
MARK = re.compile(r"<!-- output of: demes (.+?) -->\n```text\n(.*?)```", re.S)
REFERENCE = ROOT / "reports" / "demes_paper" / "reference_table.csv"


def _blocks() -> list[tuple[str, str]]:
    return MARK.findall((ROOT / "README.md").read_text())


def _without_times(text: str) -> list[list[str]]:
    """Lines as words, with the values under a 'time[s]' header replaced by '*'."""
    rows, column = [], None
    for line in text.strip().splitlines():
        words = line.split()
        if "time[s]" in words:
            column = words.index("time[s]")
        elif column is not None and len(words) > column and re.fullmatch(r"[0-9.]+", words[column]):
            words[column] = "*"
        rows.append(words)
    return rows


@pytest.fixture(scope="module")
def outputs(tmp_path_factory):
    """What each marked command prints, by its argument string."""
    import os

    work, here, printed = tmp_path_factory.mktemp("readme"), Path.cwd(), {}
    os.chdir(work)
    try:
        for args, _ in _blocks():
            buf = io.StringIO()
            with contextlib.redirect_stdout(buf):
                assert main([*shlex.split(args), "--no-progress"]) == 0
            printed[args] = (buf.getvalue(), work)
    finally:
        os.chdir(here)
    return printed


def test_the_readme_marks_the_main_job_output():
    assert "solve --prestretch 1.1 1.3 1.5 --out out/paper" in [args for args, _ in _blocks()]


def test_the_readme_scene_loads(tmp_path):
    (text,) = re.findall(r"```toml\n(.*?)```", (ROOT / "README.md").read_text(), re.S)
    (tmp_path / "my_demes.toml").write_text(text)
    scene = scenes.load(tmp_path / "my_demes.toml")
    assert (scene.name, scene.frame.side_length, scene.membrane.law) == ("my_demes", 40.0, "neo-hookean")


@pytest.mark.slow
def test_readme_outputs_are_the_commands_outputs(outputs):
    for args, shown in _blocks():
        assert _without_times(outputs[args][0]) == _without_times(shown), args


@pytest.mark.slow
def test_the_main_job_band_holds_the_committed_reference(outputs):
    """At 110, 130 and 150 % the extrapolated angle +- its estimate covers the report's converged
    reference +- its own, and the estimate is at most 2 deg."""
    _, work = outputs["solve --prestretch 1.1 1.3 1.5 --out out/paper"]
    with open(work / "out/paper/fem_strip.csv") as f:
        rows = {r["prestretch"]: r for r in csv.DictReader(f)}
    with open(REFERENCE) as f:
        reference = {r["prestretch"]: r for r in csv.DictReader(f)}
    for lam in ("1.1", "1.3", "1.5"):
        theta, err = float(rows[lam]["bending_angle_extrapolated [deg]"]), float(rows[lam]["bending_angle_error [deg]"])
        ref, ref_err = float(reference[lam]["bending_angle [deg]"]), float(reference[lam]["bending_angle_error [deg]"])
        assert abs(theta - ref) <= err + ref_err, lam
        assert err <= 2.0, lam


def test_the_ci_runs_the_readme_test_command():
    ci = [line for line in (ROOT / ".ci" / "run").read_text().splitlines() if line and not line.startswith(("#", "set ", "cd "))]
    assert len(ci) == 1 and f"    {ci[0]}\n" in (ROOT / "README.md").read_text()
