"""The scene's own mesh beside a coarsened plan's: does the coarse mesh reach the scene's states?

The quick plan solves every run on a coarse mesh (:func:`validation.report.plan.settings`), a
discrete problem other than the one ``demes solve`` and ``dr.sweep`` solve on the scene's own
``mesh.divisions``. Where the path bifurcates, the two meshes can take different branches (a
40 x 60 mm rectangle reaches 78 deg at 1.3 on 8 divisions and 136 deg on 14, whatever the steps
taken). So the FEM reference's element solves the sweep once more on the scene's own mesh, and
each of its states is set beside the coarse reference: it is the same state when its frame is
no farther from the coarse reference's extrapolated frame than the coarse levels themselves
are, plus the reference's own error estimate. The full plan runs on the scene's own mesh and
has nothing to compare.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from results import level_label

from ...common.document import Section, Table
from ..compare import CURVE_SAMPLES, frame_distance
from ..plan import REFERENCE, Run, Settings
from ..study import Study
from ..verdicts import Verdict

GROUP = "scene_mesh"
LABEL = "fem_scene_mesh"

ROUND_OFF = 1e-9
"""/side: frames this close are one state whatever the estimates (the flat state's are 0 on both meshes)."""


def runs(s: Settings) -> list[Run]:
    """The reference's element on the scene's own mesh over the sweep, where the plan coarsens it."""
    if not s.coarse:
        return []
    return [Run(LABEL, "fem", {**REFERENCE, "fem.element": s.element}, s.sweep, group=GROUP,
                title=f"FEM reference, strip frame, {s.element}, the scene's own mesh")]


def _twins(curve: np.ndarray) -> dict[str, np.ndarray]:
    """The frame curve's images of equal energy on a scene symmetric in its plane and about the
    y axis: through the flat plane (z -> -z) and left-right (x -> -x; the arc length from the
    base midpoint runs the other way). On an outline that is not symmetric about the y axis the
    left-right image lies off the outline, so it is never near another state."""
    turned = np.roll(curve[::-1], 1, axis=0)  # the sample at arc length -s
    return {"mirror image through the flat plane": curve * np.array([1.0, 1.0, -1.0]),
            "left-right mirror image": turned * np.array([-1.0, 1.0, 1.0])}


def analyse(a: Any, out_dir: Path) -> list[dict[str, Any]] | None:
    """Per pre-stretch (``a``: :class:`validation.report.analysis.Analysis`): the state on the
    scene's mesh, the coarse reference, their frames' distance, whether it is one state, and
    if not, whether it is one of the coarse state's mirror images."""
    if not a.plan.by_group(GROUP):
        return None
    rows = []
    for lam in a.plan.sweep:
        found = a.states[LABEL].get(lam)
        ref = a.references.get(lam)
        row: dict[str, Any] = {"prestretch": lam, "status": found.status if found else "not reached",
                               "theta_coarse": ref.values["bending_angle"] if ref else np.nan,
                               "theta_coarse_error": ref.errors["bending_angle"] if ref else np.nan}
        if found is not None and found.converged:
            row.update(theta_scene_mesh=found.bending_angle, branch=found.info.get("branch", ""),
                       divisions=found.scene.mesh.divisions)
        if ref is not None and found is not None and found.converged:
            spread = max(frame_distance(a.states[f"fem_r{k}"][lam].frame_curve(CURVE_SAMPLES), ref) for k in ref.levels)
            curve = found.frame_curve(CURVE_SAMPLES)
            row.update(distance=frame_distance(curve, ref), allowed=spread + ref.shape_uncertainty + ROUND_OFF)
            row["same_state"] = bool(row["distance"] <= row["allowed"])
            if not row["same_state"]:
                row["relation"] = next((name for name, twin in _twins(curve).items()
                                        if frame_distance(twin, ref) <= row["allowed"]), "another state")
        rows.append(row)
    return rows


def tables(rows: list[dict[str, Any]]) -> dict[str, list[dict[str, Any]]]:
    return {"scene_mesh": rows}


def _named(row: dict[str, Any]) -> str:
    relation = row["relation"]
    return "another state" if relation == "another state" else f"the coarse state's {relation}"


def _others(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [r for r in rows if r.get("same_state") is False]


def findings(rows: list[dict[str, Any]]) -> list[str]:
    others = _others(rows)
    if not others:
        compared = [r for r in rows if "same_state" in r]
        return [f"On the scene's own mesh the FEM reaches the coarse mesh's state at {len(compared)} of "
                f"{len(rows)} pre-stretch levels."] if compared else []
    return ["On the scene's own mesh the FEM reaches another state than this report's coarse mesh: " + "; ".join(
        f"{level_label(r['prestretch'])}: {r['theta_scene_mesh']:.2f} deg ({r['divisions']} divisions) against "
        f"{r['theta_coarse']:.2f} +- {r['theta_coarse_error']:.2g}, {_named(r)}" for r in others)
        + ". The path bifurcates, and the coarse mesh takes another branch: this report's states there are not "
          "the ones `demes solve` gives; the full plan runs on the scene's own mesh. A mirror image is a state of "
          "the same energy on the other side of a symmetry-breaking bifurcation."]


COLUMNS = (
    ("prestretch", "lambda", "level"),
    ("theta_coarse", "coarse reference: theta [deg]", ".2f"),
    ("theta_coarse_error", "+- [deg]", ".2g"),
    ("divisions", "scene's mesh.divisions", ""),
    ("theta_scene_mesh", "scene's mesh: theta [deg]", ".2f"),
    ("branch", "branch", ""),
    ("status", "status", ""),
    ("distance", "frame distance [/side]", ".3g"),
    ("allowed", "coarse levels' spread + estimate [/side]", ".3g"),
    ("same_state", "same state", ""),
    ("relation", "else", ""),
)


def section(rows: list[dict[str, Any]], figures: dict[str, Path | None]) -> Section:
    return Section("The scene's own mesh", [
        "This plan solves on a coarse mesh. The FEM reference's element solves the same sweep on the scene's own "
        "mesh (its mesh.divisions, the discrete problem `demes solve` and `dr.sweep` solve), and each state is set "
        "beside the coarse reference. It is the same state when its frame (at equal arc length) is no farther from "
        "the coarse reference's extrapolated frame than the coarse levels themselves are, plus the reference's "
        "error estimate; farther, the two meshes took different branches where the path bifurcates. A state "
        "farther off is named when it is one of the coarse state's mirror images (through the flat plane, or "
        "left-right on an outline symmetric about the y axis), a state of the same energy on the other side of a "
        "symmetry-breaking bifurcation.",
        Table(COLUMNS, rows)])


def verdicts(rows: list[dict[str, Any]]) -> list[Verdict]:
    claim = "The coarse mesh of this plan reaches the states of the scene's own mesh"
    compared = [r for r in rows if "same_state" in r]
    if not compared:
        return [Verdict(claim, "no state on both meshes", "not measured")]
    others = _others(rows)
    measured = "; ".join(f"{level_label(r['prestretch'])}: {r['theta_scene_mesh']:.2f} against "
                         f"{r['theta_coarse']:.2f} deg" for r in compared)
    return [Verdict(claim, measured, "holds" if not others else "does not hold at "
                    + ", ".join(f"{level_label(r['prestretch'])} ({_named(r)})" for r in others))]


STUDY = Study(name="scene_mesh", runs=runs, analyse=analyse, section=section, tables=tables,
              units={"theta_coarse": "deg", "theta_coarse_error": "deg", "theta_scene_mesh": "deg", "distance": "-",
                     "allowed": "-"},
              findings=findings, verdicts=verdicts, state_groups=(GROUP,))
"""The check of a coarsened plan against the scene's own mesh, as ``demes validate`` plugs it in."""
