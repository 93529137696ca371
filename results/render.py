"""Pictures of states with pyvista, off-screen, quiet on a machine without a display.

VTK's default render window on Linux tries the X server first; with no display it prints
"bad X server connection" before it falls back to EGL. :func:`plotter` picks the headless
window (EGL, else OSMesa) up front when there is no display, so nothing is printed.
"""

from __future__ import annotations

import ctypes.util
import os
import sys
from pathlib import Path
from typing import Sequence

import numpy as np

from .atomic import atomic_write
from .labels import level_label
from .state import Result

WINDOW_ENV = "VTK_DEFAULT_OPENGL_WINDOW"


class RenderUnavailable(RuntimeError):
    """No way to render off-screen here (no display, no EGL, no OSMesa)."""


def headless_window() -> str | None:
    """The VTK render window class to use without a display, or None when there is a display.

    Raises
    ------
    RenderUnavailable
        Without a display, EGL or OSMesa (the message says what to install).
    """
    if not sys.platform.startswith("linux") or os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"):
        return None
    if os.environ.get(WINDOW_ENV):
        return os.environ[WINDOW_ENV]
    if ctypes.util.find_library("EGL"):
        return "vtkEGLRenderWindow"
    if ctypes.util.find_library("OSMesa"):
        return "vtkOSOpenGLRenderWindow"
    raise RenderUnavailable(
        "no display and no off-screen OpenGL (libEGL or libOSMesa) found: install the system's "
        "EGL library (Debian/Ubuntu: apt install libegl1) or `pip install vtk-osmesa`"
    )


def plotter(**kwargs):
    """An off-screen ``pyvista.Plotter(**kwargs)`` that prints nothing on a headless machine."""
    window = headless_window()
    if window is not None:
        os.environ[WINDOW_ENV] = window
    os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")
    import pyvista as pv

    pv.OFF_SCREEN = True
    return pv.Plotter(off_screen=True, **kwargs)


FILM_BLOCKS = ("membrane_surface", "membrane")
"""The result blocks that hold the film's triangles (DR's, the FEM's), the first found drawn."""


def membrane_surface(res: Result, block: str | None = None):
    """The membrane as a triangulated ``pyvista.PolyData``: the film's triangles (corners of
    quadratic ones), or the cells of ``block``; where a result has none, the Delaunay
    triangulation of the flat reference, triangles outside the frame outline dropped."""
    import pyvista as pv
    from scipy.spatial import Delaunay

    names = [block] if block is not None else [n for n in FILM_BLOCKS if n in res.blocks]
    found = res.blocks.get(names[0]) if names else None
    if found is not None and found.cell_type in ("triangle", "triangle6"):
        tri = np.asarray(found.connectivity)[:, :3]
    else:
        xy = res.x0[:, :2]
        tri = Delaunay(xy).simplices
        centroid = xy[tri].mean(axis=1)
        keep = res.scene.outline.contains(centroid) if res.scene is not None else np.ones(len(tri), bool)
        tri = tri[keep]
    faces = np.hstack([np.full((tri.shape[0], 1), 3), tri]).ravel()
    return pv.PolyData(res.x, faces)


def add_state(pl, res: Result, offset: Sequence[float] = (0.0, 0.0, 0.0)) -> None:
    """Add the membrane (light blue) and the frame centreline with its members and the open
    windows' strip bands (dark red) of ``res``, shifted by ``offset`` (mm), to the plotter's
    current view."""
    import pyvista as pv

    shift = np.asarray(offset, float)
    surf = membrane_surface(res)
    surf.points = surf.points + shift
    pl.add_mesh(surf, color="lightsteelblue", show_edges=False, opacity=0.85)
    if "strip_band" in res.blocks:  # an open window's strips, their inner halves
        band = membrane_surface(res, "strip_band")
        band.points = band.points + shift
        pl.add_mesh(band, color="darkred", show_edges=False)
    frame = res.frame_curve() + shift
    pl.add_mesh(pv.lines_from_points(np.vstack([frame, frame[:1]])), color="darkred", line_width=4)
    members = res.blocks.get("members")
    if members is not None:
        edges = np.asarray(members.connectivity)
        lines = np.hstack([np.full((len(edges), 1), 2), edges]).ravel()
        pl.add_mesh(pv.PolyData(res.x + shift, lines=lines), color="darkred", line_width=4)


def render_states(states: Sequence[Result], path: str | Path, title: str = "",
                  panel_size: tuple[int, int] = (420, 420)) -> Path:
    """One PNG of ``states`` side by side (in the order given), each seen from the front, a
    little above and to the side, at one scale, labelled with its pre-stretch and bending
    angle; written atomically.

    Raises
    ------
    RenderUnavailable
        If this machine cannot render off-screen (the message says what to install).
    """
    n = len(states)
    pl = plotter(shape=(1, n), window_size=(panel_size[0] * n, panel_size[1]), border=False)
    # half the largest bounding-box diagonal: the whole of every state fits, from any side
    scale = 0.53 * max(float(np.linalg.norm(np.ptp(res.x[np.isfinite(res.x).all(axis=1)], axis=0)))
                       for res in states)
    for k, res in enumerate(states):
        pl.subplot(0, k)
        add_state(pl, res)
        label = f"lambda {level_label(res.prestretch)}: theta {res.bending_angle:.1f} deg"
        if not res.converged:
            label += f" ({res.status})"
        pl.add_text(f"{title}\n{label}" if title and k == 0 else label, font_size=9)
        # from the front (-y), a little above and to the side: the curl about the base shows
        pl.view_vector((0.35, -1.0, 0.45), viewup=(0.0, 0.0, 1.0))
        pl.enable_parallel_projection()
        pl.reset_camera()
        pl.camera.parallel_scale = scale

    def write(tmp: Path) -> None:
        pl.screenshot(str(tmp))

    try:
        return atomic_write(path, write)
    finally:
        pl.close()
