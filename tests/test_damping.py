"""The damping schemes (dr.damping) reach the elastica's closed form as kinetic damping does."""

import numpy as np
import pytest

import dr
from validation.bench import ALPHA, LENGTH, elastica_model
from validation.closed_forms import elastica_cantilever


@pytest.mark.parametrize("damping", ["viscous", "fire"])
def test_damping_schemes_reach_the_elastica(damping):
    x_ref, z_ref, _ = elastica_cantilever(ALPHA)
    res = dr.relax(elastica_model(), tol=1e-6, masses="scalar", damping=damping)
    assert res.converged and res.info["damping"] == damping
    tip = res.x[-1] / LENGTH
    # the 40-segment discretisation error of the tip is 2e-4 (kinetic damping gives the same)
    assert np.hypot(tip[0] - x_ref, -tip[2] - z_ref) / np.hypot(x_ref, z_ref) < 5e-4


def test_unknown_damping_is_named():
    with pytest.raises(dr.DRError, match="damping = 'none'"):
        dr.relax(elastica_model(), damping="none")
