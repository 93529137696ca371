"""Pictures without a display: `demes solve` renders its states and prints nothing from VTK."""

import ctypes.util
import os
import subprocess
import sys

import numpy as np
import pytest
from matplotlib.image import imread

from results import level_label
from results.render import RenderUnavailable, headless_window


def test_solve_renders_without_a_display_and_vtk_says_nothing(tmp_path):
    """A fresh process with no DISPLAY, so that VTK's own (fd-level) output is seen too."""
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY", "VTK_DEFAULT_OPENGL_WINDOW")}
    out = tmp_path / "run"
    proc = subprocess.run(
        [sys.executable, "-m", "validation.cli", "solve", "--solver", "dr", "--mesh-levels", "6", "--prestretch", "1.0", "1.1",
         "--out", str(out), "--no-progress"],
        env=env, capture_output=True, text=True, timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""
    lines = proc.stdout.splitlines()
    assert lines[0].startswith("demes_paper: DR, membrane net 'clustered', frame model 'strip', mesh.divisions 6 ")
    assert lines[-1] == f"wrote {out / 'dr_strip.png'}"
    assert not any(word in proc.stdout for word in ("WARN", "X server", "vtk"))
    image = imread(out / "dr_strip.png")[..., :3]
    assert image.shape[0] > 100 and image.shape[1] > 200
    # not blank: the white background, the light-blue membrane and the dark-red frame
    colours = np.unique((image * 255).astype(np.uint8).reshape(-1, 3), axis=0)
    assert len(colours) > 50
    frame_red = (image[..., 0] > 0.4) & (image[..., 1] < 0.15) & (image[..., 2] < 0.15)
    assert frame_red.sum() > 100


def test_level_labels_drop_the_round_off_of_their_grid():
    assert level_label(1.1 + 4 * 0.025) == "1.2" and 1.1 + 4 * 0.025 != 1.2
    assert [level_label(1.0 + 0.1 * k) for k in range(4)] == ["1.0", "1.1", "1.2", "1.3"]
    assert level_label(1.0375) == "1.0375" and level_label(2) == "2.0"


def test_a_machine_that_cannot_render_is_told_what_to_install(monkeypatch):
    for name in ("DISPLAY", "WAYLAND_DISPLAY", "VTK_DEFAULT_OPENGL_WINDOW"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setattr(sys, "platform", "linux")
    monkeypatch.setattr(ctypes.util, "find_library", lambda name: "libOSMesa.so.8" if name == "OSMesa" else None)
    assert headless_window() == "vtkOSOpenGLRenderWindow"
    monkeypatch.setattr(ctypes.util, "find_library", lambda name: None)
    with pytest.raises(RenderUnavailable, match="libegl1.*vtk-osmesa"):
        headless_window()
    monkeypatch.setenv("DISPLAY", ":0")
    assert headless_window() is None


def test_a_picture_draws_the_film_it_has_and_leaves_an_open_window_open():
    """The surface drawn is the film's own triangles: none inside the gripper's open middle window
    (inside its bond lines, y from 32 to 60 between x = -10 and 10), and the window's strip
    bands drawn apart, all of them in the window."""
    import fem_reference
    import scenes
    from results.render import membrane_surface

    scene = scenes.load("multisegment_gripper")
    kept = [e for e in scene.to_dict()["electrodes"] if e["name"] != "middle"]
    scene = scene.updated(**{"frame.open_windows": [[0, 45]], "electrodes": kept, "mesh.divisions": 6,
                             "fem.element": "P1"})
    res = list(fem_reference.sweep(scene, [1.02]))[-1]
    flat = res.x0[:, :2]
    for block, inside_window in (("membrane", False), ("strip_band", True)):
        faces = membrane_surface(res, block).faces.reshape(-1, 4)[:, 1:]
        centroid = flat[faces].mean(axis=1)
        in_window = (np.abs(centroid[:, 0]) < 12) & (centroid[:, 1] > 30) & (centroid[:, 1] < 60)
        assert len(faces) and (in_window.all() if inside_window else not in_window.any()), block
    drawn = membrane_surface(res).faces.reshape(-1, 4)[:, 1:]
    assert np.array_equal(drawn, res.blocks["membrane"].connectivity[:, :3])
