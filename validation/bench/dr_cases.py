"""``demes bench``: wall time, iterations and throughput of the DR solver (not a test).

Cases: the elastica cantilever with the real strip's EA and EI (40 segments, 2 mm, residual
1e-6), with tensor and with Barnes' scalar masses, and the paper's DEMES at 150 %: the Table I
frame with the pre-stretch applied at once (as the paper did) and ramped, and the strip frame
ramped; and the strip DEMES with triangles (refinement 0) flat to 130 % with tensor masses and
with the frame mass (dr.frame_mass), and with the frame mass on the mesh graded towards the frame
(:data:`GRADED`). Medians over repeated runs in one process, after a warm-up run that compiles.
"""

from __future__ import annotations

import os
import statistics
import time
from typing import Callable

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import dr  # noqa: E402
import scenes  # noqa: E402
from results import Result  # noqa: E402

from ..common.closed_forms import elastica_cantilever  # noqa: E402
from ..common.tables import format_table  # noqa: E402

EA, EI, SEGMENTS, LENGTH, ALPHA = 1300.0, 0.78, 40, 80.0, 3.0

GRADED = {"mesh.divisions": 28, "mesh.grading": 4.0}
"""The graded-mesh case: 28 divisions graded 4 (frame spacing 0.46 mm)."""


def elastica_model() -> dr.Model:
    """The 40-segment cantilever of the real strip under P L^2 / EI = 3."""
    x = np.zeros((SEGMENTS + 1, 3))
    x[:, 0] = np.linspace(0.0, LENGTH, SEGMENTS + 1)
    m = dr.Model(x)
    m.clamp(0, (1.0, 0.0, 0.0))
    m.add_beam(np.arange(SEGMENTS + 1), EI=EI, EA=EA)
    m.add_load(SEGMENTS, (0.0, 0.0, -ALPHA * EI / LENGTH**2))
    return m


def element_count(model: dr.Model) -> int:
    """Elements updated per step: links, cable segments, beam and strip node terms."""
    P = model.pack()
    return P.link_ij.shape[0] + P.clu_seg.shape[0] + P.beam_idx.shape[0] + P.strip_idx.shape[0]


def timed(run: Callable[[], Result], repeats: int, warm_up: bool = True) -> tuple[Result, float]:
    """The last result of ``run`` and the median wall time (s) of ``repeats`` calls, after one
    call that compiles and warms up (``warm_up``; off where a cheaper run did that already)."""
    if warm_up:
        run()
    times, res = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        res = run()
        times.append(time.perf_counter() - t0)
    return res, statistics.median(times)


def cases(repeats: int) -> list[dict]:
    rows = []
    x_ref, z_ref, _ = elastica_cantilever(ALPHA)
    m = elastica_model()
    for masses in ("tensor", "scalar"):
        res, t = timed(lambda: dr.relax(m, tol=1e-6, masses=masses), repeats)
        tip = res.x[-1] / LENGTH
        err = np.hypot(tip[0] - x_ref, -tip[2] - z_ref) / np.hypot(x_ref, z_ref)
        rows.append(_row(f"elastica 40 seg, {masses} masses", res, t, element_count(m), f"tip error {err:.2e}"))
    for frame_model, step in (("paper", 0.0), ("paper", None), ("strip", None)):
        changes = {} if step is None else {"dr.prestretch_step": step}
        scene = scenes.paper_demes(1.5, frame_model, **changes)
        built = dr.build(scene)
        res, t = timed(lambda: dr.solve(scene), repeats)
        how = "applied at once (the paper)" if step == 0.0 else f"in steps of {scene.dr.prestretch_step:g}"
        rows.append(_row(f"DEMES 150 %, {frame_model} frame, {how}", res, t, element_count(built.model),
                         f"theta {res.bending_angle:.1f} deg"))
    for masses in ("tensor", "frame"):
        scene = scenes.paper_demes(1.3, "strip", **{"dr.membrane_net": "triangles", "dr.masses": masses})
        res, t = timed(lambda: dr.solve(scene), repeats)
        rows.append(_row(f"DEMES 130 % from flat, strip, triangles r0, {masses} masses", res, t,
                         element_count(dr.build(scene).model), f"theta {res.bending_angle:.3f} deg"))
    scene = scenes.paper_demes(1.3, "strip", **{"dr.membrane_net": "triangles", **GRADED})
    res, t = timed(lambda: dr.solve(scene), repeats, warm_up=False)
    rows.append(_row("DEMES 130 % from flat, strip, triangles r0, 28 divisions graded 4, frame masses", res, t,
                     element_count(dr.build(scene).model), f"theta {res.bending_angle:.3f} deg"))
    return rows


def _row(name: str, res: Result, t: float, elements: int, note: str) -> dict:
    return {
        "case": name,
        "status": res.status,
        "time": t,
        "iterations": res.iterations,
        "us_per_iter": 1e6 * t / max(res.iterations, 1),
        "updates_per_s": elements * res.iterations / t,
        "note": note,
    }


COLUMNS = (
    ("case", "case", ""),
    ("status", "status", ""),
    ("time", "median time [s]", ".3f"),
    ("iterations", "iterations", "d"),
    ("us_per_iter", "time/iter [us]", ".2f"),
    ("updates_per_s", "element updates/s", ".3g"),
    ("note", "result", ""),
)


def main(repeats: int = 3) -> int:
    """Run the cases and print the table; returns 0."""
    rows = cases(repeats)
    print(format_table(rows, COLUMNS))
    el = {r["case"]: r["time"] for r in rows}
    ratio = el["elastica 40 seg, scalar masses"] / el["elastica 40 seg, tensor masses"]
    print(f"elastica: scalar / tensor masses time ratio {ratio:.1f} (same process, medians of {repeats})")
    return 0
