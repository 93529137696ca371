"""Speed against error: each solver's wall time against its shape error at one pre-stretch.

DR (the matched model) over mesh density, tolerance and graded meshes, the FEM over refinement
levels and graded meshes, each state solved from the flat state; the time each needs to reach a
shape error (:data:`THRESHOLDS`) tests the paper's low-cost claim.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ...common.document import Section, Table
from ...common.plotting import label_axes, plt, save_figure
from ..compare import state_metrics
from ..plan import MATCHED, Run, Settings
from ..study import Study
from ..verdicts import Verdict, held

GROUP = "speed"

THRESHOLDS = (0.01, 0.001)
"""Shape errors (fraction of the side length) of the 'time to reach' table: 1 % and 0.1 %."""

GRADED_DR = ((20, 2.0, 0), (14, 2.0, 1), (28, 4.0, 0), (14, 4.0, 1), (20, 4.0, 1))
"""DR's graded meshes (divisions, mesh.grading, fem.refinement): the P1 shape error at 130 %
lives at the frame, so grading towards it buys the most per unknown (docs/discrete-problem.md,
"Graded meshes")."""

GRADED_FEM = (("P1", 20, 2.0, 0), ("P2", 14, 2.0, 0), ("P1", 14, 4.0, 1), ("P2", 14, 4.0, 0), ("P2", 14, 4.0, 1))
"""The FEM's graded meshes (element, divisions, mesh.grading, refinement): P1 too, which on a
graded mesh reaches 0.1 % sooner than P2 (measured)."""

QUICK_GRADED_DR, QUICK_GRADED_FEM = ((6, 2.0, 0),), (("P1", 6, 2.0, 0),)
"""The quick plan's graded meshes: one of each solver, on one mesh."""


def speed_label(divisions: int, tolerance: float) -> str:
    """The label of DR's uniform-mesh run at ``divisions`` and ``tolerance``."""
    return f"speed_dr_n{divisions}_tol{tolerance:.0e}"


def runs(s: Settings) -> list[Run]:
    """DR over mesh density and tolerance, uniform and graded; the FEM over its levels up to r2
    (r3 would add minutes for one point) and graded. Each state from the flat state."""
    lam = (s.speed_lam,)
    graded_dr = QUICK_GRADED_DR if s.quick else GRADED_DR
    graded_fem = QUICK_GRADED_FEM if s.quick else GRADED_FEM
    graded_tols = (s.tight,) if s.quick else (1e-5, 1e-6, 1e-7)
    uniform = [Run(speed_label(n, tol), "dr", {**MATCHED, "mesh.divisions": n, "dr.tolerance": tol}, lam,
                   group=GROUP, title=f"DR matched, {n} divisions, tol {tol:.0e}", cold=True)
               for n in s.dr_meshes for tol in s.dr_tols]
    graded = [Run(f"speed_dr_n{n}_g{g:g}{f'_r{k}' if k else ''}_tol{tol:.0e}", "dr",
                  {**MATCHED, "mesh.divisions": n, "mesh.grading": g, "fem.refinement": k, "dr.tolerance": tol},
                  lam, group=GROUP, cold=True,
                  title=f"DR matched, {n} divisions graded {g:g}{f', refinement {k}' if k else ''}, tol {tol:.0e}")
              for n, g, k in graded_dr for tol in graded_tols]
    fem = [Run(f"speed_fem_r{k}", "fem", s.fem_study, lam, refinement=k, group=GROUP,
               title=f"FEM, {s.element}, refinement {k}", cold=True) for k in s.levels[:3]]
    fem_graded = [Run(f"speed_fem_{el}_n{n}_g{g:g}_r{k}", "fem",
                      {**s.fem_study, "fem.element": el, "mesh.divisions": n, "mesh.grading": g},
                      lam, refinement=k, group=GROUP, cold=True,
                      title=f"FEM, {el}, {n} divisions graded {g:g}, refinement {k}")
                  for el, n, g, k in graded_fem]
    return [*uniform, *graded, *fem, *fem_graded]


@dataclass
class Speed:
    """The study's numbers: one row per run, and per threshold the fastest time of each solver."""

    prestretch: float
    rows: list[dict[str, Any]] = field(default_factory=list)
    reach: list[dict[str, Any]] = field(default_factory=list)


def analyse(a: Any, out_dir: Path) -> Speed | None:
    """Each run's time and shape error against the FEM reference (:class:`validation.report.
    analysis.Analysis` ``a``), and the time each solver needs to reach each threshold."""
    plan = a.plan
    if not plan.by_group(GROUP):
        return None
    lam = plan.speed_prestretch
    ref = a.references.get(lam)
    speed = Speed(lam)
    for run in plan.by_group(GROUP):
        res = a.states[run.label].get(lam)
        if res is None:
            continue
        m = state_metrics(res, ref)
        speed.rows.append({
            "run": run.label, "method": run.solver, "title": run.title,
            "mesh": run.changes.get("mesh.divisions", np.nan), "grading": run.changes.get("mesh.grading", 1.0),
            "tolerance": run.changes.get("dr.tolerance", np.nan),
            "refinement": run.refinement if run.solver == "fem" else run.changes.get("fem.refinement", np.nan),
            "free_dofs": res.info.get("n_free_dofs", np.nan),
            "wall_time": res.wall_time, "iterations": res.iterations, "status": res.status,
            "shape_rms": m.get("shape_rms", np.nan), "bending_angle_diff": m.get("bending_angle_diff", np.nan),
            "peak_memory": a.records.get(run.label, {}).get("peak_memory_mb", np.nan),
        })
    for threshold in THRESHOLDS:
        row: dict[str, Any] = {"shape_error": threshold}
        for method in ("dr", "fem"):
            ok = [r["wall_time"] for r in speed.rows
                  if r["method"] == method and r["status"] == "converged" and r["shape_rms"] <= threshold]
            row[f"time_{method}"] = min(ok) if ok else np.nan
        row["ratio_fem_over_dr"] = row["time_fem"] / row["time_dr"]
        speed.reach.append(row)
    return speed


def pareto(speed: Speed, fig_dir: Path) -> dict[str, Path | None]:
    """Wall time against shape error (to the FEM reference) for every run."""
    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    for method, st in (("dr", dict(color="tab:blue", marker="o")), ("fem", dict(color="k", marker="D"))):
        rows = [r for r in speed.rows if r["method"] == method and np.isfinite(r["shape_rms"])]
        if rows:
            ax.loglog([r["shape_rms"] for r in rows], [r["wall_time"] for r in rows], st["marker"], color=st["color"],
                      ls="none", label="DR matched (mesh x tolerance)" if method == "dr" else "FEM (refinement levels)")
            for r in rows:
                tag = f"n{int(r['mesh'])}, {r['tolerance']:.0e}" if method == "dr" else f"r{int(r['refinement'])}"
                if r.get("grading", 1.0) != 1.0:
                    tag = (f"n{int(r['mesh'])} g{r['grading']:g}" + (f" r{int(r['refinement'])}" if r["refinement"] else "")
                           + (f", {r['tolerance']:.0e}" if method == "dr" else ""))
                ax.annotate(tag, (r["shape_rms"], r["wall_time"]), fontsize=6, xytext=(3, 2), textcoords="offset points")
    for t in THRESHOLDS:
        ax.axvline(t, color="0.6", ls="--", lw=0.8)
    ax.set_title(f"Speed against error at lambda {speed.prestretch:g}")
    label_axes(ax, "frame-curve RMS error / side (to the extrapolated FEM reference)", "wall time [s]")
    return {"pareto": save_figure(fig, fig_dir / "pareto.png")}


def tables(speed: Speed) -> dict[str, list[dict[str, Any]]]:
    return {"speed": speed.rows, "time_to_error": speed.reach}


def findings(speed: Speed) -> list[str]:
    """The time each solver needs for each shape error, or who did not reach it."""
    out = []
    for r in speed.reach:
        if np.isfinite(r["ratio_fem_over_dr"]):
            out.append(f"Time to reach {r['shape_error']:.1%} shape error: DR {r['time_dr']:.3g} s, FEM {r['time_fem']:.3g} s, "
                       f"ratio FEM/DR {r['ratio_fem_over_dr']:.3g}.")
        else:
            which = [m.upper() for m in ("dr", "fem") if not np.isfinite(r[f"time_{m}"])]
            out.append(f"{r['shape_error']:.1%} shape error is not reached by {' and '.join(which)} in this study.")
    return out


ROWS = (
    ("title", "run", ""),
    ("status", "status", ""),
    ("free_dofs", "free DOFs", ".0f"),
    ("wall_time", "time [s]", ".3g"),
    ("iterations", "iterations", "d"),
    ("shape_rms", "shape RMS [/side]", ".3g"),
    ("bending_angle_diff", "d theta [deg]", ".3g"),
    ("peak_memory", "peak memory [MB]", ".0f"),
)
REACH = (
    ("shape_error", "shape error [/side]", ".2%"),
    ("time_dr", "DR [s]", ".3g"),
    ("time_fem", "FEM [s]", ".3g"),
    ("ratio_fem_over_dr", "FEM / DR time", ".3g"),
)


def section(speed: Speed, figures: dict[str, Path | None]) -> Section:
    return Section(f"Speed against error (lambda = {speed.prestretch:g})", [
        "Each state solved from scratch; DR over mesh density and tolerance, the FEM over refinement levels "
        "(continuation from the flat state included in its time); 'graded g' rows on meshes graded towards the "
        "frame (mesh.grading: element size h0 / g at the outline), where the shape error lives.",
        Table(ROWS, speed.rows), Table(REACH, speed.reach), figures.get("pareto")])


def verdicts(speed: Speed) -> list[Verdict]:
    """The paper's claim: DR reaches a shape accuracy in less time than the FEM."""
    claim = "DR is cheaper than the FEM for the same shape accuracy (the paper's low-cost claim)"
    rows = [r for r in speed.reach if np.isfinite(r["ratio_fem_over_dr"])]
    missing = [f"{r['shape_error']:.1%}" for r in speed.reach if not np.isfinite(r["ratio_fem_over_dr"])]
    if not rows:
        return [Verdict(claim, "; ".join(f"{m} not reached" for m in missing) or "no speed runs", "not measured")]
    measured = "; ".join(f"{r['shape_error']:.1%} shape error: DR {r['time_dr']:.3g} s, FEM {r['time_fem']:.3g} s "
                         f"(FEM/DR {r['ratio_fem_over_dr']:.3g})" for r in rows)
    if missing:
        measured += f"; {', '.join(missing)} not reached by one of them"
    return [Verdict(claim, measured, held(sum(r["ratio_fem_over_dr"] > 1.0 for r in rows), len(rows), "accuracies"))]


STUDY = Study(name="speed", runs=runs, analyse=analyse, section=section, tables=tables,
              units={"shape_error": "-", "time_dr": "s", "time_fem": "s", "wall_time": "s"},
              figures=pareto, findings=findings, verdicts=verdicts)
"""Speed against error, as ``demes validate`` plugs it in."""
