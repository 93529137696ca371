"""``demes bench --gallery``: what a gallery scene's path costs in each solver.

For each scene (default :data:`SCENES`: a rectangle of aspect 0.5 and the quadrilateral without
mirror symmetry), DR's triangles and the FEM's P1 elements on one mesh
(:func:`validation.solve.gallery.gallery_scene`) follow the gallery's path from the flat state
(1.1, then 1.3). Per solver: the median wall time of the whole path, its iterations (DR's
steps, the FEM's Newton iterations), the cost of one (DR: ns per node-step; the FEM: ms per
Newton iteration), the free DOFs, and the last state's angle and energy, with the DR - FEM
difference. Medians of runs in one process, after one warm-up path per solver.
"""

from __future__ import annotations

import os
from typing import Any, Sequence

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import dr  # noqa: E402
import fem_reference  # noqa: E402

from ..solve.gallery import PRESTRETCHES, gallery_scene  # noqa: E402
from .dr_cases import timed  # noqa: E402

SCENES = ("wide_rectangle", "asymmetric_quadrilateral")


def rows(*, names: Sequence[str] = SCENES, repeats: int = 3, divisions: int = 14) -> list[dict[str, Any]]:
    """One row per scene and solver (DR first): the path's median time, iterations and cost per
    iteration, and its last state."""
    out: list[dict[str, Any]] = []
    warm: set[str] = set()
    for name in names:
        scene = gallery_scene(name, divisions)
        last: dict[str, Any] = {}
        for solver, sweep in (("DR triangles", dr.sweep), ("FEM P1", fem_reference.sweep)):
            states: list = []

            def path(sweep=sweep, states=states):
                states[:] = list(sweep(scene, list(PRESTRETCHES)))
                return states[-1]

            res, t = timed(path, repeats, warm_up=solver not in warm)
            warm.add(solver)
            iterations = sum(s.iterations for s in states)
            nodes = res.x.shape[0]
            per_iteration = (f"{1e9 * t / max(iterations * nodes, 1):.0f} ns/node-step" if solver.startswith("DR")
                             else f"{1e3 * t / max(iterations, 1):.1f} ms/Newton it")
            last[solver] = res
            out.append({"scene": name, "solver": solver, "status": res.status, "reached": res.prestretch,
                        "free_dofs": res.info["n_free_dofs"], "time": t, "iterations": iterations,
                        "per_iteration": per_iteration, "bending_angle": res.bending_angle,
                        "energy": res.energy["total"]})
        d, f = last["DR triangles"], last["FEM P1"]
        out[-2]["note"] = out[-1]["note"] = (
            f"DR - FEM {d.bending_angle - f.bending_angle:+.3f} deg, "
            f"{(d.energy['total'] - f.energy['total']) / abs(f.energy['total']):+.1e} energy; "
            f"FEM/DR time {out[-1]['time'] / out[-2]['time']:.2f}")
    return out


COLUMNS = (
    ("scene", "scene", ""),
    ("solver", "solver", ""),
    ("status", "status", ""),
    ("reached", "pre-stretch", "g"),
    ("free_dofs", "free DOFs", "d"),
    ("time", "median time, path [s]", ".2f"),
    ("iterations", "iterations", "d"),
    ("per_iteration", "cost per iteration", ""),
    ("bending_angle", "theta [deg]", ".3f"),
    ("energy", "energy [N mm]", ".7f"),
    ("note", "DR against the FEM", ""),
)
