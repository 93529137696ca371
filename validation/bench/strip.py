"""``demes bench --strip``: DR on the strip DEMES for each damping and each net, against the FEM.

For each net (``dr.membrane_net``) and damping (``dr.damping``), from flat to each pre-stretch:
iterations, median wall time, ns per node-iteration, the time to reach 1 % and 0.1 % RMS shape
error against the converged state (the fastest of the runs at looser tolerances that is that
close, else the converged run's time), and the FEM/DR time ratio with the FEM timed in the same
process on the same mesh (``fem.refinement``). The floor of the per-iteration cost is a kernel
that only reads and writes the loop's arrays (:func:`floor_ns_per_node_iteration`).
"""

from __future__ import annotations

import time

import numpy as np
from numba import njit

import dr
import fem_reference
import scenes
from results import Result

from .dr_cases import timed

NETS = ("triangles", "links", "clustered")
DAMPINGS = ("kinetic", "viscous", "fire")
LADDER = (1e-3, 1e-4, 1e-5)
"""Looser tolerances whose states give the time to a shape error."""


def strip_scene(prestretch: float, net: str, damping: str, refinement: int) -> scenes.Scene:
    return scenes.paper_demes(prestretch, "strip", **{"dr.membrane_net": net, "dr.damping": damping,
                                                      "fem.refinement": refinement})


def time_to_error(scene: scenes.Scene, converged: Result, t_converged: float) -> dict[str, float]:
    """Seconds to 1 % and 0.1 % RMS shape error (of the side) against ``converged``."""
    runs = []
    for tol in LADDER:
        t0 = time.perf_counter()
        res = dr.solve(scene.updated(**{"dr.tolerance": tol}))
        runs.append((time.perf_counter() - t0, res.shape_error(converged)[0] if res.converged else np.inf))
    out = {}
    for key, level in (("t_1pct", 1e-2), ("t_01pct", 1e-3)):
        out[key] = min([t for t, e in runs if e <= level] + [t_converged])
    return out


@njit(cache=True)
def _floor_kernel(X, V, R, G, M, Minv, D, S, tri, steps):
    """Reads and writes what one DR step touches, with no arithmetic beyond a sum."""
    acc = 0.0
    for _ in range(steps):
        for t in range(tri.shape[0]):
            for k in range(3):
                i = tri[t, k]
                for c in range(3):
                    G[i, c] += X[i, c]
                    D[i, c] += S[i]
        for i in range(X.shape[0]):
            for c in range(3):
                R[i, c] = G[i, c] * Minv[i, c] + M[i, c]
                V[i, c] += R[i, c]
                X[i, c] += 1e-300 * V[i, c]
                G[i, c] = 0.0
                D[i, c] = 0.0
            acc += S[i]
    return acc


def floor_ns_per_node_iteration(model: dr.Model, steps: int = 2000) -> float:
    """ns per node and step of :func:`_floor_kernel` on ``model``'s nodes and triangles."""
    n = model.n
    tri = model.triangles if model.triangles is not None else np.zeros((0, 3), np.int64)
    arrays = [np.ones((n, 3)) for _ in range(4)] + [np.ones((n, 6)) for _ in range(3)]
    args = (*arrays, np.ones(n), np.ascontiguousarray(tri, dtype=np.int64))
    _floor_kernel(*args, 1)
    t0 = time.perf_counter()
    _floor_kernel(*args, steps)
    return 1e9 * (time.perf_counter() - t0) / (steps * n)


def fem_times(prestretches, refinement: int, repeats: int) -> dict[float, tuple[Result, float]]:
    """The FEM from flat to each pre-stretch on the strip DEMES at ``refinement`` (s, median)."""
    fem_reference.solve(strip_scene(1.05, "triangles", "kinetic", refinement))  # warm-up
    return {lam: timed(lambda: fem_reference.solve(strip_scene(lam, "triangles", "kinetic", refinement)),
                       repeats, warm_up=False) for lam in prestretches}


def rows(nets=NETS, dampings=DAMPINGS, prestretches=(1.5,), refinement: int = 0, repeats: int = 1,
         fem: bool = True) -> list[dict]:
    """One row per net, damping and pre-stretch (keys: :data:`COLUMNS`)."""
    dr.solve(strip_scene(1.05, "triangles", "kinetic", refinement))  # compile
    fem_t = fem_times(prestretches, refinement, repeats) if fem else {}
    out = []
    for net in nets:
        for damping in dampings:
            for lam in prestretches:
                scene = strip_scene(lam, net, damping, refinement)
                res, t = timed(lambda: dr.solve(scene), repeats, warm_up=False)
                row = {"net": net, "damping": damping, "prestretch": lam, "status": res.status,
                       "iterations": res.iterations, "time": t, "theta": res.bending_angle,
                       "ns_per_node_iteration": 1e9 * t / max(res.iterations, 1) / res.x.shape[0]}
                if res.converged:
                    row.update(time_to_error(scene, res, t))
                if lam in fem_t:
                    f_res, f_t = fem_t[lam]
                    row.update(fem_time=f_t, fem_dr_ratio=f_t / t, fem_theta=f_res.bending_angle)
                    if net == "triangles":
                        row["shape_error_vs_fem"] = res.shape_error(f_res)[0]
                out.append(row)
    return out


COLUMNS = (
    ("net", "net", ""),
    ("damping", "damping", ""),
    ("prestretch", "lambda", ".2f"),
    ("status", "status", ""),
    ("iterations", "iterations", "d"),
    ("time", "time [s]", ".2f"),
    ("ns_per_node_iteration", "ns/node-it", ".0f"),
    ("t_1pct", "t 1 % [s]", ".2f"),
    ("t_01pct", "t 0.1 % [s]", ".2f"),
    ("theta", "theta [deg]", ".2f"),
    ("fem_time", "FEM [s]", ".2f"),
    ("fem_dr_ratio", "FEM/DR", ".2f"),
    ("shape_error_vs_fem", "RMS vs FEM", ".1e"),
)
