"""The demes command line end to end (coarse mesh)."""

import csv
import signal
import subprocess
import sys
import time

import pytest
import pyvista as pv

import dr
import scenes
from validation import cli
from validation.cli import main


def test_demes_solve_writes_table_csv_and_vtk_series(tmp_path, capsys):
    out = tmp_path / "run"
    code = main(["solve", "--solver", "dr", "--mesh-levels", "10", "--prestretch", "1.0", "1.2", "--set", "mesh.divisions=10",
                 "--frame-model", "strip", "--out", str(out), "--no-progress"])
    assert code == 0
    printed = capsys.readouterr().out
    assert "theta[deg]" in printed and "+-[deg]" in printed
    assert "contact checks were off" not in printed
    assert (out / "dr_strip.png").stat().st_size > 0
    with open(out / "dr_strip.csv") as f:
        rows = list(csv.DictReader(f))
    assert [float(r["prestretch"]) for r in rows] == [1.0, 1.2]
    assert "bending_angle [deg]" in rows[0] and "energy_total [N mm]" in rows[0]
    # the CSV holds what a direct call of the solver gives (same warm-started sweep)
    scene = scenes.paper_demes(1.0, "strip", **{"mesh.divisions": 10})
    direct = list(dr.sweep(scene, [1.0, 1.2]))
    for row, res in zip(rows, direct):
        assert float(row["bending_angle [deg]"]) == res.bending_angle
    series = pv.get_reader(out / "dr_strip.pvd")
    assert series.time_values == [1.0, 1.2]
    series.set_active_time_value(1.2)
    assert series.read()[0].n_points == direct[1].x.shape[0]


def test_demes_reports_a_bad_scene_field_without_a_traceback(tmp_path, capsys):
    code = main(["solve", "--set", "frame.E=-5", "--out", str(tmp_path), "--no-progress"])
    assert code == 2
    err = capsys.readouterr().err
    assert "frame.E" in err and "Traceback" not in err
    code = main(["solve", "--prestretch", "0.8", "--out", str(tmp_path), "--no-progress"])
    assert code == 2 and "below 1" in capsys.readouterr().err


def test_demes_solve_names_the_stop_and_the_levels_it_did_not_reach(tmp_path, capsys):
    out = tmp_path / "run"
    code = main(["solve", "--solver", "dr", "--mesh-levels", "12", "--prestretch", "1.1", "1.3", "1.5", "--set", "mesh.divisions=12",
                 "--frame-model", "paper", "--out", str(out), "--no-progress"])
    assert code == 2  # not every state converged
    printed = capsys.readouterr().out
    assert "membrane_fold: lambda = " in printed
    missed = [line for line in printed.splitlines() if "not reached (the path stopped before them): " in line]
    assert len(missed) == 1 and missed[0].endswith(" 1.5")
    with open(out / "dr_paper.csv") as f:
        rows = list(csv.DictReader(f))
    assert rows[-1]["status"] == "membrane_fold" and "membrane folded over" in rows[-1]["message"]


def test_bad_command_lines_give_one_line_and_exit_code_2(tmp_path, capsys):
    afile = tmp_path / "afile"
    afile.write_text("x")
    cases = [
        (["solve", "--prestretch", "nan"], "--prestretch[0] = nan"),
        (["solve", "--prestretch", "inf"], "--prestretch[0] = inf"),
        (["solve", "--prestretch", "1.1", "--out", str(afile)], "is a file, not a folder"),
        (["solve", "--prestretch", "1.1", "--out", str(afile / "sub")], "cannot be written"),
        (["bench", "--repeats", "0"], "--repeats 0"),
        (["bench", "--fem", "--levels", "0", "7"], "--levels 0 7"),
        (["bench", "--fem", "--prestretch", "1.1", "1.3"], "give one pre-stretch"),
        (["bench", "--fem", "--prestretch", "0.9"], "--prestretch"),
        (["bench", "--spectrum", "--prestretch", "1.1", "1.3"], "give one --prestretch"),
        (["bench", "--spectrum", "--refinement", "3"], "--refinement 0 to 2"),
        (["bench", "--gallery", "no_such_scene"], "no_such_scene"),
        (["fem", "--refinement", "99", "--prestretch", "1.1"], "fem.refinement"),
        (["solve", "--set", "mesh.divisions=" + "9" * 5000], "mesh.divisions"),
    ]
    for argv, words in cases:
        if argv[0] != "bench":
            argv = argv + ["--no-progress"] + ([] if "--out" in argv else ["--out", str(tmp_path / "o")])
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert words in err and "Traceback" not in err and len(err.strip().splitlines()) == 1, err


def test_a_repeated_prestretch_is_solved_once(tmp_path, capsys):
    out = tmp_path / "run"
    main(["solve", "--solver", "dr", "--mesh-levels", "6", "--prestretch", "1.1", "1.1", "1.0", "--frame-model", "paper", "--set", "mesh.divisions=6", "--out", str(out), "--no-progress"])
    with open(out / "dr_paper.csv") as f:
        assert [float(r["prestretch"]) for r in csv.DictReader(f)] == [1.0, 1.1]


def test_demes_solve_without_contact_checks_says_so_and_names_what_it_cannot_read(tmp_path, capsys):
    """Table I's frame at 6 divisions, contact checks off: twisted at 1.1, and at 1.2 its film has
    passed through itself (which the checks would have stopped): that state reads 'unreadable',
    not 31.7 deg, and the run says once that nothing was checked."""
    out = tmp_path / "run"
    code = main(["solve", "--solver", "dr", "--mesh-levels", "6", "--prestretch", "1.1", "1.2", "--set", "mesh.divisions=6", "--set", "dr.check_contact=false",
                 "--frame-model", "paper", "--out", str(out), "--no-progress"])
    assert code == 2  # a state without an answer
    printed = capsys.readouterr().out
    assert printed.count("contact checks were off") == 1
    table = printed.splitlines()
    head = next(i for i, line in enumerate(table) if "theta[deg]" in line)
    assert "branch" in table[head]
    last = table[head + 2].split()
    assert last[1:3] == ["unreadable", "up"] and last[table[head].split().index("status")] == "unreadable"
    assert "the bending angle cannot be read: the film passes through itself" in printed
    with open(out / "dr_paper.csv") as f:
        rows = list(csv.DictReader(f))
    assert [r["branch"] for r in rows] == ["twisted", "up"]
    assert [r["contact_checked"] for r in rows] == ["no", "no"]
    assert rows[1]["bending_angle [deg]"] == "nan" and rows[1]["angle_unreadable"] == "film_crossing"
    assert (rows[1]["status"], rows[1]["converged"]) == ("unreadable", "no")


@pytest.mark.parametrize("after", [0.1, 0.3, 1.5, 3.0])
def test_ctrl_c_at_any_moment_ends_in_one_line(tmp_path, after):
    """SIGINT while the command loads its libraries (0.1 s, 0.3 s), compiles or solves (the FEM's
    compiled rod and membrane kernels): exit code 130 and one line, never a traceback."""
    command = [sys.executable, "-m", "validation.console", "solve", "--mesh-levels", "8", "16",
               "--prestretch", "1.1", "1.3", "1.5", "--no-progress", "--out", str(tmp_path / "run")]
    # the child gets SIGINT's default disposition: a process that ignores it (as a test runner
    # or a cluster may) passes the ignoring on, and Python then installs no handler
    run = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                           preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    time.sleep(after)
    if run.poll() is not None:
        pytest.skip(f"the command finished within {after} s")
    run.send_signal(signal.SIGINT)
    _, err = run.communicate(timeout=120)
    assert run.returncode == 130, err
    assert err.strip().splitlines() == ["demes: interrupted; finished states are on disk"], err


def test_an_interrupt_inside_compiled_code_is_an_interrupt(monkeypatch, capsys):
    """numba's dispatcher turns a KeyboardInterrupt raised in its call into a SystemError caused
    by it: that is an interrupt (130, one line); a SystemError of another cause is not."""
    def interrupted_in_numba(args):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as exc:
            raise SystemError("CPUDispatcher(<function vertex_terms>) returned a result with an exception set") from exc

    monkeypatch.setattr(cli, "cmd_solve", interrupted_in_numba)
    assert main(["solve"]) == 130
    assert capsys.readouterr().err == "demes: interrupted; finished states are on disk\n"

    def broken(args):
        raise SystemError("a bug")

    monkeypatch.setattr(cli, "cmd_solve", broken)
    with pytest.raises(SystemError, match="a bug"):
        main(["solve"])
