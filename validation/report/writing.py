"""The validation report: report.md, a self-contained index.html, and CSV/JSON of every number.

The report is one document (:mod:`validation.common.document`) rendered as Markdown and as HTML.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from results import ENERGY_DEFINITION, atomic_write_text, level_label

from ..common.document import Section, Table, to_html, to_markdown
from ..common.tables import write_csv
from .analysis import BRANCH_JUMP, Analysis
from .beam_energy import mismatch_sentence
from .compare import METRIC_UNITS
from .study import Study
from .verdicts import COLUMNS as VERDICT_COLUMNS
from .verdicts import verdicts

HEADLINE = (
    ("prestretch", "lambda [-]", "level"),
    ("theta_fem", "theta FEM [deg]", ".2f"),
    ("theta_fem_error", "+- [deg]", ".2g"),
    ("reference_levels", "levels", "d"),
    ("theta_matched", "theta DR matched [deg]", ".2f"),
    ("shape_rms_matched", "shape RMS DR matched [/side]", ".3g"),
    ("status_matched", "DR matched", ""),
    ("theta_paper", "theta DR paper [deg]", ".2f"),
    ("shape_rms_paper", "shape RMS DR paper [/side]", ".3g"),
    ("status_paper", "DR paper", ""),
    ("time_matched", "DR matched [s]", ".2f"),
    ("time_fem_finest", "FEM finest [s]", ".2f"),
)
SLACK = (
    ("run", "run", ""),
    ("prestretch", "lambda", "level"),
    ("status", "status", ""),
    ("slack_area_fraction_any", "some family slack", ".1%"),
    ("slack_area_fraction_full", "all slack", ".1%"),
)
BRANCH = (
    ("prestretch", "lambda", "level"),
    ("level", "level", "d"),
    ("branch", "branch", ""),
    ("stable", "stable", ""),
    ("lowest_eigenvalue", "lowest eigenvalue [N/mm^3]", ".3g"),
    ("move", "move from previous level [/side]", ".3g"),
)
REFERENCE = (
    ("prestretch", "lambda", "level"),
    ("levels", "levels", ""),
    ("bending_angle", "theta [deg]", ".3f"),
    ("bending_angle_error", "+- [deg]", ".2g"),
    ("order_bending_angle", "observed order", ".2f"),
    ("apex_y", "apex y [mm]", ".3f"),
    ("apex_y_error", "+- [mm]", ".2g"),
    ("apex_z", "apex z [mm]", ".3f"),
    ("apex_z_error", "+- [mm]", ".2g"),
    ("energy_total", "energy [N mm]", ".4g"),
    ("energy_total_error", "+- [N mm]", ".2g"),
    ("shape_uncertainty", "shape +- [/side]", ".2g"),
)
LIMITS = (
    ("prestretch", "lambda", "level"),
    ("dr_levels", "DR levels", "d"),
    ("theta_dr", "DR limit theta [deg]", ".3f"),
    ("theta_dr_error", "+- [deg]", ".2g"),
    ("theta_fem", "FEM limit theta [deg]", ".3f"),
    ("theta_fem_error", "+- [deg]", ".2g"),
    ("theta_diff", "DR - FEM [deg]", ".3g"),
    ("agree", "within +-", ""),
    ("shape_distance", "limits' distance [/side]", ".2g"),
    ("shape_uncertainty_dr", "DR shape +- [/side]", ".2g"),
    ("shape_uncertainty_fem", "FEM shape +- [/side]", ".2g"),
)
LEVEL_COSTS = (
    ("level", "level", "d"),
    ("free_dofs", "free DOFs", "d"),
    ("elements", "triangles", "d"),
    ("states", "states", "d"),
    ("newton_per_state", "Newton iterations / state", ".0f"),
    ("factorisations_per_state", "factorisations / state", ".0f"),
    ("time_per_state", "time / state [s]", ".3g"),
    ("time_total", "time, all states [s]", ".3g"),
)
FIRST_CONTACT = (
    ("level", "level", ""),
    ("last_free", "last free lambda", ".4f"),
    ("first_contact", "first contact lambda", ".4f"),
    ("value", "first contact [-]", ".4f"),
    ("error", "+- [-]", ".2g"),
    ("order", "observed order", ".2f"),
)


def _findings(a: Analysis) -> list[str]:
    """The core's sentences stating the measured outcome (numbers only, no judgement beyond them)."""
    out = []
    rows = [r for r in a.headline if np.isfinite(r.get("theta_fem", np.nan))]
    if rows:
        out.append(
            f"FEM reference (strip frame, extrapolated from refinement levels {list(a.plan.reference_levels)}): "
            + ", ".join(f"{level_label(r['prestretch'])}: {r['theta_fem']:.1f} +- {r['theta_fem_error']:.2g} deg" for r in rows) + "."
        )
        m = [r for r in rows if np.isfinite(r.get("shape_rms_matched", np.nan))]
        if m:
            out.append("DR matched (triangles, strip) frame-curve RMS error / side: "
                       + ", ".join(f"{level_label(r['prestretch'])}: {r['shape_rms_matched']:.3g}" for r in m) + ".")
        p = [r for r in rows if np.isfinite(r.get("shape_rms_paper", np.nan))]
        if p:
            out.append("DR as the paper built it (clustered net, Table I isotropic frame): "
                       + ", ".join(f"{level_label(r['prestretch'])}: {r['status_paper']}" for r in rows) + ".")
    contact = [r for r in a.first_contact if r["level"] == "extrapolated"]
    if contact:
        c = contact[0]
        out.append(f"First contact (FEM levels {', '.join(c['levels'])}): lambda = {c['value']:.3f} +- {c['error']:.2g}.")
    jumps = [r for r in a.branch_rows if r["branch"] not in ("first", "same")]
    if jumps:
        out.append("Levels off the converging branch (not extrapolated): " + ", ".join(
            f"r{r['level']} at {level_label(r['prestretch'])} ({r['branch']})" for r in jumps) + ".")
    lam = a.plan.speed_prestretch
    fem_ref = a.references.get(lam)
    if a.dr_limit is not None and fem_ref is not None:
        out.append(
            f"Extrapolated limits at lambda = {lam:g}, bending angle: DR triangles "
            f"{a.dr_limit.values['bending_angle']:.3f} +- {a.dr_limit.errors['bending_angle']:.2g} deg, FEM "
            f"{fem_ref.values['bending_angle']:.3f} +- {fem_ref.errors['bending_angle']:.2g} deg "
            "(the same discrete problem refined by each solver).")
    both = [r for r in a.limits if "agree" in r]
    for observed, rows in ((True, [r for r in both if r["dr_levels"] >= 3]), (False, [r for r in both if r["dr_levels"] < 3])):
        if not rows:
            continue
        worst = max(rows, key=lambda r: abs(r["theta_diff"]))
        how = ("where DR's limit has an observed order (three levels)" if observed else
               "where DR's limit rests on two levels with the order assumed (not a bound where the coarse levels "
               "are outside the asymptotic range)")
        out.append(f"DR's and the FEM's refined limits agree within their error estimates at {sum(r['agree'] for r in rows)} "
                   f"of {len(rows)} pre-stretch levels {how}; largest difference {abs(worst['theta_diff']):.3g} deg "
                   f"at lambda = {worst['prestretch']:g}.")
    return out


def _run_notes(a: Analysis) -> list[str]:
    """Sentences on runs solved again, stale, stopped on an error or unfinished (the report's last findings)."""
    out = []
    if a.resolved:
        out.append(f"Runs solved again because the states on disk were made with another scene, settings or "
                   f"code version: {', '.join(a.resolved)}.")
    if a.stale:
        out.append(f"Runs made with another scene, settings or code version than this report's (shown as they "
                   f"are; run without --report-only to solve them again): {', '.join(a.stale)}.")
    if a.failed:
        out.append("Runs that stopped on an error (their states are left out): "
                   + "; ".join(f"{label} ({error})" for label, error in a.failed.items()) + ".")
    if a.unfinished:
        out.append(f"Runs not finished when this report was written (their missing states are left out): "
                   f"{', '.join(a.unfinished)}.")
    return out


UNITS = {**METRIC_UNITS, "wall_time": "s",
         "theta_fem": "deg", "theta_fem_error": "deg", "theta_matched": "deg", "theta_paper": "deg",
         "time_matched": "s", "time_paper": "s",
         "time_fem_finest": "s", "bending_angle_error": "deg", "apex_y_error": "mm", "apex_z_error": "mm",
         "energy_total_error": "N mm", "shape_uncertainty": "-", "time_per_state": "s", "time_total": "s",
         "theta_dr": "deg", "theta_dr_error": "deg", "theta_diff": "deg", "shape_distance": "-",
         "lowest_eigenvalue": "N/mm^3"}
"""The unit of every column of the core's tables (CSV headers, metrics.json); a study adds its own."""


@dataclass(frozen=True)
class DataTable:
    """A table of the report's numbers: written as ``<name>.csv`` and as ``metrics.json[name]``,
    its rows the :class:`Analysis` field ``rows``."""

    name: str
    rows: str


DATA_TABLES = (
    DataTable("headline", "headline"),
    DataTable("reference", "reference_rows"),
    DataTable("branches", "branch_rows"),
    DataTable("first_contact", "first_contact"),
    DataTable("reference_table", "reference_table"),
    DataTable("fem_levels", "level_costs"),
    DataTable("limits", "limits"),
    DataTable("states", "state_rows"),
)
"""The core's tables of numbers, in the order of metrics.json (the studies' follow)."""


def write_report(a: Analysis, out_dir: Path, figures: dict[str, Path | None], title: str, *,
                 studies: Sequence[Study] = ()) -> dict[str, Path]:
    """Write report.md, index.html and the CSV/JSON tables: the core's, then each study's
    (:class:`validation.report.study.Study`) tables, findings, section and verdicts; returns
    their paths."""
    reported = [(study, a.studies[study.name]) for study in studies if study.name in a.studies]
    tables = {t.name: getattr(a, t.rows) for t in DATA_TABLES}
    units = dict(UNITS)
    for study, numbers in reported:
        tables.update(study.tables(numbers))
        units.update(study.units)
    files = write_tables(tables, a.records, units, out_dir)
    findings = [*_findings(a), *(line for study, numbers in reported for line in study.findings(numbers)), *_run_notes(a)]
    sections = [Section("Findings", findings), *(build(a, figures) for build in SECTIONS),
                *(study.section(numbers, figures) for study, numbers in reported)]
    rows = verdicts(a) + [row for study, numbers in reported for row in study.verdicts(numbers)]
    table = [r._asdict() for r in rows]
    files["verdicts"] = write_csv(out_dir / "verdicts.csv", table)
    files.update(write_document([_verdict_section(table), *sections], title, out_dir))
    return files


def write_tables(tables: dict[str, list[dict[str, Any]]], records: dict[str, dict[str, Any]],
                 units: dict[str, str], out_dir: Path) -> dict[str, Path]:
    """Each table as ``<name>.csv``, and all of them (with the run records and the units) in
    metrics.json; their paths by table name, metrics.json as 'json'."""
    files = {name: write_csv(out_dir / f"{name}.csv", rows, units=units) for name, rows in tables.items()}
    everything = {**tables, "runs": records, "units": units}
    files["json"] = atomic_write_text(out_dir / "metrics.json", json.dumps(_plain(everything), indent=1))
    return files


def write_document(sections: list[Section], title: str, out_dir: Path) -> dict[str, Path]:
    """report.md and index.html of ``sections`` (figures that were not drawn left out)."""
    for sec in sections:
        sec.parts = [p for p in sec.parts if p is not None]
    return {"md": atomic_write_text(out_dir / "report.md", to_markdown(sections, title, out_dir)),
            "html": atomic_write_text(out_dir / "index.html", to_html(sections, title))}


def _verdict_section(rows: list[dict[str, str]]) -> Section:
    """One row per claim (:class:`validation.report.verdicts.Verdict` as a dict): what was measured and
    what it says; the detail follows."""
    return Section("Verdicts", ["Each claim the validation tests, what it measured and the verdict; the sections "
                                "below give the detail.", Table(VERDICT_COLUMNS, rows)])


def _shape_section(a: Analysis, figures: dict[str, Path | None]) -> Section:
    """Bending angle and shape of the DR models against the FEM reference."""
    return Section("Bending angle and shape against the FEM reference", [
        "Shape error: RMS and max distance between frame curves at equal reference arc length, divided by the side "
        "length, against the FEM state extrapolated from its refinement levels (Richardson; error estimates from the "
        "grid convergence index: with three levels the observed order and a factor 1.25, with two the formal order 2 "
        "and a factor 3). Statuses other than 'converged' are the named stops of the solver.",
        Table(HEADLINE, a.headline), figures.get("bending_angle"), figures.get("frame_curves")])


def _limits_section(a: Analysis, figures: dict[str, Path | None]) -> Section:
    """DR and the FEM refined on one discrete problem: their limits side by side."""
    return Section("One discrete problem, two limits", [
        "DR on the FEM's own discrete problem (membrane triangles, the same rod, bond and supports), refined over "
        "meshes doubling in density at its tightest tolerance and extrapolated as the FEM's levels are: if both "
        "solvers minimise the same energy, the two limits agree within their error estimates.",
        Table(LIMITS, a.limits)])


def _reference_levels_section(a: Analysis, figures: dict[str, Path | None]) -> Section:
    """The FEM reference levels: extrapolation, cost, branch check and first contact."""
    return Section("Reference levels: branches and first contact", [
        "The FEM reference per pre-stretch: values extrapolated over the levels listed (the last three give the "
        "observed order; '-' where it was outside 0.5-4 and the formal order 2 was used), each with its error "
        "estimate.", Table(REFERENCE, a.reference_table),
        "What each level costs along the sweep (medians over its converged states, each started from the "
        "previous one; a state's time includes the coarser levels that lead Newton to it; factorisations: sparse "
        "Cholesky on the level's own mesh, one per Newton iteration plus one per shift tried where the tangent is "
        "not positive definite and those of the path tangent and the stability check).", Table(LEVEL_COSTS, a.level_costs),
        "Each FEM level follows the path of the coarsest (its states start Newton from the coarse state) and is "
        "checked: stable (lowest eigenvalue of the tangent above zero) and converging (the frame curve moves less "
        f"from the previous level than that one moved, within a factor {BRANCH_JUMP:g}). A level that jumped branch "
        "or is unstable is listed here and left out of the extrapolation.", Table(BRANCH, a.branch_rows),
        "First frame-frame or frame-film contact: the bracket each level's path found (bisection to 1e-3 in "
        "pre-stretch) and the value extrapolated over the levels (Richardson), its error estimate plus half the "
        "finest bracket.", Table(FIRST_CONTACT, a.first_contact)])


def _energy_section(a: Analysis, figures: dict[str, Path | None]) -> Section:
    """Energies against stroke."""
    return Section("Energy against stroke", [
        ENERGY_DEFINITION, mismatch_sentence(),
        "Strain energy split into membrane and frame, against the stroke from the most bent state; dotted: the "
        "membrane part by the paper's formula.", figures.get("energy_stroke")])


def _tension_field_section(a: Analysis, figures: dict[str, Path | None]) -> Section:
    """Slack film area per state."""
    return Section("Tension field", [
        "Flat membrane area with at least one slack link family (a tension field: the film would wrinkle) and with "
        "every family slack, per state.",
        Table(SLACK, [r for r in a.state_rows if r.get("group") in ("sweep", "reference")])])


def _shapes_section(a: Analysis, figures: dict[str, Path | None]) -> Section:
    """Renders of the states."""
    return Section("Shapes", [
        "DR and FEM states rendered top, side and perspective (the paper's Fig. 3 views); ParaView series: "
        "runs/<run>/<run>.pvd.", figures.get("renders")])


SECTIONS: tuple[Callable[[Analysis, dict[str, Path | None]], Section], ...] = (
    _shape_section, _limits_section, _reference_levels_section, _energy_section, _tension_field_section,
    _shapes_section,
)
"""The core's sections of the report after its findings, in order; the studies' follow."""


def _plain(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    if isinstance(obj, (np.floating, float)):
        return None if not np.isfinite(obj) else float(obj)
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    return obj


__all__ = ["write_report"]
