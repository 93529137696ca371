"""The paper's nets carry the whole film: flat-state pre-stress energy equals the continuum's."""

import numpy as np
import pytest

import dr
import fem_reference
import scenes
from dr.kernels import energy


def _outline_area(scene: scenes.Scene) -> float:
    poly = scene.outline.polyline(scene.outline.side_length / 4000)[0]
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


@pytest.mark.parametrize("net", ["links", "clustered"])
def test_flat_prestress_energy_is_the_films(net):
    """At the flat state every link family is stretched by lambda, so the continuum stores
    3 E h A (lambda - 1)^2 / (2 lambda); the net's boundary cables carry the film of the margin
    the lattice leaves at the frame, so the net stores the same at every mesh density."""
    lam = 1.3
    for divisions in (8, 12, 28):
        scene = scenes.paper_demes(prestretch=lam, frame_model="strip",
                                   **{"dr.membrane_net": net, "mesh.divisions": divisions})
        model = dr.build(scene).model
        P = model.pack()
        X = np.zeros((P.n_total, 3))
        X[: P.n] = model.nodes
        stored = energy(X, P)[0]
        mem = scene.membrane
        film = 3 * mem.E * mem.thickness * _outline_area(scene) * (lam - 1) ** 2 / (2 * lam)
        assert stored == pytest.approx(film, rel=1e-3), divisions


@pytest.mark.parametrize("divisions", [8, 28])
def test_strip_plane_is_set_at_the_bond_lever_whatever_the_mesh(divisions):
    """Each strip edge's plane passes through the film point halfway between the points
    frame.bond_lever inside its two ends (the FEM's director), not through the lattice node
    beside the edge."""
    scene = scenes.paper_demes(prestretch=1.3, frame_model="strip", **{
        "dr.membrane_net": "links", "mesh.divisions": divisions, "frame.bond_lever": 1.5})
    built = dr.build(scene)
    P = built.model.pack()
    X = np.zeros((P.n_total, 3))
    X[: P.n] = built.model.nodes
    dr.kernels.place_virtual(X, P)
    bonds = X[P.n : P.n + P.bond_nodes.shape[0], :2]
    net = built.net
    assert bonds.shape[0] == net.n_frame
    xy, t = scene.outline.evaluate(net.frame_s)
    inner = xy + 1.5 * np.column_stack([-t[:, 1], t[:, 0]])
    np.testing.assert_allclose(bonds, 0.5 * (inner + np.roll(inner, -1, axis=0)), atol=1e-9)
    fem = fem_reference.mesh.build_mesh(scene.updated(**{"mesh.divisions": divisions}), 0)
    directors = 0.5 * (fem.frame_inner + np.roll(fem.frame_inner, -1, axis=0))
    lever = np.linalg.norm(directors - 0.5 * (fem.nodes[fem.frame_nodes] + np.roll(fem.nodes[fem.frame_nodes], -1, axis=0)), axis=1)
    assert np.median(lever) == pytest.approx(1.5, rel=0.02)
