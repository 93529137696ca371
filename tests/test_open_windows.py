"""Open windows (frame.open_windows): refused input by name, the mesh against the window's area,
and the flat pre-stretched film's energy against its closed form on the film left in both solvers
(DR and the FEM on one state: tests/test_examples.py, examples/open_window.py)."""

from __future__ import annotations

import numpy as np
import pytest

import scenes
from dr.demes_model import build as build_dr, set_prestretch
from dr.kernels import energy as dr_energy
from fem_reference.model import DemesProblem
from scenes import SceneError
from scenes.mesh import membrane_mesh

E, H = 1.0, 0.05  # the gripper's film: MPa, mm (mounted)
MIDDLE = [[0.0, 45.0]]
"""A point of the gripper's middle window (y from 30 to 60 between the members' centrelines)."""


def gripper(**changes):
    """The built-in gripper with its middle window open (its electrode removed) and ``changes``."""
    scene = scenes.load("multisegment_gripper")
    kept = [e for e in scene.to_dict()["electrodes"] if e["name"] != "middle"]
    return scene.updated(**{"frame.open_windows": MIDDLE, "electrodes": kept, **changes})


def area(nodes: np.ndarray, triangles: np.ndarray) -> float:
    e1, e2 = nodes[triangles[:, 1]] - nodes[triangles[:, 0]], nodes[triangles[:, 2]] - nodes[triangles[:, 0]]
    return float(0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum())


@pytest.mark.parametrize("changes, words", [
    ({"frame.open_windows": [[0, 30]]}, r"frame\.open_windows\[0\] = \[0, 30\] is not inside a window"),
    ({"frame.open_windows": [[0, 95]]}, r"frame\.open_windows\[0\] = \[0, 95\] is not inside a window"),
    ({"frame.open_windows": [[0, 40], [5, 50]]}, r"frame\.open_windows\[1\] and frame\.open_windows\[0\] lie in the "
                                                 "same window"),
    ({"frame.open_windows": [[0, 15], [0, 45], [0, 75]]}, r"frame\.open_windows opens every window \(3\)"),
    ({"frame.open_windows": [[0, 45]]}, r"electrodes\[1\]\.region \('middle'\) reaches into the open window"),
    ({"frame.open_windows": [0, 45]}, r"frame\.open_windows\[0\] = 0"),
])
def test_open_windows_a_scene_cannot_model_are_refused_by_name(changes, words):
    with pytest.raises(SceneError, match="^" + words):
        scenes.load("multisegment_gripper").updated(**changes)


def test_a_frame_without_members_cannot_open_its_one_window():
    with pytest.raises(SceneError, match=r"^frame\.open_windows opens every window \(1\)"):
        scenes.load("rectangular_demes").updated(**{"frame.open_windows": [[0, 20]]})


@pytest.mark.parametrize("refinement", [0, 1])
def test_an_open_window_leaves_its_strip_bands_and_nothing_inside_them(refinement):
    """The middle window is the 24 x 30 mm rectangle between the members' centrelines; its bands are
    the two side rails' inner halves (2 mm, frame.bond_lever) and the lower member's band (its bond
    line to its left, +y), so 160 mm^2 of it is kept as strip material and 560 mm^2 removed."""
    scene = gripper()
    closed = membrane_mesh(scenes.load("multisegment_gripper"), refinement)
    mesh = membrane_mesh(scene, refinement)
    lever = scene.frame.lever
    band = area(mesh.nodes, mesh.band_triangles)
    assert band == pytest.approx(2 * lever * 30 + lever * (24 - 2 * lever), rel=1e-12)
    assert area(closed.nodes, closed.triangles) - area(mesh.nodes, mesh.triangles) == pytest.approx(
        (24 - 2 * lever) * (30 - lever), rel=1e-12)
    centroids = mesh.nodes[mesh.film_triangles].mean(axis=1)
    inside = (np.abs(centroids[:, 0]) < 12) & (centroids[:, 1] > 30) & (centroids[:, 1] < 60)
    assert not inside.any()
    used = np.unique(mesh.triangles)
    assert np.array_equal(used, np.arange(len(mesh.nodes)))  # no node left without a triangle
    for chain in (mesh.frame_nodes, mesh.bond_nodes, *mesh.members, *mesh.member_bonds):
        assert np.allclose(mesh.nodes[chain], closed.nodes[_same(closed.nodes, mesh.nodes[chain])])


def _same(nodes: np.ndarray, points: np.ndarray) -> np.ndarray:
    return np.argmin(np.linalg.norm(nodes[None] - points[:, None], axis=2), axis=1)


@pytest.mark.parametrize("prestretch, later", [(1.2, 1.3), ((1.3, 1.1), None)])
def test_the_flat_film_stores_its_closed_form_energy_on_the_film_left_in_both_solvers(prestretch, later):
    """The flat state at a pre-stretch (isotropic, changed on the built model as a sweep does, or
    a pair): the link-net law's energy per flat area times the film's area, the covered scene's
    less the open window's 24 x 30 mm; the strip bands, unstretched, store nothing."""
    changes = {"loading.prestretch": list(prestretch) if isinstance(prestretch, tuple) else prestretch,
               "dr.check_contact": False}
    scene = gripper(**changes)
    pair = prestretch if isinstance(prestretch, tuple) else (later or prestretch,) * 2
    lams = []
    for phi in (0.0, 60.0, 120.0):
        t = np.radians(phi)
        lams.append(1.0 / np.sqrt(np.cos(t) ** 2 / pair[0] ** 2 + np.sin(t) ** 2 / pair[1] ** 2))
    density = E * H * sum((lam - 1.0) ** 2 / (2.0 * lam) for lam in lams)
    closed = membrane_mesh(scenes.load("multisegment_gripper"), 0)
    expected = density * (area(closed.nodes, closed.triangles) - 24 * 30)

    dm = build_dr(scene)
    if later is not None:
        set_prestretch(dm.model, scene, later, current=scene.prestretch)
    packed = dm.model.pack()
    X = np.zeros((packed.n_total, 3))
    X[:packed.n] = dm.model.nodes
    assert float(sum(dr_energy(X, packed))) == pytest.approx(expected, rel=1e-12)
    problem = DemesProblem(scene, 0, "P1")
    problem.lam = later or scene.prestretch
    assert problem.energy(problem.X.ravel()) == pytest.approx(expected, rel=1e-12)
