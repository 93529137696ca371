"""How a study plugs into ``demes validate``: one record of hooks, one per stage.

The validation's own comparisons are built into :mod:`validation.report.plan`,
:mod:`validation.report.analysis` and :mod:`validation.report.writing`. A study beside them (the voltage runs
against the experiment, :mod:`validation.report.studies.experiment`) owns one group of runs and gives each stage
a hook; :mod:`validation.report.validate` lists the studies and hands them to every stage, so no stage
imports a study.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

from results import Result
from scenes import Scene

from ..common.document import Section
from .plan import Plan, Run


@dataclass(frozen=True)
class Study:
    """A study's hooks into the plan, the runner, the analysis and the report.

    Attributes
    ----------
    name
        Key of its numbers in :attr:`validation.report.analysis.Analysis.studies`.
    group
        The group of its runs in the plan: the runner hands these runs to ``execute``.
    runs
        ``runs(coarse=, quick=)``: its runs, given the plan's coarse-mesh changes and mode.
    execute
        ``execute(run, scene, run_dir)``: solve one of its runs into ``run_dir``; its states by key.
    analyse
        ``analyse(plan, out_dir)``: its numbers from the states on disk (None: nothing to report).
    figures
        ``figures(numbers, fig_dir)``: its figures by name.
    tables
        ``tables(numbers, out_dir)``: its CSV files by name.
    section
        ``section(numbers, figures)``: its section of the report (``figures``: all of them by name).
    verdicts
        ``verdicts(numbers)``: its rows of the report's verdict table
        (:class:`validation.report.verdicts.Verdict`).
    """

    name: str
    group: str
    runs: Callable[..., list[Run]]
    execute: Callable[[Run, Scene, Path], dict[float, Result]]
    analyse: Callable[[Plan, Path], Any]
    figures: Callable[[Any, Path], dict[str, Path]]
    tables: Callable[[Any, Path], dict[str, Path]]
    section: Callable[[Any, dict[str, Path | None]], Section]
    verdicts: Callable[[Any], list[Any]]
