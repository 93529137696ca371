"""How a study plugs into ``demes validate``: one module, one record of hooks, one registry line.

The validation's core (:mod:`validation.report.plan`, :mod:`validation.report.analysis` and
:mod:`validation.report.writing`) compares DR with the FEM reference along the main sweep: the
states, the reference levels, DR's own refinement and the two limits. Every other study (speed
against error, the error budget, second states, hard cases, the experiment) is a module under
:mod:`validation.report.studies` that builds one :class:`Study`;
:data:`validation.report.validate.STUDIES` lists them and hands them to every stage, so no stage
imports a study.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping

from results import Result
from scenes import Scene

from ..common.document import Section
from .plan import Run, Settings


def _none(*_: Any) -> dict:
    return {}


def _nothing(*_: Any) -> list:
    return []


@dataclass(frozen=True)
class Study:
    """A study's hooks into the plan, the runner, the analysis and the report.

    Attributes
    ----------
    name
        Key of its numbers in :attr:`validation.report.analysis.Analysis.studies`.
    runs
        ``runs(settings)``: its runs, given the plan's :class:`validation.report.plan.Settings`.
    analyse
        ``analyse(a, out_dir)``: its numbers from the core analysis ``a`` (every run's states,
        the references, DR's limits) and the files in ``out_dir``; None: nothing to report.
    section
        ``section(numbers, figures)``: its section of the report (``figures``: all by name).
    tables
        ``tables(numbers)``: its tables of numbers by name, rows as dicts; each is written as
        ``<name>.csv`` and into metrics.json.
    units
        The unit of each of its tables' columns that the shared metrics do not name.
    figures
        ``figures(numbers, fig_dir)``: its figures by name.
    findings
        ``findings(numbers)``: its sentences in the report's Findings.
    verdicts
        ``verdicts(numbers)``: its rows of the verdict table (:class:`validation.report.verdicts.Verdict`).
    state_groups
        Groups of its runs whose states are rows of the states table beside the core's.
    group, execute
        A study whose runs are not plain solver runs (voltages, a fit first) names their group and
        ``execute(run, scene, run_dir)``, which solves one into ``run_dir`` and returns its states
        by key; any other run is solved by the runner.
    """

    name: str
    runs: Callable[[Settings], list[Run]]
    analyse: Callable[[Any, Path], Any]
    section: Callable[[Any, dict[str, Path | None]], Section]
    tables: Callable[[Any], dict[str, list[dict[str, Any]]]] = _none
    units: Mapping[str, str] = field(default_factory=dict)
    figures: Callable[[Any, Path], dict[str, Path | None]] = _none
    findings: Callable[[Any], list[str]] = _nothing
    verdicts: Callable[[Any], list[Any]] = _nothing
    state_groups: tuple[str, ...] = ()
    group: str = ""
    execute: Callable[[Run, Scene, Path], dict[float, Result]] | None = None
