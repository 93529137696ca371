"""Execute the runs of a plan on a Dask cluster (:mod:`validation.common.executor`), resumably, with
timings and memory.

Every finished state is written at once (``runs/<label>/<lambda>.npz`` and a ``.vtu``), and a
run's record (``run.json``) when the run is done; an interrupted validation picks up from
there: complete runs are not repeated, a DR sweep continues from its last finished state, and
a FEM run (one continuation path) is redone.

Runs of the plan that compute the same thing under two labels (the same solver, scene, levels
and start; e.g. the speed study's tightest 40-division DR state is DR's own refinement at 40
divisions) are solved once: the other label gets a copy of the states and files, and its
record names the run it was copied from (``same_as``).

A run on disk is reused only if it was made from the same computation by the same code: its
record holds a key (:func:`run_key`) of the scene after the run's changes, its levels and
options, and the sources of the packages that make states; a run whose key differs is solved
again from scratch and its record says why (``resolved``). While ``run_plan`` fills a folder,
the folder is locked against another process (:mod:`validation.common.lock`).
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import resource
import shutil
import time
import traceback
from dataclasses import asdict
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import scenes
from results import Result, atomic_write_text, level_label, load_result, save_result, write_pvd

from ..common.executor import DEFAULT_WORKERS, connect, run_tasks
from ..common.lock import folder_lock
from .plan import Plan, Run
from .study import Study

STATE_CODE = ("dr", "fem_reference", "results", "scenes", "validation/report/studies/experiment.py",
              "validation/actuation/calibrate.py", "validation/actuation/actuate.py", "validation/report/runner.py")
"""The sources whose code makes a run's states (packages: every ``*.py`` in them), relative to
the project root: an edit of any of them makes the runs on disk stale."""

RESOLVED = "its scene, settings or code differ from those its states were made with"
"""Why a run on disk was solved again (its record's ``resolved``)."""


def state_path(run_dir: Path, lam: float) -> Path:
    return run_dir / f"{lam:.4f}.npz"


def state_key(res: Result, requested: tuple[float, ...]) -> float:
    """The requested pre-stretch a state solves, or the one it reached if it stopped early."""
    return next((lam for lam in requested if abs(lam - res.prestretch) < 1e-9), res.prestretch)


def load_states(run_dir: Path, requested: tuple[float, ...]) -> dict[float, Result]:
    """The states of a run that are on disk, keyed by :func:`state_key`.

    A path that stopped early (contact, no convergence) left its last state at the pre-stretch
    it reached, which is none of the requested ones; it is loaded too, so that the report
    shows where and why the run stopped.
    """
    states = (load_result(path) for path in sorted(run_dir.glob("*.npz")))
    return {state_key(res, requested): res for res in states}


def run_record(run_dir: Path) -> dict[str, Any] | None:
    path = run_dir / "run.json"
    return json.loads(path.read_text()) if path.exists() else None


def _reset_peak_memory() -> bool:
    """Reset this process's peak resident memory (Linux: /proc/self/clear_refs <- 5)."""
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
        return True
    except OSError:
        return False


def _peak_memory_mb() -> float:
    """Peak resident memory of this process since the last reset, MB."""
    try:
        for line in open("/proc/self/status"):
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _states(run: Run, scene: Any, done: dict[float, Result]):
    """The solver's states for ``run`` that are not on disk yet."""
    todo = [lam for lam in run.prestretches if lam not in done]
    if run.solver == "dr":
        import dr

        if run.cold:
            found = (dr.solve(scene, lam) for lam in todo)
            return (_polished(res) for res in found) if run.polish else found
        finished = [done[lam] for lam in sorted(done) if done[lam].converged]
        return dr.sweep(scene, todo, start=finished[-1] if finished else None)
    import fem_reference

    if run.cold:
        return (fem_reference.solve(scene.updated(prestretch=lam), refinement=run.refinement) for lam in todo)
    # one continuation path from the flat state: a partly done FEM sweep is redone
    return fem_reference.sweep(scene, run.prestretches, refinement=run.refinement)


def _polished(found: Result) -> Result:
    """The FEM's Newton from DR's state on the same discrete problem: the stable state it is
    (or leads to), with DR's bending angle and cost beside it."""
    import fem_reference

    if not found.converged:
        return found
    res = fem_reference.solve_from(found.scene, found.x, refinement=found.scene.fem.refinement)
    res.info.update(dr_bending_angle=found.bending_angle, dr_iterations=found.iterations,
                    dr_wall_time=found.wall_time)
    res.wall_time += found.wall_time
    return res


StudyExecute = Callable[[Run, Any, Path], dict[float, Result]]
"""A study's solver of its own runs (:attr:`validation.report.study.Study.execute`)."""


def execute(run: Run, scene_data: dict[str, Any], out_dir: str,
            copies: dict[str, tuple[Run, ...]] | None = None,
            studies: Mapping[str, StudyExecute] | None = None) -> dict[str, Any]:
    """Solve one run (in a worker process) and write its states and record; the runs in
    ``copies[run.label]`` (the same computation, see :func:`computation_key`) get a copy. A run
    of a group in ``studies`` is solved by that study's ``execute``."""
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    run_dir = Path(out_dir) / "runs" / run.label
    run_dir.mkdir(parents=True, exist_ok=True)
    key = run_key(run, scene_data)
    record: dict[str, Any] = {"run": _as_recorded(run), "key": key, "states": [], "error": None, "complete": False}
    if _clear_another_run(run_dir, run, key):
        record["resolved"] = RESOLVED
    atomic_write_text(run_dir / "run.json", json.dumps(record, indent=1))
    measured = _reset_peak_memory()
    t0 = time.perf_counter()
    states: dict[float, Result] = {}
    try:
        scene = scenes.Scene.from_dict(scene_data).updated(**run.changes)
        study = (studies or {}).get(run.group)
        if study is not None:
            states = study(run, scene, run_dir)
        else:
            states.update(load_states(run_dir, run.prestretches))
            for res in _states(run, scene, dict(states)):
                save_result(state_path(run_dir, res.prestretch), res)
                res.write_vtk(run_dir / f"{run.label}_{level_label(res.prestretch)}.vtu")
                states[state_key(res, run.prestretches)] = res
    except scenes.DemesError as exc:  # bad input for this run: named, no traceback
        record["error"] = f"{'scene error' if isinstance(exc, scenes.SceneError) else 'refused'}: {exc}"
    except Exception as exc:  # a solver failure is a result of the validation, not its end
        record["error"] = f"{type(exc).__name__}: {exc}"
        record["traceback"] = traceback.format_exc(limit=4)
    record["wall_time"] = time.perf_counter() - t0
    record["peak_memory_mb"] = _peak_memory_mb()
    record["peak_memory_is_per_run"] = measured
    record["states"] = [
        {"voltage" if run.voltages else "prestretch": lam, "status": r.status, "converged": r.converged, "wall_time": r.wall_time,
         "iterations": r.iterations, "message": r.message}
        for lam, r in sorted(states.items())
    ]
    vtus = [(lam, run_dir / f"{run.label}_{level_label(lam)}.vtu") for lam in sorted(states)]
    if vtus and not run.voltages:
        write_pvd(run_dir / f"{run.label}.pvd", [(lam, p) for lam, p in vtus if p.exists()])
    record["complete"] = record["error"] is None
    atomic_write_text(run_dir / "run.json", json.dumps(record, indent=1))
    for twin in (copies or {}).get(run.label, ()):
        copy_run(run, twin, Path(out_dir))
    return record


@functools.lru_cache(maxsize=1)
def code_version() -> str:
    """SHA-256 of the sources in :data:`STATE_CODE` as they are on disk (read once per process)."""
    from dr.cache import source_digest

    root = Path(__file__).resolve().parents[2]
    paths = [p for name in STATE_CODE
             for p in ([root / name] if name.endswith(".py") else sorted((root / name).glob("*.py")))]
    return source_digest(paths)


def run_key(run: Run, scene_data: dict[str, Any]) -> str:
    """What a run's states are made from: its :func:`computation_key` and the :func:`code_version`."""
    return hashlib.sha256((computation_key(run, scene_data) + code_version()).encode()).hexdigest()


def computation_key(run: Run, scene_data: dict[str, Any]) -> str:
    """What ``run`` computes: solver, scene with the run's changes, levels, start and options.
    Two runs with one key give the same states bit for bit; a one-level DR sweep starts from
    the flat state, as a cold solve does, so the two count as one."""
    key = _as_recorded(run)
    for name in ("label", "title", "group", "changes"):
        del key[name]
    try:
        key["scene"] = scenes.Scene.from_dict(scene_data).updated(**run.changes).to_dict()
    except scenes.DemesError:  # a refused scene: the run itself says why
        return json.dumps({"label": run.label})
    if run.solver == "dr" and len(run.prestretches) == 1 and not run.voltages:
        key["cold"] = True
    return json.dumps(key, sort_keys=True, default=str)


def copy_run(source: Run, target: Run, out_dir: Path) -> None:
    """Give ``target`` the files of ``source``, a run of the same computation: files named
    after the run are renamed, states already there are kept (they are the same), other files
    are replaced, and the record, written last, names the run it comes from (``same_as``)."""
    src, dst = out_dir / "runs" / source.label, out_dir / "runs" / target.label
    dst.mkdir(parents=True, exist_ok=True)
    record = run_record(src) or {}
    resolved = _clear_another_run(dst, target, record.get("key"))
    for path in sorted(src.iterdir()):
        if path.name == "run.json" or not path.is_file():
            continue
        name = target.label + path.name[len(source.label):] if path.name.startswith(source.label) else path.name
        if path.suffix == ".pvd":  # it lists its .vtu files by name
            atomic_write_text(dst / name, path.read_text().replace(f'file="{source.label}_', f'file="{target.label}_'))
        elif path.suffix != ".npz" or not (dst / name).exists():
            part = dst / f".{name}.part"  # atomic: an interrupted copy leaves no half state
            shutil.copyfile(path, part)
            os.replace(part, dst / name)
    record.update(run=_as_recorded(target), same_as=source.label)
    if resolved:
        record["resolved"] = RESOLVED
    atomic_write_text(dst / "run.json", json.dumps(record, indent=1))


def _clear_another_run(run_dir: Path, run: Run, key: str | None) -> bool:
    """Delete the states and VTK files in ``run_dir`` if its record is of another run (the plan
    changed) or of another :func:`run_key` (scene, settings or code changed): they are not
    ``run``'s. Returns whether a record of a run with another key was there."""
    previous = run_record(run_dir)
    if previous is None:
        return False
    if previous["run"] != _as_recorded(run) or previous.get("key") != key:
        for stale in [*run_dir.glob("*.npz"), *run_dir.glob("*.vtu"), *run_dir.glob("*.pvd")]:
            stale.unlink()
    return previous["run"] == _as_recorded(run) and previous.get("key") != key


def is_complete(run: Run, out_dir: Path, key: str) -> bool:
    """Whether ``run`` is on disk, complete and made with :func:`run_key` ``key``."""
    rec = run_record(out_dir / "runs" / run.label)
    return bool(rec and rec.get("complete") and rec["run"] == _as_recorded(run) and rec.get("key") == key)


def stale_runs(plan: Plan, scene_data: dict[str, Any], out_dir: Path) -> list[str]:
    """Runs of ``plan`` complete on disk but made with another scene, settings or code."""
    return [r.label for r in plan.runs
            if (rec := run_record(out_dir / "runs" / r.label)) and rec.get("complete")
            and rec.get("key") != run_key(r, scene_data)]


def _as_recorded(run: Run) -> dict[str, Any]:
    """``run`` as its record holds it (through JSON: tuples become lists). The voltage and
    polish fields are left out where they are off: a record holds the options its run uses."""
    rec = asdict(run)
    for key in ("voltages", "calibrate", "polish"):
        if not rec[key]:
            del rec[key]
    return json.loads(json.dumps(rec))


def run_plan(plan: Plan, scene_data: dict[str, Any], out_dir: Path, workers: int = DEFAULT_WORKERS,
             progress: bool = True, on_done: Callable[[dict[str, Any]], None] | None = None,
             scheduler: str | None = None, *, studies: Sequence[Study] = ()) -> dict[str, dict[str, Any]]:
    """Execute every run of ``plan`` that is not complete on disk; returns all run records.

    The runs go to the Dask cluster at ``scheduler`` if given, else to a LocalCluster of
    ``workers`` processes (``workers <= 1``: this process), see :mod:`validation.common.executor`.
    The runs of each study's group are solved by the study (:class:`validation.report.study.Study`).
    """
    executes = {study.group: study.execute for study in studies if study.execute is not None}
    with folder_lock(out_dir, "demes validate"):
        return _run_plan(plan, scene_data, out_dir, workers, progress, on_done, scheduler, executes)


def _run_plan(plan: Plan, scene_data: dict[str, Any], out_dir: Path, workers: int, progress: bool,
              on_done: Callable[[dict[str, Any]], None] | None, scheduler: str | None,
              studies: Mapping[str, StudyExecute]) -> dict[str, dict[str, Any]]:
    todo, copies = _computations(plan, scene_data, out_dir)
    # the slowest first, so that the workers finish together: the runs that take minutes (the
    # reference levels, the main sweeps, DR's own refinement, the voltage runs, DR on 40 or more
    # divisions), then the rest (measured: a 56-division hard case left last ran 4 min alone)
    long_groups = ("reference", "sweep", "drconv", "experiment")
    todo.sort(key=lambda r: (r.group not in long_groups and r.changes.get("mesh.divisions", 0) < 40,
                             r.solver != "fem", -r.refinement, -len(r.prestretches) - len(r.voltages)))
    def weight(run: Run) -> int:
        return 1 + len(copies[run.label])

    with connect(scheduler, workers if todo else 1) as client:
        for outcome in run_tasks(execute, todo, client=client, args=(scene_data, str(out_dir), copies, studies),
                                 weight=weight, total=len(plan.runs),
                                 done=len(plan.runs) - sum(weight(r) for r in todo),
                                 desc="validate", unit="run", progress=progress):
            if outcome.error is not None:
                # the worker died: the run's record on disk says how far it got
                raise RuntimeError(f"validation run {outcome.task.label!r} failed: {outcome.error}")
            if on_done:
                on_done(outcome.value)
    return {r.label: run_record(out_dir / "runs" / r.label) or {} for r in plan.runs}


def _computations(plan: Plan, scene_data: dict[str, Any], out_dir: Path
                  ) -> tuple[list[Run], dict[str, tuple[Run, ...]]]:
    """The runs to solve, one per computation that some run still needs, and for each the runs
    that get a copy of it; a run whose computation is complete under another label gets its
    copy here, without solving."""
    same: dict[str, list[Run]] = {}
    for run in plan.runs:
        same.setdefault(run_key(run, scene_data), []).append(run)
    todo, copies = [], {}
    for key, runs in same.items():
        missing = [r for r in runs if not is_complete(r, out_dir, key)]
        done = [r for r in runs if r not in missing]
        if done:
            for run in missing:
                copy_run(done[0], run, out_dir)
        elif missing:
            # the one with most states on disk resumes; the others wait for its copy
            first = max(missing, key=lambda r: len(list((out_dir / "runs" / r.label).glob("*.npz"))))
            todo.append(first)
            copies[first.label] = tuple(r for r in missing if r is not first)
    return todo, copies
