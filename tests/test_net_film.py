"""The paper's nets carry the whole film: flat-state pre-stress energy equals the continuum's."""

import numpy as np
import pytest

import dr
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
