"""A run folder is reused only for the computation and code it was made with, and is filled by
one process at a time."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import textwrap

import pytest

import scenes
from validation.report import runner
from validation.common.lock import FolderBusy, folder_lock
from validation.report.plan import Plan, Run

RUN = Run(label="tiny", solver="dr", changes={"mesh.divisions": 4}, prestretches=(1.05,), refinement=0,
          group="sweep", title="a 4-division DR state")
PLAN = Plan(runs=(RUN,), sweep=(1.05,), speed_prestretch=1.05, reference_levels=(0,))


def _solve(out, scene):
    return runner.run_plan(PLAN, scene.to_dict(), out, workers=1, progress=False)["tiny"]


def test_a_run_is_solved_again_when_its_scene_or_code_changed(tmp_path, monkeypatch):
    scene = scenes.load("demes_paper")
    first = _solve(tmp_path, scene)
    state = tmp_path / "runs" / "tiny" / "1.0500.npz"
    made = state.stat().st_mtime_ns
    assert first["complete"] and first["key"] and "resolved" not in first
    assert _solve(tmp_path, scene)["key"] == first["key"] and state.stat().st_mtime_ns == made  # reused
    # the film's modulus changed in the scene file: the state on disk is not this scene's
    again = _solve(tmp_path, scene.updated(**{"membrane.E": 1.1}))
    assert again["key"] != first["key"] and again["resolved"] == runner.RESOLVED
    assert state.stat().st_mtime_ns != made
    # the same scene, but the solvers' code changed
    made = state.stat().st_mtime_ns
    monkeypatch.setattr(runner, "code_version", lambda: "an edited solver")
    edited = _solve(tmp_path, scene.updated(**{"membrane.E": 1.1}))
    assert edited["resolved"] == runner.RESOLVED and state.stat().st_mtime_ns != made
    assert runner.stale_runs(PLAN, scene.to_dict(), tmp_path) == ["tiny"]


def test_the_code_version_follows_the_solver_sources():
    assert len(runner.code_version()) == 64
    assert any(name == "dr" for name in runner.STATE_CODE) and "results" in runner.STATE_CODE


def test_a_folder_being_filled_is_refused_naming_the_process(tmp_path):
    with folder_lock(tmp_path, "demes validate"):
        # another process finds it locked, and is told who holds it
        probe = textwrap.dedent(f"""
            from pathlib import Path
            from validation.common.lock import FolderBusy, folder_lock
            try:
                with folder_lock(Path({str(tmp_path)!r}), "demes validate"):
                    print("got it")
            except FolderBusy as exc:
                print(exc)
        """)
        out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=120).stdout
        assert f"process {os.getpid()} on {socket.gethostname()} (demes validate" in out
        assert "wait for it to finish" in out and "got it" not in out
        with pytest.raises(FolderBusy, match=str(os.getpid())):
            runner.run_plan(PLAN, scenes.load("demes_paper").to_dict(), tmp_path, workers=1, progress=False)
    # released: the next process takes it
    with folder_lock(tmp_path, "demes validate"):
        pass


def test_a_lock_left_by_a_dead_process_is_taken_over(tmp_path):
    """A process killed while it held the folder leaves its lock file behind; the lock itself
    went with the process."""
    holder = subprocess.Popen([sys.executable, "-c", textwrap.dedent(f"""
        import sys, time
        from pathlib import Path
        from validation.common.lock import folder_lock
        with folder_lock(Path({str(tmp_path)!r}), "demes validate"):
            print("locked", flush=True)
            time.sleep(600)
    """)], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "locked"
        with pytest.raises(FolderBusy, match=str(holder.pid)):
            with folder_lock(tmp_path, "demes validate"):
                pass
    finally:
        holder.kill()
        holder.wait()
    assert json.loads((tmp_path / ".demes.lock").read_text())["pid"] == holder.pid  # left behind
    with folder_lock(tmp_path, "demes validate"):
        assert json.loads((tmp_path / ".demes.lock").read_text())["pid"] == os.getpid()
