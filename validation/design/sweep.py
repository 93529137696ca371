"""``demes sweep``: solve every point of a design grid on a Dask cluster, resumably; one table.

Each family of the grid (the points that differ only in pre-stretch) is one task, a path
warm-started from one pre-stretch to the next. The task writes each point's record
(``points/<family>/<lambda>.json``) atomically as soon as the point is solved, after its state
(``<lambda>.npz``); only the last recorded point's state is kept, as the one a rerun continues
from. A rerun solves only the points with no record, so a killed worker or an interrupted study
loses only the point in progress, and redoes it from the state it started from.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterator

import numpy as np
import pandas as pd

from results import Result, atomic_write, atomic_write_text, load_result, save_result, write_pvd

from ..common.executor import DEFAULT_WORKERS, connect, run_tasks
from ..common.tables import write_csv
from .grid import Family, Grid

MEASURES = (
    "bending_angle", "apex_x", "apex_y", "apex_z", "mid_height_width",
    "energy_membrane", "energy_frame_bending", "energy_frame_torsion", "energy_frame_axial", "energy_total",
    "iterations", "residual", "wall_time",
)
"""The measures of each point (:data:`results.SUMMARY_COLUMNS` names and units)."""

COLUMNS = ("prestretch", "status", "converged", "branch", *MEASURES, "reached_prestretch", "point", "message")
"""The table's columns after the swept fields."""

NOT_REACHED = "not_reached"
"""Status of a pre-stretch above the one where its path stopped (contact, fold, divergence)."""


@dataclass(frozen=True)
class DesignSweep:
    """What :func:`run_design_sweep` did: the table (one row per grid point, grid order), the families
    it solved in this call, the ones that failed (key -> error) and the files it wrote."""

    table: pd.DataFrame
    solved: tuple[str, ...]
    failed: dict[str, str]
    files: dict[str, Path]
    wall_time: float


def family_dir(out_dir: str | Path, family: Family) -> Path:
    return Path(out_dir) / "points" / family.key


def record_path(folder: Path, lam: float) -> Path:
    return folder / f"{lam:.4f}.json"


def load_records(out_dir: str | Path, family: Family) -> dict[float, dict[str, Any]]:
    """The records of ``family`` on disk, by pre-stretch."""
    folder = family_dir(out_dir, family)
    paths = {lam: record_path(folder, lam) for lam in family.prestretches}
    return {lam: json.loads(p.read_text()) for lam, p in paths.items() if p.exists()}


def state_path(folder: Path, lam: float) -> Path:
    return folder / f"{lam:.4f}.npz"


def solve_family(family: Family, out_dir: str, vtk: bool = False) -> int:
    """Solve the points of ``family`` that have no record yet (on a worker), writing each one's
    state, then its record, as it finishes; returns how many points it solved."""
    import scenes

    folder = family_dir(out_dir, family)
    folder.mkdir(parents=True, exist_ok=True)
    done = load_records(out_dir, family)
    stops = [lam for lam, rec in done.items() if not rec["converged"]]
    todo = [lam for lam in family.prestretches if lam not in done]
    # above the pre-stretch where its path stopped, the path cannot go on
    reachable = [lam for lam in todo if not stops or lam < min(stops)]
    scene = scenes.Scene.from_dict(family.scene_data)
    solved = 0
    for lam, res in zip(reachable, _states(family, scene, reachable, folder, done)):
        if res.converged:
            save_result(state_path(folder, lam), res)
        else:
            stops.append(lam)
        if vtk:
            _write_vtk(folder, family, lam, res)
        _write_record(folder, _record(family, lam, res))
        solved += 1
        if res.converged:
            _keep_only_the_state_of(folder, lam)
    stop = min(stops, default=np.inf)
    for lam in todo:
        if lam > stop and not record_path(folder, lam).exists():
            _write_record(folder, _not_reached(family, lam, stop))
    return solved


def _keep_only_the_state_of(folder: Path, lam: float) -> None:
    for path in folder.glob("*.npz"):
        if path != state_path(folder, lam):
            path.unlink(missing_ok=True)


def _states(family: Family, scene: Any, prestretches: list[float], folder: Path,
            done: dict[float, dict[str, Any]]) -> Iterator[Result]:
    if not prestretches:
        return iter(())
    if family.solver == "fem":
        import fem_reference

        # one continuation path from the flat state: an interrupted path is redone
        return fem_reference.sweep(scene, prestretches)
    import dr

    # the path goes on from the last recorded state below the first point to solve; a state
    # saved without its record (the worker stopped in between) is not used: that point is
    # solved again from the same state as before, so it comes out the same
    below = [lam for lam, rec in done.items() if rec["converged"] and lam < prestretches[0]]
    path = state_path(folder, max(below)) if below else None
    start = load_result(path) if path is not None and path.exists() else None
    return dr.sweep(scene, prestretches, start=start)


def _record(family: Family, lam: float, res: Result) -> dict[str, Any]:
    row = res.summary()
    return {
        **family.fields, "prestretch": lam, **{c: row[c] for c in ("status", "converged", "branch", *MEASURES)},
        "reached_prestretch": res.prestretch, "point": family.key, "message": res.message,
    }


def _not_reached(family: Family, lam: float, stop: float) -> dict[str, Any]:
    return {
        **family.fields, "prestretch": lam, "status": NOT_REACHED, "converged": False, "branch": "",
        **{m: float("nan") for m in MEASURES}, "reached_prestretch": float("nan"), "point": family.key,
        "message": f"not reached: the path stopped on its way to the pre-stretch {stop:g}",
    }


def _write_record(folder: Path, record: dict[str, Any]) -> None:
    atomic_write_text(record_path(folder, record["prestretch"]), json.dumps(record, indent=1))


def _write_vtk(folder: Path, family: Family, lam: float, res: Result) -> None:
    res.write_vtk(folder / f"{family.key}_{lam:.4f}.vtu")
    series = [(v, folder / f"{family.key}_{v:.4f}.vtu") for v in family.prestretches]
    write_pvd(folder / f"{family.key}.pvd", [(v, p) for v, p in series if p.exists()])


def study_table(grid: Grid, out_dir: str | Path, failed: dict[str, str] | None = None) -> pd.DataFrame:
    """One row per grid point (grid order) from the records on disk; a point without one has
    status 'failed' (its task's error) or 'missing'."""
    rows = []
    for family in grid.families:
        records = load_records(out_dir, family)
        for lam in grid.prestretches:
            row = records.get(lam)
            if row is None:
                error = (failed or {}).get(family.key)
                row = {**family.fields, "prestretch": lam, "status": "failed" if error else "missing",
                       "converged": False, "point": family.key, "message": error or "not solved yet"}
            rows.append(row)
    columns = [*grid.fields, *COLUMNS]
    return pd.DataFrame([{c: _cell(r.get(c, float("nan"))) for c in columns} for r in rows], columns=columns)


def _cell(value: Any) -> Any:
    """Lists (polygon vertices) as JSON text: a table cell is a scalar."""
    return json.dumps(value) if isinstance(value, (list, tuple, dict)) else value


def write_table(table: pd.DataFrame, out_dir: Path, name: str) -> dict[str, Path]:
    """The table as CSV (units in the headers, as every CSV of the project) and Parquet; atomically."""
    csv = write_csv(out_dir / f"{name}.csv", table.to_dict("records"), list(table.columns))
    parquet = atomic_write(out_dir / f"{name}.parquet", lambda p: table.to_parquet(p, index=False))
    return {"csv": csv, "parquet": parquet}


def _recorded(grid: Grid, out_dir: Path) -> int:
    """How many points of ``grid`` have a record on disk (the progress of running paths)."""
    return sum(record_path(family_dir(out_dir, f), lam).exists() for f in grid.families for lam in f.prestretches)


def run_design_sweep(grid: Grid, out_dir: str | Path, *, scheduler: str | None = None,
                     workers: int = DEFAULT_WORKERS, vtk: bool = False, plots: bool = True,
                     progress: bool = True) -> DesignSweep:
    """Solve every point of ``grid`` without a record in ``out_dir``, then write the table
    (``<grid>.csv``, ``<grid>.parquet``) and the plots (``figures/``).

    Parameters
    ----------
    scheduler
        Address of a running Dask cluster (``tcp://host:8786``); default a LocalCluster of
        ``workers`` single-threaded processes (``workers <= 1``: this process, serially).
    vtk
        Also write a ParaView series per family (``points/<family>/<family>.pvd``).
    plots
        Draw each measure against each swept field (``figures/<field>.png``).
    """
    from .figures import measure_plots

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    left = {f.key: len(f.prestretches) - len(load_records(out, f)) for f in grid.families}
    todo = [f for f in grid.families if left[f.key]]
    solved, failed = [], {}
    with connect(scheduler, workers if todo else 1) as client:
        for outcome in run_tasks(solve_family, todo, client=client, args=(str(out), vtk),
                                 weight=lambda f: left[f.key], total=grid.n_points,
                                 done=grid.n_points - sum(left.values()), desc=grid.name, unit="point",
                                 progress=progress, poll=lambda: _recorded(grid, out)):
            if outcome.error is None:
                solved.append(outcome.task.key)
            else:
                failed[outcome.task.key] = outcome.error
    table = study_table(grid, out, failed)
    files = write_table(table, out, grid.name)
    if plots:
        files.update(measure_plots(table, grid, out / "figures"))
    return DesignSweep(table, tuple(solved), failed, files, time.perf_counter() - t0)
