"""From the runs on disk to the report's core numbers: headline, state metrics, the FEM reference
levels and branches, first contact, DR's and the FEM's refined limits; then each study's numbers
(:class:`validation.report.study.Study`). Everything here reads stored states; nothing is solved."""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import takewhile
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from fem_reference import richardson
from results import Result

from .compare import CURVE_SAMPLES, Reference, build_reference, curve_distance, state_metrics
from .plan import Plan, Run
from .runner import load_states, run_record
from .study import Study

STATE_GROUPS = ("sweep", "reference", "drconv")
"""The core's groups of runs whose states are rows of the states table."""


@dataclass
class Analysis:
    """All numbers of a validation report (rows are dicts; units in validation.report.compare)."""

    plan: Plan
    states: dict[str, dict[float, Result]]
    records: dict[str, dict[str, Any]]
    references: dict[float, Reference]
    dr_limits: dict[float, Reference]  # DR's own refined limit per pre-stretch (the drconv runs)
    state_rows: list[dict[str, Any]] = field(default_factory=list)
    headline: list[dict[str, Any]] = field(default_factory=list)
    reference_rows: list[dict[str, Any]] = field(default_factory=list)
    branch_rows: list[dict[str, Any]] = field(default_factory=list)
    first_contact: list[dict[str, Any]] = field(default_factory=list)
    reference_table: list[dict[str, Any]] = field(default_factory=list)
    level_costs: list[dict[str, Any]] = field(default_factory=list)
    limits: list[dict[str, Any]] = field(default_factory=list)  # DR's and the FEM's limits side by side
    studies: dict[str, Any] = field(default_factory=dict)  # each study's numbers by its name (validation.report.study)
    stale: list[str] = field(default_factory=list)  # complete runs made with another scene, settings or code

    @property
    def finest_fem(self) -> dict[float, tuple[int, Result]]:
        """Per pre-stretch, (level, state) of the finest FEM reference level that solved it
        (the finest level runs at fewer pre-stretches than the others)."""
        finest: dict[float, tuple[int, Result]] = {}
        for k in self.plan.reference_levels:
            finest.update((lam, (k, r)) for lam, r in self.states[f"fem_r{k}"].items())
        return finest

    @property
    def dr_limit(self) -> Reference | None:
        """DR's refined limit at the speed study's pre-stretch."""
        return self.dr_limits.get(self.plan.speed_prestretch)

    @property
    def resolved(self) -> list[str]:
        """Runs solved again because the ones on disk were made with another scene, settings or code."""
        return [r.label for r in self.plan.runs if self.records.get(r.label, {}).get("resolved")]

    @property
    def failed(self) -> dict[str, str]:
        """Runs of the plan that stopped on an error (a scene the solver refuses, say), with the error."""
        return {r.label: self.records[r.label]["error"] for r in self.plan.runs
                if self.records.get(r.label, {}).get("error")}

    @property
    def unfinished(self) -> list[str]:
        """Runs of the plan without a complete record and without an error (interrupted, or never started)."""
        failed = self.failed
        return [r.label for r in self.plan.runs
                if not self.records.get(r.label, {}).get("complete") and r.label not in failed]


def analyse(plan: Plan, out_dir: Path, *, studies: Sequence[Study] = ()) -> Analysis:
    """Read every run of ``plan`` from ``out_dir`` and compute the report's tables, and each
    study's numbers (:class:`validation.report.study.Study`; a study with nothing to report is left out)."""
    states = {r.label: load_states(out_dir / "runs" / r.label, r.prestretches) for r in plan.runs if not r.voltages}
    records = {r.label: run_record(out_dir / "runs" / r.label) or {} for r in plan.runs}
    references, branch_rows = fem_references(plan, states)
    dr_limits = dr_references(plan, states)
    a = Analysis(plan, states, records, references, dr_limits, branch_rows=branch_rows)
    a.first_contact = first_contact(plan, states)
    _state_rows(a, STATE_GROUPS + tuple(g for study in studies for g in study.state_groups))
    _headline(a)
    _reference_rows(a)
    _level_costs(a)
    _limits(a)
    for study in studies:
        numbers = study.analyse(a, out_dir)
        if numbers is not None:
            a.studies[study.name] = numbers
    return a


def fem_references(plan: Plan, states: dict[str, dict[float, Result]]
                   ) -> tuple[dict[float, Reference], list[dict[str, Any]]]:
    """The FEM reference per pre-stretch, extrapolated over the levels on one branch, and the
    branch check of every level (:func:`branch_check`)."""
    references = {}
    branch_rows = []
    for lam in plan.sweep:
        rows = branch_check([states[f"fem_r{k}"].get(lam) for k in plan.reference_levels], plan.reference_levels)
        branch_rows += rows
        # the consecutive levels from the coarsest on the branch the coarser ones are on: a level
        # that jumped is reported (branch table), not extrapolated with the others
        on_branch = takewhile(lambda r: r["branch"] in ("first", "same"), rows)
        levels = [states[f"fem_r{r['level']}"][lam] for r in on_branch]
        ref = build_reference(plan.reference_levels, levels)
        if ref is not None:
            references[lam] = ref
    return references, branch_rows


def dr_references(plan: Plan, states: dict[str, dict[float, Result]]) -> dict[float, Reference]:
    """DR's own refined limit per pre-stretch: the matched model on meshes doubling in density
    at its tightest tolerance (the drconv runs), extrapolated as the FEM's levels are."""
    drconv = plan.by_group("drconv")
    dr_limits = {}
    for lam in plan.sweep:
        # the levels that ran at this pre-stretch, coarsest first (the finest runs at fewer)
        dr_states = list(takewhile(lambda r: r is not None, (states[r.label].get(lam) for r in drconv)))
        dr_ref = build_reference(tuple(range(len(dr_states))), dr_states)
        if dr_ref is not None:
            dr_limits[lam] = dr_ref
    return dr_limits


def _row(a: Analysis, run: Run, lam: float, res: Result) -> dict[str, Any]:
    row = {"run": run.label, "group": run.group, "title": run.title}
    row.update(state_metrics(res, a.references.get(lam)))
    row["peak_memory"] = a.records.get(run.label, {}).get("peak_memory_mb", float("nan"))
    return row


def _state_rows(a: Analysis, groups: tuple[str, ...]) -> None:
    for run in a.plan.runs:
        if run.group in groups:
            for lam, res in sorted(a.states[run.label].items()):
                a.state_rows.append(_row(a, run, lam, res))


def _headline(a: Analysis) -> None:
    """Per pre-stretch: bending angle of each model and the DR shape errors."""
    for lam in a.plan.sweep:
        row: dict[str, Any] = {"prestretch": lam}
        ref = a.references.get(lam)
        row["theta_fem"] = ref.values["bending_angle"] if ref else np.nan
        row["theta_fem_error"] = ref.errors["bending_angle"] if ref else np.nan
        row["shape_fem_uncertainty"] = ref.shape_uncertainty if ref else np.nan
        for label, key in (("dr_paper", "paper"), ("dr_matched", "matched")):
            res = a.states[label].get(lam)
            if res is None:
                row[f"theta_{key}"], row[f"status_{key}"] = np.nan, "not reached"
                continue
            m = state_metrics(res, ref)
            row[f"theta_{key}"] = m["bending_angle"]
            row[f"status_{key}"] = m["status"]
            row[f"shape_rms_{key}"] = m.get("shape_rms", np.nan)
            row[f"shape_max_{key}"] = m.get("shape_max", np.nan)
            row[f"time_{key}"] = m["wall_time"]
        row["reference_levels"] = len(ref.levels) if ref else 0
        fem_fine = a.states[f"fem_r{ref.levels[-1]}"].get(lam) if ref else None
        row["time_fem_finest"] = fem_fine.wall_time if fem_fine else np.nan
        a.headline.append(row)


REFERENCE_QUANTITIES = ("bending_angle", "apex_y", "apex_z", "energy_total")
"""The scalars of the reference table (with their error estimates)."""

ANGLE_ROUND_OFF = 1e-9
"""deg: two limits' bending angles this close are equal whatever their error estimates (at the
flat state both are zero to round-off, with estimates of 1e-19 deg or exactly 0)."""


def _reference_rows(a: Analysis) -> None:
    """The reference per pre-stretch: values per level, observed order, extrapolation, error;
    and one row per pre-stretch of the extrapolated values with their errors."""
    for lam, ref in sorted(a.references.items()):
        row: dict[str, Any] = {"prestretch": lam, "levels": "-".join(f"r{k}" for k in ref.levels),
                               "order_bending_angle": ref.orders["bending_angle"],
                               "shape_uncertainty": ref.shape_uncertainty}
        for q in REFERENCE_QUANTITIES:
            row[q], row[f"{q}_error"] = ref.values[q], ref.errors[q]
        a.reference_table.append(row)
        for q, values in ref.level_values.items():
            a.reference_rows.append({"prestretch": lam, "quantity": q, **{f"r{k}": v for k, v in zip(ref.levels, values)},
                                     "order": ref.orders[q], "extrapolated": ref.values[q], "error": ref.errors[q]})


def _limits(a: Analysis) -> None:
    """Per pre-stretch, DR's refined limit (the matched model on doubling meshes) beside the
    FEM's: one discrete problem refined by two solvers. 'agree' when the bending angles differ
    by less than the sum of their error estimates; ``dr_levels`` says whether DR's estimate has
    an observed order (three levels) or an assumed one (two)."""
    for lam in a.plan.sweep:
        dr_ref = a.dr_limits.get(lam)
        fem_ref = a.references.get(lam)
        if dr_ref is None and fem_ref is None:
            continue
        row: dict[str, Any] = {"prestretch": lam}
        for key, ref in (("dr", dr_ref), ("fem", fem_ref)):
            row[f"theta_{key}"] = ref.values["bending_angle"] if ref else np.nan
            row[f"theta_{key}_error"] = ref.errors["bending_angle"] if ref else np.nan
            row[f"shape_uncertainty_{key}"] = ref.shape_uncertainty if ref else np.nan
        row["dr_levels"] = len(dr_ref.levels) if dr_ref else 0
        if dr_ref is not None and fem_ref is not None:
            row["theta_diff"] = row["theta_dr"] - row["theta_fem"]
            row["shape_distance"] = curve_distance(dr_ref, fem_ref)
            band = row["theta_dr_error"] + row["theta_fem_error"] + ANGLE_ROUND_OFF
            row["agree"] = bool(abs(row["theta_diff"]) <= band)
        a.limits.append(row)


def _level_costs(a: Analysis) -> None:
    """What each FEM reference level costs: unknowns, Newton iterations, factorisations and wall
    time per state (medians over its converged states along the sweep; a state's time includes
    the coarser levels that lead Newton to it)."""
    for k in a.plan.reference_levels:
        done = [r for r in a.states[f"fem_r{k}"].values() if r.converged and r.prestretch > 1.0]
        if not done:
            continue
        a.level_costs.append({
            "level": k, "free_dofs": done[0].info.get("n_free_dofs", np.nan),
            "elements": done[0].info.get("n_elements", np.nan), "states": len(done),
            "newton_per_state": float(np.median([r.iterations for r in done])),
            "factorisations_per_state": float(np.median([r.info.get("factorisations", np.nan) for r in done])),
            "time_per_state": float(np.median([r.wall_time for r in done])),
            "time_total": float(sum(r.wall_time for r in done)),
        })


BRANCH_JUMP = 1.5
"""A level whose frame curve moved more from the previous level than that one did from its own
previous level, by this factor, is off the converging sequence: a branch jump (or a level outside
the asymptotic range), reported and not extrapolated."""


def branch_check(states: list[Result | None], levels: tuple[int, ...]) -> list[dict[str, Any]]:
    """Per level (coarse to fine, one pre-stretch): stability, lowest eigenvalue and the frame
    curve's largest move from the previous level (/ side); 'branch' is 'first', 'same', 'jump',
    'unstable' or 'not converged'. Levels after a missing state are left out."""
    rows: list[dict[str, Any]] = []
    previous_curve, previous_move = None, None
    for k, res in zip(levels, states):
        if res is None:
            break
        row = {"prestretch": res.prestretch, "level": k, "stable": bool(res.info.get("stable", False)),
               "lowest_eigenvalue": res.info.get("lowest_eigenvalue_N_per_mm3", np.nan), "move": np.nan}
        if not res.converged:
            row["branch"] = "not converged"
        elif res.prestretch > 1.0 and not row["stable"]:
            row["branch"] = "unstable"
        else:
            curve = res.frame_curve(CURVE_SAMPLES)
            if previous_curve is not None:
                row["move"] = float(np.linalg.norm(curve - previous_curve, axis=1).max() / res.scene.outline.side_length)
            jumped = previous_move is not None and row["move"] > BRANCH_JUMP * previous_move + 1e-9
            row["branch"] = "first" if previous_curve is None else ("jump" if jumped else "same")
            previous_curve, previous_move = curve, row["move"] if np.isfinite(row["move"]) else None
        rows.append(row)
    return rows


def first_contact(plan: Plan, states: dict[str, dict[float, Result]]) -> list[dict[str, Any]]:
    """First frame-frame or frame-film contact per FEM level (the bracket its path found) and its
    refined value: Richardson over the levels that found one (observed order with three), the
    error estimate plus half the finest bracket."""
    rows = []
    for k in plan.reference_levels:
        brackets = [r.info["first_contact_prestretch"] for r in states[f"fem_r{k}"].values()
                    if "first_contact_prestretch" in r.info]
        if brackets:
            free, hit = brackets[0]
            rows.append({"level": f"r{k}", "last_free": free, "first_contact": hit, "value": 0.5 * (free + hit),
                         "error": 0.5 * (hit - free), "order": np.nan})
    if len(rows) >= 2:
        est = richardson([r["value"] for r in rows])
        rows.append({"level": "extrapolated", "value": est.extrapolated, "error": est.error + rows[-1]["error"],
                     "order": est.order, "levels": [r["level"] for r in rows]})
    return rows
