"""demes sweep: grid checks, a Dask LocalCluster run equal to a serial one, a killed worker,
resume."""

import os
import signal
import sys

import cloudpickle
import pandas as pd
import pytest

from scenes import tomllib
from validation.cli import main
from validation.design.grid import GridError, grid_from_dict
from validation.design.sweep import family_dir, load_records, record_path, run_design_sweep, solve_family, state_path

# a fast study: the strip frame (stated: the default frame model may change) on coarse meshes at
# low pre-stretch; the finer mesh is the slow point, several times slower than the coarse one
GRID_TOML = """
scene = "demes_paper"
prestretch = [1.05, 1.1]
[set]
frame.model = "strip"
[product]
mesh.divisions = [6, 56]
"""
GRID = tomllib.loads(GRID_TOML)


def grid(max_points=10_000, **changes):
    return grid_from_dict({**GRID, **changes}, name="study", max_points=max_points)


@pytest.mark.parametrize("changes, words", [
    ({"product": {"frame.thikness": [0.1]}}, ["frame.thikness"]),
    ({"product": {"frame.thickness": []}}, ["frame.thickness", "empty"]),
    ({"product": {"frame.thickness": 0.1}}, ["frame.thickness", "list"]),
    ({"product": {"frame.thickness": ["thin"]}}, ["frame.thickness", "number"]),
    ({"product": {"loading.prestretch": [1.2]}}, ["loading.prestretch", "top-level"]),
    ({"points": [{"frame.width": "wide"}]}, ["points[0]", "frame.width"]),
    ({"points": [{"mesh.divisions": 8}]}, ["mesh.divisions", "both"]),
    ({"prestretch": [0.9]}, ["prestretch[0]", "below 1"]),
    ({"prestretch": []}, ["prestretch", "1 to 1000"]),
    ({"solver": "abaqus"}, ["solver"]),
    ({"product": {"mesh.divisions": [6, 6]}}, ["'mesh.divisions': 6", "twice"]),
    ({"sweep": [1.1]}, ["'sweep'"]),
])
def test_bad_grids_name_the_field(changes, words):
    with pytest.raises(GridError) as err:
        grid(**changes)
    for word in words:
        assert word in str(err.value)


def test_a_grid_above_the_bound_says_how_to_raise_it():
    with pytest.raises(GridError, match=r"12 points \(2 mesh.divisions x 3 frame.thickness x 2 pre-stretches\).*--max-points 12"):
        grid(product={"mesh.divisions": [6, 8], "frame.thickness": [0.1, 0.11, 0.12]}, max_points=10)


def test_grid_is_the_product_of_the_listed_points_and_the_value_lists():
    g = grid(points=[{"frame": {"width": 3.0}}, {"frame.width": 4.0, "dr.prestretch_step": 0.0125}])
    assert len(g.families) == 4 and g.n_points == 8
    assert g.fields == ("frame.width", "dr.prestretch_step", "mesh.divisions")
    # a listed point that does not set a field carries the base scene's value
    assert g.families[1].fields == {"frame.width": 3.0, "dr.prestretch_step": 0.025, "mesh.divisions": 56}
    assert len({f.key for f in g.families}) == 4


def test_cli_reports_a_bad_grid(tmp_path, capsys):
    path = tmp_path / "bad.toml"
    path.write_text('prestretch = [1.1]\n[product]\nframe.thickness = []\n')
    assert main(["sweep", str(path), "--out", str(tmp_path / "out")]) == 1
    err = capsys.readouterr().err
    assert "bad grid" in err and "frame.thickness" in err and "empty" in err


@pytest.fixture(scope="module")
def serial(tmp_path_factory):
    out = tmp_path_factory.mktemp("serial")
    return run_design_sweep(grid(), out, workers=1, plots=False, progress=False)


@pytest.fixture(scope="module")
def cluster():
    import logging

    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                      silence_logs=logging.ERROR) as cl, Client(cl) as client:
        yield cl, client


def comparable(table):
    return table.drop(columns=["wall_time"])


def mtimes(out, family):
    folder = family_dir(out, family)
    return {lam: record_path(folder, lam).stat().st_mtime_ns for lam in load_records(out, family)}


def _die_after_the_first_record_of(folder: str, marker: str) -> None:
    """In a worker: once the first record of the family in ``folder`` is on disk, note its
    time in ``marker`` and kill this worker process (once, whichever worker gets there)."""
    import validation.design.sweep as worker_study

    write = worker_study._write_record

    def write_then_die(where, record):
        write(where, record)
        if str(where) == folder and not os.path.exists(marker):
            first = worker_study.record_path(where, record["prestretch"])
            with open(marker, "x") as f:
                f.write(str(first.stat().st_mtime_ns))
            os.kill(os.getpid(), signal.SIGKILL)

    worker_study._write_record = write_then_die
    write_then_die.original = write


def _restore_the_record_writer() -> None:
    import validation.design.sweep as worker_study

    worker_study._write_record = getattr(worker_study._write_record, "original", worker_study._write_record)


def test_cluster_run_survives_a_killed_worker_and_equals_the_serial_run(serial, cluster, tmp_path, capsys):
    """The worker solving the slow point is killed right after its first pre-stretch's record
    is written (from inside the worker, so the kill lands at that point on every run): that
    record is kept as it was, the rest is redone, and the table is the serial run's."""
    cl, client = cluster
    g = grid()
    _, slow = g.families
    pids = set(client.run(os.getpid).values())
    marker = tmp_path / "killed"
    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    try:
        client.run(_die_after_the_first_record_of, str(family_dir(tmp_path, slow)), str(marker))
        study = run_design_sweep(g, tmp_path, scheduler=cl.scheduler_address, plots=False, progress=False)
        client.run(_restore_the_record_writer)
    finally:
        cloudpickle.unregister_pickle_by_value(sys.modules[__name__])
    assert study.failed == {}
    assert marker.exists(), "no worker was killed"
    assert len(pids - set(client.run(os.getpid).values())) == 1  # one worker died and was replaced
    first = record_path(family_dir(tmp_path, slow), slow.prestretches[0])
    assert first.stat().st_mtime_ns == int(marker.read_text())  # the finished record not rewritten
    pd.testing.assert_frame_equal(comparable(study.table), comparable(serial.table))
    assert (study.table["status"] == "converged").all()
    assert study.table["bending_angle"].between(5, 90).all()  # a curling strip, not a flat state
    assert (study.table["branch"] == "up").all()  # the way the scene's lift pushed it
    pd.testing.assert_frame_equal(pd.read_parquet(study.files["parquet"]), study.table)

    before = {f.key: mtimes(tmp_path, f) for f in g.families}
    path = tmp_path / "study.toml"
    path.write_text(GRID_TOML)
    assert main(["sweep", str(path), "--out", str(tmp_path), "--workers", "1", "--no-progress"]) == 0
    assert "4 converged; solved 0 path(s) now" in capsys.readouterr().out  # resume: nothing recomputed
    assert {f.key: mtimes(tmp_path, f) for f in g.families} == before
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "study.parquet"), study.table)
    for plot in ("prestretch", "mesh.divisions"):
        assert (tmp_path / "figures" / f"{plot}.png").stat().st_size > 10_000, plot


def test_a_stopped_path_records_why_and_the_pre_stretches_it_did_not_reach(tmp_path):
    """Table I's beam at 8 divisions twists off the flat state and folds its membrane on the way
    to 1.2 (docs/elements.md: it does not curl): that point keeps its status and where it
    stopped, in the table and the ParaView series; 1.3 is not reached; a rerun solves nothing."""
    g = grid(**{"set": {"frame.model": "paper"}, "product": {"mesh.divisions": [8]}, "prestretch": [1.1, 1.2, 1.3]})
    table = run_design_sweep(g, tmp_path, workers=1, vtk=True, plots=False, progress=False).table
    assert table["status"].tolist() == ["converged", "membrane_fold", "not_reached"]
    key = g.families[0].key
    series = (tmp_path / "points" / key / f"{key}.pvd").read_text()  # ParaView series of the path
    assert series.count("<DataSet") == 2 and f"{key}_1.2000.vtu" in series
    assert 1.1 < table["reached_prestretch"][1] < 1.2
    # the folded state's film passes through itself: its angle is not read
    assert table["bending_angle"][:1].notna().all() and table["bending_angle"][1:].isna().all()
    again = run_design_sweep(g, tmp_path, workers=1, plots=False, progress=False)
    assert again.solved == () and again.table.equals(table)


def test_a_failed_path_is_reported_and_left_to_the_rerun(tmp_path, monkeypatch):
    def broken(family, out_dir, vtk):
        raise FloatingPointError(f"path {family.key} diverged")

    monkeypatch.setattr("validation.design.sweep.solve_family", broken)
    study = run_design_sweep(grid(), tmp_path, workers=1, plots=False, progress=False)
    assert set(study.failed) == {f.key for f in grid().families} and study.solved == ()
    assert (study.table["status"] == "failed").all()
    assert study.table["message"].str.contains("FloatingPointError: path .* diverged").all()
    assert not list(tmp_path.glob("points/*/*.json"))  # nothing recorded: a rerun tries again


def test_a_point_whose_record_was_lost_after_its_state_is_solved_again_the_same(tmp_path, monkeypatch):
    """A worker killed between writing a point's state and its record: the rerun solves that point
    again from the state it started from, and its record is the uninterrupted run's."""
    family = grid(product={"mesh.divisions": [6]}).families[0]
    solve_family(family, str(tmp_path / "whole"))
    whole = load_records(tmp_path / "whole", family)

    import validation.design.sweep as study

    write = study._write_record

    def killed_at_the_last_point(folder, record):
        if record["prestretch"] == family.prestretches[-1]:
            raise KeyboardInterrupt("killed")
        write(folder, record)

    out = tmp_path / "killed"
    monkeypatch.setattr(study, "_write_record", killed_at_the_last_point)
    with pytest.raises(KeyboardInterrupt):
        solve_family(family, str(out))
    folder = family_dir(out, family)
    assert state_path(folder, family.prestretches[-1]).exists()  # the state, not the record
    monkeypatch.setattr(study, "_write_record", write)
    assert solve_family(family, str(out)) == 1
    again = load_records(out, family)
    for lam in family.prestretches:
        assert {**again[lam], "wall_time": 0} == {**whole[lam], "wall_time": 0}, lam
    assert sorted(p.name for p in folder.glob("*.npz")) == [state_path(folder, family.prestretches[-1]).name]
