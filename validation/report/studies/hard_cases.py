"""Hard cases: scenes that stress the solvers' numerical stability, each run by DR and the FEM.

Each case changes one thing against the validated scene (no or tiny pre-stretch, one beyond the
paper's range, a frame 100 times stiffer or softer, a coarse or fine mesh, an asymmetric or tiny
perturbation, another outline, DR's mass safety factor at its bound); its outcome is a status
the solver names, and where both solvers ran, their distance.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ...common.document import Section, Table
from ...solve.levels import not_reached
from ..compare import state_difference
from ..plan import LINKS, REFERENCE, Run, Settings
from ..study import Study

GROUP = "hard"

FEM_TIME_LIMIT = {False: 240.0, True: 60.0}
"""Wall-time budget (s) of a hard case's FEM run, full and quick mode."""


def runs(s: Settings) -> list[Run]:
    """DR on the paper's link net (and the FEM where it has a counterpart): the cases stress DR's
    time stepping, which the net exercises as the triangles do, at a third of their cost per step."""
    lams = (1.0, 1.3) if s.quick else (1.0, 1.3, 1.5)
    cases: list[tuple[str, dict[str, Any], tuple[float, ...], str]] = [
        ("zero_prestretch", {}, (1.0,), "no pre-stretch: must stay flat with no energy"),
        ("tiny_prestretch", {}, (1.001,), "pre-stretch 1.001"),
        ("very_high_prestretch", {}, (2.0,) if s.quick else (2.5, 3.0), "pre-stretch beyond the paper's 200 %"),
        ("stiff_frame", {"frame.E": 260000.0}, lams, "frame 100x stiffer"),
        ("soft_frame", {"frame.E": 26.0}, lams, "frame 100x softer"),
        ("coarse_mesh", {"mesh.divisions": 4}, lams, "4 divisions per side"),
        ("asymmetric", {"perturbation.asymmetry": 2.0}, lams, "antisymmetric tilt of the sides, 2 mm"),
        ("tiny_perturbation", {"perturbation.amplitude": 1e-4}, lams, "apex lift 1e-4 mm"),
        ("square_frame", {"frame.outline": "polygon", "frame.vertices": [[-20.0, 0.0], [20.0, 0.0], [20.0, 40.0], [-20.0, 40.0]]},
         lams, "square frame outline (40 mm sides)"),
    ]
    if not s.quick:
        cases.append(("fine_mesh", {"mesh.divisions": 56}, (1.3,), "56 divisions per side"))
    out = []
    for name, change, case_lams, title in cases:
        out.append(Run(f"hard_dr_{name}", "dr", {**s.coarse, **LINKS, **change}, case_lams, group=GROUP, title=title))
        if name != "fine_mesh":
            # a hard case may make the reference crawl (measured: the 100x softer frame took 20 min
            # to get from 1.0 to 1.12); its time limit keeps the report's budget
            limit = {"fem.time_limit": FEM_TIME_LIMIT[s.quick]}
            out.append(Run(f"hard_fem_{name}", "fem", {**s.coarse, **REFERENCE, **change, **limit}, case_lams,
                           group=GROUP, title=title))
    # below f = 1 the time step is unstable and the scene refuses it (dr.relax itself, given one,
    # stops with status 'diverged' before any contact is reported: tests/test_errors.py)
    out.append(Run("hard_dr_mass_safety_1", "dr", {**s.coarse, **LINKS, "dr.mass_safety": 1.0}, lams, group=GROUP,
                   title="DR mass safety factor f = 1 (the stability bound; scenes refuse f < 1)"))
    return out


def analyse(a: Any, out_dir: Path) -> list[dict[str, Any]] | None:
    """Each case's outcome per pre-stretch: status, iterations, time and the distance to the
    FEM's state of the same case, or the error it gave (``a``: the core analysis)."""
    if not a.plan.by_group(GROUP):
        return None
    rows: list[dict[str, Any]] = []
    for run in a.plan.by_group(GROUP):
        rec = a.records.get(run.label, {})
        base = {"case": run.label.split("_", 2)[2], "solver": run.solver, "title": run.title}
        if rec.get("error"):
            rows.append({**base, "prestretch": np.nan, "status": "error", "message": rec["error"]})
            continue
        twin = run.label.replace("hard_dr_", "hard_fem_") if run.solver == "dr" else None
        for lam, res in sorted(a.states[run.label].items()):
            other = a.states.get(twin, {}).get(lam) if twin else None
            rms, dtheta = state_difference(res, other)
            rows.append({**base, "prestretch": lam, "status": res.status, "converged": res.converged,
                         "iterations": res.iterations, "wall_time": res.wall_time,
                         "bending_angle": res.bending_angle if res.scene else np.nan,
                         "branch": res.info.get("branch", ""),
                         "shape_rms_vs_fem": rms, "bending_angle_diff_vs_fem": dtheta,
                         "peak_memory": rec.get("peak_memory_mb", np.nan), "message": res.message})
        for lam in not_reached(run.prestretches, list(a.states[run.label])):
            rows.append({**base, "prestretch": lam, "status": "not reached",
                         "message": "the path stopped before this pre-stretch"})
    return rows


def tables(rows: list[dict[str, Any]]) -> dict[str, list[dict[str, Any]]]:
    return {"hard_cases": rows}


COLUMNS = (
    ("case", "case", ""),
    ("solver", "solver", ""),
    ("prestretch", "lambda", "level"),
    ("status", "status", ""),
    ("iterations", "iterations", "d"),
    ("wall_time", "time [s]", ".3g"),
    ("bending_angle", "theta [deg]", ".2f"),
    ("branch", "branch", ""),
    ("shape_rms_vs_fem", "DR vs FEM shape RMS [/side]", ".3g"),
    ("message", "message", ""),
)


def section(rows: list[dict[str, Any]], figures: dict[str, Path | None]) -> Section:
    return Section("Hard cases", [Table(COLUMNS, rows)])


STUDY = Study(name="hard_cases", runs=runs, analyse=analyse, section=section, tables=tables,
              units={"wall_time": "s", "bending_angle_diff_vs_fem": "deg", "shape_rms_vs_fem": "-"})
"""The hard cases, as ``demes validate`` plugs them in."""
