"""Execute the runs of a plan in parallel worker processes, resumably, with timings and memory.

Every finished state is written at once (``runs/<label>/<lambda>.npz`` and a ``.vtu``), and a
run's record (``run.json``) when the run is done; an interrupted validation picks up from
there: complete runs are not repeated, a DR sweep continues from its last finished state, and
a FEM run (one continuation path) is redone.
"""

from __future__ import annotations

import json
import os
import resource
import time
import traceback
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import asdict
from pathlib import Path
from typing import Any, Callable

from tqdm import tqdm

from results import Result, atomic_write_text, load_result, save_result, write_pvd

from .plan import Plan, Run


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
            return (dr.solve(scene, lam) for lam in todo)
        finished = [done[lam] for lam in sorted(done) if done[lam].converged]
        return dr.sweep(scene, todo, start=finished[-1] if finished else None)
    import fem_reference

    if run.cold:
        return (fem_reference.solve(scene.updated(prestretch=lam), refinement=run.refinement) for lam in todo)
    # one continuation path from the flat state: a partly done FEM sweep is redone
    return fem_reference.sweep(scene, run.prestretches, refinement=run.refinement)


def execute(run: Run, scene_data: dict[str, Any], out_dir: str) -> dict[str, Any]:
    """Solve one run (in a worker process) and write its states and record."""
    import scenes

    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    run_dir = Path(out_dir) / "runs" / run.label
    run_dir.mkdir(parents=True, exist_ok=True)
    record: dict[str, Any] = {"run": asdict(run), "states": [], "error": None, "complete": False}
    previous = run_record(run_dir)
    if previous is not None and previous["run"] != _as_recorded(run):
        # the plan changed: the states on disk belong to another run
        for stale in [*run_dir.glob("*.npz"), *run_dir.glob("*.vtu"), *run_dir.glob("*.pvd")]:
            stale.unlink()
    atomic_write_text(run_dir / "run.json", json.dumps(record, indent=1))
    measured = _reset_peak_memory()
    t0 = time.perf_counter()
    states: dict[float, Result] = {}
    try:
        scene = scenes.Scene.from_dict(scene_data).updated(**run.changes)
        states.update(load_states(run_dir, run.prestretches))
        for res in _states(run, scene, dict(states)):
            save_result(state_path(run_dir, res.prestretch), res)
            res.write_vtk(run_dir / f"{run.label}_{res.prestretch:.3f}.vtu")
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
        {"prestretch": lam, "status": r.status, "converged": r.converged, "wall_time": r.wall_time,
         "iterations": r.iterations, "message": r.message}
        for lam, r in sorted(states.items())
    ]
    vtus = [(lam, run_dir / f"{run.label}_{lam:.3f}.vtu") for lam in sorted(states)]
    if vtus:
        write_pvd(run_dir / f"{run.label}.pvd", [(lam, p) for lam, p in vtus if p.exists()])
    record["complete"] = record["error"] is None
    atomic_write_text(run_dir / "run.json", json.dumps(record, indent=1))
    return record


def is_complete(run: Run, out_dir: Path) -> bool:
    rec = run_record(out_dir / "runs" / run.label)
    return bool(rec and rec.get("complete") and rec["run"] == _as_recorded(run))


def _as_recorded(run: Run) -> dict[str, Any]:
    """``run`` as its record holds it (through JSON: tuples become lists)."""
    return json.loads(json.dumps(asdict(run)))


def run_plan(plan: Plan, scene_data: dict[str, Any], out_dir: Path, workers: int = 2,
             progress: bool = True, on_done: Callable[[dict[str, Any]], None] | None = None) -> dict[str, dict[str, Any]]:
    """Execute every run of ``plan`` that is not complete on disk; returns all run records."""
    out_dir.mkdir(parents=True, exist_ok=True)
    todo = [r for r in plan.runs if not is_complete(r, out_dir)]
    # the slowest first, so that two workers finish together
    todo.sort(key=lambda r: (r.solver != "fem", -r.refinement, -len(r.prestretches)))
    bar = tqdm(total=len(plan.runs), initial=len(plan.runs) - len(todo), desc="validate", unit="run",
               disable=not progress)
    try:
        if workers <= 1:
            for r in todo:
                rec = execute(r, scene_data, str(out_dir))
                bar.set_postfix_str(r.label)
                bar.update()
                if on_done:
                    on_done(rec)
        else:
            with ProcessPoolExecutor(max_workers=workers) as pool:
                futures = {pool.submit(execute, r, scene_data, str(out_dir)): r for r in todo}
                for fut in as_completed(futures):
                    rec = fut.result()
                    bar.set_postfix_str(futures[fut].label)
                    bar.update()
                    if on_done:
                        on_done(rec)
    finally:
        bar.close()
    return {r.label: run_record(out_dir / "runs" / r.label) or {} for r in plan.runs}
