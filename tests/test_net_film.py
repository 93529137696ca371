"""The paper's nets carry the whole film: flat-state pre-stress energy equals the continuum's."""

import numpy as np
import pytest

import dr
import scenes
from dr.kernels import energy


def _area(poly: np.ndarray) -> float:
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


@pytest.mark.parametrize("net", ["links", "clustered"])
def test_flat_prestress_energy_is_the_films(net):
    """At the flat state every lattice family is stretched by lambda, so the continuum stores
    3 E h A (lambda - 1)^2 / (2 lambda). The row of triangles at the bond line and the cables
    inside it (whose film areas reach the bond line) together store exactly that for A, the
    polygon of frame nodes, at every mesh density; A converges to the outline's area, and is
    within 0.5 % of it at 28 divisions."""
    lam = 1.3
    deficits = []
    for divisions in (8, 12, 28, 40):
        scene = scenes.paper_demes(prestretch=lam, frame_model="strip",
                                   **{"dr.membrane_net": net, "mesh.divisions": divisions})
        dm = dr.build(scene)
        P = dm.model.pack()
        X = np.zeros((P.n_total, 3))
        X[: P.n] = dm.model.nodes
        stored = energy(X, P)[0]
        mem = scene.membrane
        per_area = 3 * mem.E * mem.thickness * (lam - 1) ** 2 / (2 * lam)
        frame_polygon = _area(dm.net.nodes[: dm.net.n_frame, :2])
        assert stored == pytest.approx(per_area * frame_polygon, rel=1e-9), divisions
        outline = scene.outline.polyline(scene.outline.side_length / 4000)[0]
        deficits.append(1.0 - stored / (per_area * _area(outline)))
    assert deficits[2] <= 5e-3
    assert np.all(np.diff(deficits) < 0) and deficits[-1] > 0, deficits


@pytest.mark.parametrize("divisions", [8, 28])
def test_the_nets_bond_the_strip_at_the_lever_at_every_density(divisions):
    """Each frame node's bond node is frame.bond_lever inside it, across the frame, whatever
    the lattice spacing: the film turns the strip at the same lever as in the FEM."""
    scene = scenes.paper_demes(prestretch=1.3, frame_model="strip", **{"mesh.divisions": divisions})
    net = dr.build(scene).net
    frame, bond = net.nodes[: net.n_frame, :2], net.nodes[net.bond_nodes, :2]
    _, tangent = scene.outline.evaluate(net.frame_s)
    across = bond - frame
    assert np.linalg.norm(across, axis=1) == pytest.approx(scene.frame.lever, rel=1e-12)
    assert np.abs(np.sum(across * tangent, axis=1)).max() < 1e-12 * scene.frame.lever
    # the row of film tiles the band between the two lines: every triangle counter-clockwise,
    # their areas adding up to the frame polygon less the bond polygon
    x = net.nodes[:, :2]
    e1 = x[net.row_triangles[:, 1]] - x[net.row_triangles[:, 0]]
    e2 = x[net.row_triangles[:, 2]] - x[net.row_triangles[:, 0]]
    signed = 0.5 * (e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    assert signed.min() > 0
    assert signed.sum() == pytest.approx(_area(frame) - _area(bond), rel=1e-12)
