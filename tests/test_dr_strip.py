"""The strip beam against closed forms: weak- and strong-axis elastica, torsion."""

import numpy as np
import pytest

import dr
from validation.common.closed_forms import elastica_cantilever

LENGTH, N = 80.0, 40
EA, EI_W, EI_S, GJ = 1300.0, 0.78, 1761.0, 2.58  # the real strip (Table I, b t^3/12 ...)
WIDTH = 1.0  # lever of the orientation nodes, mm


def strip_cantilever() -> tuple[dr.Model, np.ndarray]:
    """A straight strip along x, taped and clamped at x = 0. Each edge's orientation node sits
    WIDTH inside (+y), held by two stiff links: pin-jointed triangles that add no stiffness of
    their own, so the strip's plane is x-y and its normal +z."""
    x = np.zeros((N + 1, 3))
    x[:, 0] = np.linspace(0.0, LENGTH, N + 1)
    mid = 0.5 * (x[1:] + x[:-1]) + [0.0, WIDTH, 0.0]
    m = dr.Model(np.vstack([x, mid]))
    orient = np.arange(N + 1, 2 * N + 1)
    m.clamp(0, (1.0, 0.0, 0.0), taped=True)
    m.add_beam(np.arange(N + 1), EI=EI_W, EA=EA, EI_strong=EI_S, GJ=GJ, orientation=orient)
    m.add_link(np.concatenate([np.arange(N), np.arange(1, N + 1)]), np.concatenate([orient, orient]), EA=100.0, role="frame")
    return m, orient


@pytest.mark.parametrize("axis, EI", [(2, EI_W), (1, EI_S)])
def test_tip_load_bends_the_strip_about_the_loaded_axis(axis, EI):
    """A load normal to the strip's plane (z) bends it about its weak axis with EI_w; one in
    its plane (y) about the strong axis with EI_s. PL^2/EI = 3 either way. In-plane, the strip
    is held in its plane: free, it would buckle sideways and twist (lateral-torsional
    buckling at P = 4.01 sqrt(EI_w GJ) / L^2 = 9e-4 N, far below this load)."""
    m, _ = strip_cantilever()
    if axis == 1:
        m.support(np.arange(1, m.n), axes="z")
    load = np.zeros(3)
    load[axis] = -3.0 * EI / LENGTH**2
    m.add_load(N, load)
    res = dr.relax(m, tol=1e-8)
    assert res.converged, res.message
    x_ref, z_ref, _ = elastica_cantilever(3.0)
    tip = res.x[N] / LENGTH
    assert tip[0] == pytest.approx(x_ref, rel=5e-3)
    assert -tip[axis] == pytest.approx(z_ref, rel=5e-3)
    other = 3 - axis  # the strip must not wander out of the loading plane
    assert abs(tip[other]) < 1e-6


def test_end_torque_twists_the_strip_by_TL_over_GJ():
    """A small couple about the strip's axis at its tip twists it by phi = T L / GJ."""
    m, orient = strip_cantilever()
    torque = 0.02 * GJ / LENGTH  # phi = 0.02 rad: the couple's arm shortens by 2e-4 only
    # a couple: +F z on the last orientation node, -F z on the tip's edge, lever WIDTH
    f = torque / WIDTH
    m.add_load(orient[-1], (0.0, 0.0, f))
    m.add_load(N, (0.0, 0.0, -0.5 * f))
    m.add_load(N - 1, (0.0, 0.0, -0.5 * f))
    res = dr.relax(m, tol=1e-8)
    assert res.converged, res.message
    p0, p1, q = res.x[N - 1], res.x[N], res.x[orient[-1]]
    w = q - 0.5 * (p0 + p1)
    phi = np.arctan2(w[2], w[1])
    # the last edge's normal sits half an edge from the tip: it has turned by T (L - l/2) / GJ
    expected = torque * (LENGTH - 0.5 * LENGTH / N) / GJ
    assert phi == pytest.approx(expected, rel=5e-3)
