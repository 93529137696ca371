"""``demes bench --fem``: what one FEM reference state costs at each refinement level.

For each element (P1, P2) and level k, one state of the paper DEMES (strip frame) from the flat
state, as the reference solves it: the path followed on level 0, each finer level started from
the one below. Per level: free DOFs, Newton iterations and sparse Cholesky factorisations on
that level's mesh, the median wall time of the whole state, and the level's own share (the
state's time less the state one level down, whose work it repeats exactly) per Newton
iteration.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import fem_reference  # noqa: E402
import scenes  # noqa: E402

from .dr_cases import timed  # noqa: E402

ELEMENTS = ("P1", "P2")


def rows(*, levels: tuple[int, ...] = (0, 1, 2), elements: tuple[str, ...] = ELEMENTS,
         prestretch: float = 1.3, repeats: int = 1, grading: float = 1.0) -> list[dict]:
    """One row per element and level, levels ascending; a level's own share is its time less the
    level below's (NaN where that level was not timed). ``grading``: the scene's mesh.grading
    (the mesh graded towards the frame; 1 uniform)."""
    out: list[dict] = []
    for element in elements:
        scene = scenes.paper_demes(prestretch, **{"fem.element": element, "mesh.grading": grading})
        times = {-1: 0.0}  # level -> median time of its state; level 0 repeats nothing below it
        for k in sorted(levels):
            # one warm-up compiles for the whole process
            res, t = timed(lambda: fem_reference.solve(scene, refinement=k), repeats, warm_up=not out)
            times[k] = t
            own = t - times.get(k - 1, float("nan"))  # unknown when the level below was not timed
            out.append({
                "element": element, "grading": grading, "level": k, "free_dofs": res.info["n_free_dofs"], "status": res.status,
                "newton": res.iterations, "factorisations": res.info["factorisations"], "time": t,
                "time_level": own, "per_newton": own / max(res.iterations, 1),
                "bending_angle": res.bending_angle,
            })
    return out


COLUMNS = (
    ("element", "element", ""),
    ("grading", "mesh.grading", "g"),
    ("level", "level", "d"),
    ("free_dofs", "free DOFs", "d"),
    ("status", "status", ""),
    ("newton", "Newton its (level)", "d"),
    ("factorisations", "factorisations (level)", "d"),
    ("time", "median time, state [s]", ".2f"),
    ("time_level", "level's own [s]", ".2f"),
    ("per_newton", "per Newton it [s]", ".3f"),
    ("bending_angle", "theta [deg]", ".4f"),
)
