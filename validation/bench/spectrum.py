"""``demes bench --spectrum``: what sets DR's step count on the strip DEMES.

At DR's converged state (triangles, strip frame, ``fem.refinement``, from flat to the
pre-stretch), both ends of the spectrum of K v = w M v (:func:`dr.stability.spectrum`) for each
kind of masses, over all free DOFs and with the frame's nodes held (the film's own spectrum:
what is left once no frame mode moves, the most a constraint on the frame such as an
inextensible, in-plane-rigid strip could give). Kinetic damping's steps scale with
sqrt(w_max / w_min); the frame shares say which part of the structure each end's mode moves.
"""

from __future__ import annotations

import time

import numpy as np

import dr
from dr import stability

from .strip import strip_scene

COLUMNS = (
    ("masses", "masses", ""),
    ("dofs", "DOFs", ""),
    ("w_max", "w_max", ".4g"),
    ("w_min", "w_min", ".3e"),
    ("sqrt_kappa", "sqrt(w_max/w_min)", ".1f"),
    ("top_frame_share", "top: frame share", ".2f"),
    ("bottom_frame_share", "bottom: frame share", ".2f"),
    ("found", "converged", ""),
    ("time", "time [s]", ".1f"),
)
MASSES = ("tensor", "frame")


def frame_share(shape: np.ndarray, frame_nodes: np.ndarray) -> float:
    """The fraction of a mode's squared nodal displacement at the frame's nodes."""
    sq = np.sum(shape**2, axis=1)
    return float(sq[frame_nodes].sum() / sq.sum())


def rows(prestretch: float = 1.3, refinement: int = 0) -> list[dict]:
    scene = strip_scene(prestretch, "triangles", "kinetic", refinement)
    state = dr.solve(scene)
    if not state.converged:
        raise RuntimeError(f"DR did not converge at {prestretch:g}: {state.message}")
    built = dr.build(scene)
    frame = np.zeros(built.model.n, dtype=bool)
    frame[built.frame_nodes] = True
    out = []
    for masses in MASSES:
        for dofs, held in (("all", None), ("frame held", frame)):
            t0 = time.perf_counter()
            ends = stability.spectrum(built.model, state.x, masses=masses, held=held)
            out.append(dict(masses=masses, dofs=dofs, w_max=ends.w_max, w_min=ends.w_min, sqrt_kappa=ends.condition,
                            top_frame_share=frame_share(ends.top, built.frame_nodes),
                            bottom_frame_share=frame_share(ends.bottom, built.frame_nodes), found=ends.found,
                            time=time.perf_counter() - t0))
    return out
