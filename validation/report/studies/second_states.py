"""Second stable states: the pre-stretch applied at once from flat, polished and checked by the FEM.

The sweep follows one quasi-static branch. To look for others, DR applies each pre-stretch at
once from the flat state (as the paper did: the pseudo-dynamic transient can settle off the path)
on the matched model, and the FEM's Newton on the same mesh polishes that state and checks its
stability; each found state is set beside the path's state (DR matched) at its pre-stretch.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from results import Result, level_label

from ...common.document import Section, Table
from ...solve.other_starts import SECOND_STATE
from ..compare import state_difference
from ..plan import MATCHED, Run, Settings, levels_between
from ..study import Study
from ..verdicts import Verdict

GROUP = "second"


def runs(s: Settings) -> list[Run]:
    """One cold run over the pre-stretches below first contact (about 1.77), or two in the quick plan."""
    lams = (1.15, 1.3) if s.quick else levels_between(1.1, 1.7, 0.1)
    return [Run("second_states", "dr", {**s.coarse, **MATCHED, "dr.prestretch_step": 0.0, "dr.tolerance": s.tight},
                lams, group=GROUP, cold=True, polish=True,
                title="DR matched, pre-stretch at once from flat, polished by the FEM (r0)")]


def _mirror(state: Result | None) -> Result | None:
    """The state reflected in the flat plane (z -> -z): an equilibrium of the same energy."""
    return None if state is None else replace(state, x=state.x * np.array([1.0, 1.0, -1.0]))


def analyse(a: Any, out_dir: Path) -> list[dict[str, Any]] | None:
    """Each state found beside the path's (``a``: :class:`validation.report.analysis.Analysis`).
    A second stable state is converged, stable and more than :data:`SECOND_STATE` from the
    path's state and from its mirror image in the flat plane (the same state curled the other
    way, of the same energy)."""
    if not a.plan.by_group(GROUP):
        return None
    rows = []
    for run in a.plan.by_group(GROUP):
        for lam, found in sorted(a.states[run.label].items()):
            path = a.states["dr_matched"].get(lam)
            row = {"prestretch": lam, "status": found.status,
                   "theta_path": path.bending_angle if path is not None else np.nan,
                   "energy_path": path.energy["total"] if path is not None else np.nan,
                   "theta_dr_at_once": found.info.get("dr_bending_angle", np.nan)}
            if found.converged:
                rms, _ = state_difference(found, path)
                mirrored, _ = state_difference(found, _mirror(path))
                row.update(theta_found=found.bending_angle, energy_found=found.energy["total"],
                           energy_gap=found.energy["total"] - row["energy_path"], shape_distance=rms,
                           mirror_distance=mirrored, stable=bool(found.info.get("stable")),
                           lowest_eigenvalue=found.info.get("lowest_eigenvalue_N_per_mm3", np.nan))
                row["mirror_of_path"] = bool(mirrored <= SECOND_STATE)
                row["second_state"] = bool(row["stable"] and rms > SECOND_STATE and not row["mirror_of_path"])
            rows.append(row)
    return rows


def tables(rows: list[dict[str, Any]]) -> dict[str, list[dict[str, Any]]]:
    return {"second_states": rows}


def findings(rows: list[dict[str, Any]]) -> list[str]:
    """The second stable states found, and where DR landed on the path's mirror image."""
    out = []
    second = [r for r in rows if r.get("second_state")]
    if second:
        out.append("Second stable states (refinement 0, the pre-stretch applied at once): " + "; ".join(
            f"{level_label(r['prestretch'])}: theta {r['theta_found']:.1f} deg, energy {r['energy_gap']:+.3g} N mm from the "
            f"path's {r['theta_path']:.1f} deg" for r in second) + ".")
    elif rows:
        out.append(f"The search for second stable states found none at {len(rows)} pre-stretch levels.")
    mirrors = [level_label(r["prestretch"]) for r in rows if r.get("mirror_of_path")]
    if mirrors:
        out.append(f"Applied at once, DR ended on the path's state curled the other way (its mirror image in the "
                   f"flat plane, the same energy) at {', '.join(mirrors)}.")
    return out


COLUMNS = (
    ("prestretch", "lambda", "level"),
    ("theta_path", "path: theta [deg]", ".2f"),
    ("energy_path", "path: energy [N mm]", ".4g"),
    ("theta_dr_at_once", "at once, DR: theta [deg]", ".2f"),
    ("theta_found", "polished: theta [deg]", ".2f"),
    ("energy_found", "polished: energy [N mm]", ".4g"),
    ("energy_gap", "energy above the path's [N mm]", ".3g"),
    ("shape_distance", "distance [/side]", ".3g"),
    ("mirror_distance", "from the path's mirror image [/side]", ".3g"),
    ("stable", "stable", ""),
    ("lowest_eigenvalue", "lowest eigenvalue [N/mm^3]", ".3g"),
    ("second_state", "second stable state", ""),
)


def section(rows: list[dict[str, Any]], figures: dict[str, Path | None]) -> Section:
    return Section("Second stable states", [
        "The path above is one quasi-static branch. To look for others, DR applies each pre-stretch at once from "
        "the flat state (as the paper did: the pseudo-dynamic transient can settle off the path) on the matched "
        "model at refinement 0, and the FEM's Newton on the same mesh polishes that state and checks its stability "
        "(lowest eigenvalue of the tangent). A polished state that is stable and more than "
        f"{SECOND_STATE:g} of the side from the path's state is a second stable state; both are listed with their "
        "energies. A search from one start per pre-stretch finds some other states, not all.",
        Table(COLUMNS, rows)])


def verdicts(rows: list[dict[str, Any]]) -> list[Verdict]:
    """The path's state against the states other starts reach."""
    claim = "The path's state is the lowest-energy state found"
    if not rows:
        return [Verdict(claim, "no search for other states", "not measured")]
    found = [r for r in rows if r.get("second_state")]
    if not found:
        return [Verdict(claim, f"no second stable state at {len(rows)} pre-stretch levels", "holds")]
    measured = "; ".join(f"{level_label(r['prestretch'])}: {r['theta_found']:.1f} deg, {r['energy_gap']:+.3g} N mm "
                         f"against the path's {r['theta_path']:.1f} deg" for r in found)
    lower = [level_label(r["prestretch"]) for r in found if r["energy_gap"] < 0.0]
    verdict = (f"does not hold at {', '.join(lower)}: a state of lower energy" if lower
               else "holds; other stable states exist, of higher energy")
    return [Verdict(claim, measured, verdict)]


STUDY = Study(name="second_states", runs=runs, analyse=analyse, section=section, tables=tables,
              units={"theta_path": "deg", "theta_found": "deg", "theta_dr_at_once": "deg", "energy_path": "N mm",
                     "energy_found": "N mm", "energy_gap": "N mm", "shape_distance": "-", "lowest_eigenvalue": "N/mm^3"},
              findings=findings, verdicts=verdicts)
"""The search for second stable states, as ``demes validate`` plugs it in."""
