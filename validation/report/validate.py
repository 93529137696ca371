"""``demes validate``: run the plan, analyse it, draw it, write the report.

Here the studies that plug into the validation (:class:`validation.report.study.Study`) are listed
and handed to every stage.
"""

from __future__ import annotations

import time
from pathlib import Path

import scenes

from . import figures
from .analysis import Analysis, analyse
from .plan import Plan, build_plan
from .runner import run_plan, stale_runs
from .studies import budget, experiment, hard_cases, scene_mesh, second_states, speed
from .study import Study
from .writing import write_report

STUDIES: tuple[Study, ...] = (scene_mesh.STUDY, speed.STUDY, budget.STUDY, second_states.STUDY, hard_cases.STUDY, experiment.STUDY)
"""The studies of ``demes validate`` beside its core comparison, in the report's order."""


def validation_plan(quick: bool = False) -> Plan:
    """The plan ``demes validate`` runs: the core's runs and those of every study in :data:`STUDIES`."""
    return build_plan(quick, studies=STUDIES)


def validate(scene: scenes.Scene, out_dir: Path, quick: bool = False, workers: int = 2,
             progress: bool = True, scheduler: str | None = None, solve: bool = True) -> dict[str, Path]:
    """Validate DR against the FEM reference on ``scene`` and write ``out_dir``; returns the
    report's files. Finished runs found in ``out_dir`` are kept (resume). The runs go to the
    Dask cluster at ``scheduler`` (``tcp://host:8786``), else to a LocalCluster of ``workers``
    processes (``workers <= 1``: this process). ``solve=False`` solves nothing: the report is
    written from the states already in ``out_dir``, and names the runs that are not finished."""
    t0 = time.perf_counter()
    plan = validation_plan(quick)
    if solve:
        run_plan(plan, scene.to_dict(), out_dir, workers=workers, progress=progress, scheduler=scheduler,
                 studies=STUDIES)
    a = analyse(plan, out_dir, studies=STUDIES)
    if not solve:
        a.stale = stale_runs(plan, scene.to_dict(), out_dir)
    figs = draw(a, out_dir / "figures")
    title = f"DEMES validation: DR against the FEM reference ({scene.name}{', quick' if quick else ''})"
    files = write_report(a, out_dir, figs, title, studies=STUDIES)
    files["elapsed_s"] = time.perf_counter() - t0  # type: ignore[assignment]
    return files


def draw(a: Analysis, fig_dir: Path) -> dict[str, Path | None]:
    """The report's figures by name: the core's, then each study's."""
    figs = {
        "bending_angle": figures.bending_angle(a, fig_dir / "bending_angle.png"),
        "energy_stroke": figures.energy_stroke(a, fig_dir / "energy_stroke.png"),
        "frame_curves": figures.frame_curves(a, fig_dir / "frame_curves.png"),
        "renders": figures.renders(a, a.plan.speed_prestretch, fig_dir / "shapes.png"),
    }
    for study in STUDIES:
        if study.name in a.studies:
            figs.update(study.figures(a.studies[study.name], fig_dir))
    return figs
