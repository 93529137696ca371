"""Every script in examples/ runs, at its fast setting (DEMES_QUICK=1), and does what it says."""

import re
import runpy
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


@pytest.fixture
def run_example(tmp_path, monkeypatch, capsys):
    """Run examples/<name> in a fresh folder with DEMES_QUICK=1; returns what it printed."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("DEMES_QUICK", "1")

    def run(name, *args):
        monkeypatch.setattr(sys, "argv", [name, *args])
        runpy.run_path(str(EXAMPLES / name), run_name="__main__")
        return capsys.readouterr().out

    return run


def test_every_example_is_tested():
    tested = set(re.findall(r'run_example\("(\w+\.py)"', Path(__file__).read_text())) | {"validate_paper_demes.py"}
    assert tested == {p.name for p in EXAMPLES.glob("*.py")}


def test_elastica_example_meets_the_exact_solution(run_example):
    printed = run_example("elastica.py")
    errors = [float(e) for e in re.findall(r"tip error ([0-9.e+-]+)", printed)]
    assert len(errors) == 2 and errors[1] < errors[0] < 5e-3  # second order: 10 -> 20 segments


def test_custom_structure_example_converges(run_example, tmp_path):
    printed = run_example("custom_structure.py")
    assert "converged" in printed and "middle node deflection -" in printed
    assert (tmp_path / "out/example/cable_net.vtu").exists()


def test_electrode_example_drives_one_half(run_example):
    printed = run_example("electrode_regions.py")
    angle = {(label.strip(), float(v)): float(a) for label, v, a in
             re.findall(r"^(.+?) V = +([0-9]+) V: bending angle +([0-9.-]+) deg", printed, re.M)}
    assert len(angle) == 9 and "converged" in printed
    dr_left, fem_left, whole = (angle[(k, 2000.0)] for k in ("DR, left driven", "FEM, left driven", "DR, whole film"))
    assert abs(dr_left - fem_left) < 0.1
    assert angle[("DR, left driven", 0.0)] > dr_left > whole


def test_open_window_example_leaves_the_middle_segment_bare(run_example, tmp_path):
    """DR and the FEM on one discrete problem: one state on the lift's side, every segment's turn
    within 0.1 deg, energies within 1e-6; the open segment, with no film to curl it, turns least;
    the VTU holds the film and the open window's strip bands as blocks of their own."""
    import meshio

    printed = run_example("open_window.py")
    found = {label: ([float(t) for t in turns], float(energy), side) for label, *turns, energy, side in re.findall(
        r"^(DR|FEM) +at 1.15: turns base +([0-9.-]+), middle \(open\) +([0-9.-]+), tip +([0-9.-]+) deg, "
        r"energy ([0-9.]+) N mm, apex (\w+), converged", printed, re.M)}
    assert set(found) == {"DR", "FEM"}
    (dr_turns, dr_energy, dr_side), (fem_turns, fem_energy, fem_side) = found["DR"], found["FEM"]
    assert dr_side == fem_side == "up"
    assert dr_turns == pytest.approx(fem_turns, abs=0.1) and dr_energy == pytest.approx(fem_energy, rel=1e-6)
    assert abs(fem_turns[1]) < min(fem_turns[0], fem_turns[2])
    for solver in ("dr", "fem"):
        blocks = re.search(rf"^written .*{solver}_1\.15\.vtu with the blocks (.+)$", printed, re.M).group(1).split(", ")
        assert {"strip_band", "frame", "members"} <= set(blocks), blocks
        written = meshio.read(tmp_path / f"out/open_window/{solver}_1.15.vtu")
        assert len(written.cells) == len(blocks)


def test_solve_example_curls_and_writes_a_picture(run_example, tmp_path):
    printed = run_example("solve_paper_demes.py")
    angles = [float(a) for a in re.findall(r"bending angle +([0-9.-]+) deg", printed)]
    assert len(angles) == 3 and 0 < angles[0] < angles[1] < angles[2]
    assert "1.1: converged" in printed
    for name in ("dr_strip.pvd", "dr_strip_1.3.vtu", "dr_strip.png"):
        assert (tmp_path / "out/example" / name).exists(), name


def test_fem_example_curls_the_strip(run_example, tmp_path):
    printed = run_example("fem_paper_demes.py")
    strip = [float(a) for a in re.findall(r"strip  lambda = [0-9.]+  theta = +([0-9.-]+) deg", printed)]
    assert len(strip) == 3 and strip[0] > 20
    assert (tmp_path / "out/fem_example/strip.pvd").exists()


def test_fem_convergence_example_extrapolates(run_example):
    printed = run_example("fem_convergence.py", "1.05")
    assert re.search(r"reference bending angle at lambda = 1.05: [0-9.]+ \+- ", printed)


def test_validate_example_reads_the_report(report):
    """The example made the quick report the validation tests check (tests/conftest.py)."""
    out, files, printed = report
    assert f"report: {files['html']}" in printed and out.name == "demes_paper_quick"
    assert re.search(r"time to 1\.0% shape error: DR", printed)
    lines = [line for line in printed.splitlines() if re.match(r" *1\.(0|15|3)  ", line)]
    assert len(lines) == 3  # one headline row per pre-stretch of the quick plan


def test_design_sweep_example_tabulates_the_bending_angles(run_example):
    printed = run_example("design_sweep.py", "--workers", "1")
    assert "9 paths solved" in printed and "bending angle [deg]" in printed
