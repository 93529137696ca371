"""The gallery: DR and the FEM on one discrete problem for built-in scenes of varied outlines.

Each scene is solved by DR's membrane triangles and the FEM's P1 elements on the same mesh
(refinement 0, so both minimise one discrete energy, docs/discrete-problem.md), along one
pre-stretch path from the flat state. A row per scene and pre-stretch says where the two
agree (:data:`ANGLE_AGREES` deg, :data:`ENERGY_AGREES` relative energy), each state's branch
and stability, the jumps on the way, and each solver's time. Scenes fan out over a Dask
cluster (:mod:`validation.common.executor`); each scene's states are written as they end.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any, Sequence

import numpy as np

import scenes
from results import Result, atomic_write_text, level_label

from ..common.executor import connect, run_tasks
from ..common.tables import write_csv

GALLERY = ("square", "tall_rectangle", "wide_rectangle", "pentagon", "hexagon", "octagon", "large_triangle",
           "asymmetric_quadrilateral", "thick_film_triangle", "rectangular_demes", "finger", "multisegment_gripper")
"""The built-in gallery scenes (scenes/<name>.toml)."""

PRESTRETCHES = (1.1, 1.3)

ANGLE_AGREES = 0.1
"""deg: two states this close in bending angle (and in energy) are one state."""

ENERGY_AGREES = 1e-4
"""Relative energy difference below which two states are one (with the angle)."""

COLUMNS = (
    ("scene", "-"), ("prestretch", "-"),
    ("dr_status", "-"), ("dr_angle", "deg"), ("dr_branch", "-"), ("dr_energy", "N mm"), ("dr_stable", "-"),
    ("dr_jumps", "-"), ("dr_time", "s"), ("dr_reached", "-"), ("dr_mirror", "-"), ("dr_newton_step", "mm"),
    ("fem_status", "-"), ("fem_angle", "deg"), ("fem_branch", "-"), ("fem_energy", "N mm"), ("fem_stable", "-"),
    ("fem_jumps", "-"), ("fem_time", "s"), ("fem_reached", "-"), ("fem_mirror", "-"),
    ("angle_difference", "deg"), ("energy_difference", "-"), ("agree", "-"),
)


def gallery_scene(name: str, divisions: int = 14) -> scenes.Scene:
    """Built-in scene ``name`` as the gallery solves it: DR's triangles on the FEM's P1 mesh."""
    return scenes.load(name).updated(**{"dr.membrane_net": "triangles", "fem.element": "P1", "fem.refinement": 0,
                                        "mesh.divisions": divisions})


def _solver_columns(prefix: str, res: Result | None) -> dict[str, Any]:
    if res is None:
        return {f"{prefix}_status": "not reached"}
    row = res.summary()
    return {f"{prefix}_status": res.status, f"{prefix}_angle": row["bending_angle"], f"{prefix}_branch": row["branch"],
            f"{prefix}_energy": res.energy["total"], f"{prefix}_stable": row["stable"],
            f"{prefix}_jumps": row["jumps"], f"{prefix}_time": res.wall_time, f"{prefix}_reached": res.prestretch,
            f"{prefix}_mirror": _mirror_words(res)}


def _mirror_words(res: Result) -> str:
    """'up 52.96' for a state against the lift whose mirror image through the flat plane is a
    stable state of the same energy (:func:`validation.solve.other_starts.mirror_state`)."""
    mirror = res.info.get("mirror_state")
    return f"{mirror['branch']} {mirror['bending_angle']:.2f}" if mirror else ""


def compare(name: str, lam: float, dr_state: Result | None, fem_state: Result | None) -> dict[str, Any]:
    """One gallery row: both solvers' states at ``lam`` and whether they are one state."""
    row: dict[str, Any] = {"scene": name, "prestretch": lam, **_solver_columns("dr", dr_state),
                           **_solver_columns("fem", fem_state),
                           "dr_newton_step": dr_state.info.get("newton_step_mm", np.nan) if dr_state else np.nan}
    both = dr_state is not None and fem_state is not None and dr_state.converged and fem_state.converged
    if both:
        d_angle = abs(row["dr_angle"] - row["fem_angle"])
        d_energy = abs(row["dr_energy"] - row["fem_energy"]) / max(abs(row["fem_energy"]), 1e-300)
        row.update(angle_difference=d_angle, energy_difference=d_energy,
                   agree=bool(d_angle <= ANGLE_AGREES and d_energy <= ENERGY_AGREES))
    else:
        row.update(angle_difference=np.nan, energy_difference=np.nan, agree=False)
    return row


def run_scene(name: str, out_dir: str, prestretches: Sequence[float], divisions: int) -> list[dict[str, Any]]:
    """Both solvers along the path of scene ``name`` (a built-in name or a .toml file); writes
    its VTK states and picture, named by the scene's own name, and returns its rows."""
    import dr
    import fem_reference

    from . import other_starts

    scene = gallery_scene(name, divisions)
    out = Path(out_dir)
    states: dict[str, dict[float, Result]] = {}
    for solver, sweep in (("dr", dr.sweep), ("fem", fem_reference.sweep)):
        states[solver] = {}
        for res in sweep(scene, list(prestretches)):
            res.write_vtk(out / f"{scene.name}_{solver}_{level_label(res.prestretch)}.vtu")
            # a path that stopped short (contact, fold) is shown at the level it was headed for
            headed = min((lam for lam in prestretches if lam >= res.prestretch - 1e-12), default=res.prestretch)
            other_starts.mirror_state(res)
            states[solver][headed] = res
    _picture(scene.name, states, out)
    return [compare(scene.name, lam, states["dr"].get(lam), states["fem"].get(lam)) for lam in prestretches]


def _picture(name: str, states: dict[str, dict[float, Result]], out: Path) -> None:
    """``name``.png of the states, DR's then the FEM's; none where this machine cannot render
    (``demes gallery`` names the scenes left without one)."""
    from results.render import RenderUnavailable, render_states

    shown = [*states["dr"].values(), *states["fem"].values()]
    try:
        render_states(shown, out / f"{name}.png", f"{name}: DR triangles ({len(states['dr'])}), then FEM P1")
    except RenderUnavailable:
        pass


def run_gallery(out_dir: str | Path, names: Sequence[str] = GALLERY, prestretches: Sequence[float] = PRESTRETCHES,
                divisions: int = 14, workers: int = 2, scheduler: str | None = None,
                progress: bool = True) -> list[dict[str, Any]]:
    """Run the gallery; writes ``gallery.csv`` and ``gallery.md`` in ``out_dir`` after each
    scene (so an interrupted run keeps the scenes it finished) and returns the rows."""
    for name in names:
        scenes.load(name)  # a bad name fails here, before any work
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rows: list[dict[str, Any]] = []
    finished: dict[str, list[dict[str, Any]]] = {}
    errors: list[str] = []
    t0 = time.perf_counter()
    with connect(scheduler, workers) as client:
        for outcome in run_tasks(run_scene, list(names), client=client, args=(str(out), tuple(prestretches), divisions),
                                 desc="gallery", unit="scene", progress=progress):
            if outcome.error:
                errors.append(f"{outcome.task}: {outcome.error}")
            else:
                finished[outcome.task] = outcome.value
            rows = [row for name in names for row in finished.get(name, [])]  # in the order asked for
            write_csv(out / "gallery.csv", rows, [c for c, _ in COLUMNS], dict(COLUMNS))
            atomic_write_text(out / "gallery.md", table(rows, errors, time.perf_counter() - t0))
    return rows


def _status(row: dict[str, Any], prefix: str) -> str:
    """A solver's status, with the pre-stretch it stopped at where that is short of the row's."""
    reached = row.get(f"{prefix}_reached", row["prestretch"])
    status = row[f"{prefix}_status"]
    return status if reached >= row["prestretch"] - 1e-12 else f"{status} at {reached:.4f}"


def table(rows: Sequence[dict[str, Any]], errors: Sequence[str] = (), seconds: float = float("nan")) -> str:
    """The gallery table in Markdown."""
    def angle(v: Any) -> str:
        return f"{v:.2f}" if isinstance(v, float) and np.isfinite(v) else "-"

    lines = ["# Gallery: DR triangles against the FEM P1 on one discrete problem", "",
             f"States agree within {ANGLE_AGREES:g} deg and {ENERGY_AGREES:g} relative energy. "
             "Stable: lowest eigenvalue of the stiffness not negative (DR against its masses, the FEM its tangent). "
             "Mirror: for a state against the scene's lift, its mirror image through the flat plane where that is a "
             "stable state of the same energy (branch, deg). DR step: the length of the Newton step K^-1 r from DR's "
             "state to the discrete equilibrium (mm), how far its residual tolerance left it.",
             "",
             "| scene | lambda | DR deg | FEM deg | branch DR/FEM | dE/E | agree | stable DR/FEM | mirror DR / FEM "
             "| DR step mm | jumps DR / FEM | DR s | FEM s | status DR/FEM |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        de = r.get("energy_difference", np.nan)
        lines.append(
            f"| {r['scene']} | {r['prestretch']:g} | {angle(r.get('dr_angle'))} | {angle(r.get('fem_angle'))} | "
            f"{r.get('dr_branch', '-')}/{r.get('fem_branch', '-')} | {de:.1e} | {'yes' if r['agree'] else 'no'} | "
            f"{r.get('dr_stable', '-')}/{r.get('fem_stable', '-')} | {r.get('dr_mirror') or '-'} / {r.get('fem_mirror') or '-'} | "
            f"{r.get('dr_newton_step', np.nan):.1e} | "
            f"{r.get('dr_jumps') or '-'} / {r.get('fem_jumps') or '-'} | "
            f"{r.get('dr_time', np.nan):.1f} | {r.get('fem_time', np.nan):.1f} | {_status(r, 'dr')}/{_status(r, 'fem')} |")
    agreed = sum(bool(r["agree"]) for r in rows)
    lines += ["", f"{agreed} of {len(rows)} states agree" + (f"; {seconds:.0f} s in all" if np.isfinite(seconds) else "") + "."]
    lines += [f"- {e}" for e in errors]
    return "\n".join(lines) + "\n"
