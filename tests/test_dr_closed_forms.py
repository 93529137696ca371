"""DR against closed forms: elastica, circular arc, sliding cable, catenary."""

import numpy as np
import pytest

import dr
from validation.common.closed_forms import arc_under_end_moment, catenary_sag, elastica_cantilever, sliding_cable

# the real strip (Table I): EA = 2600 * 0.5 N, EI = 2600 * 0.0003 N mm^2, 2 mm segments at N = 40
EA, EI, LENGTH = 1300.0, 0.78, 80.0


def straight_nodes(n_seg: int, length: float = LENGTH) -> np.ndarray:
    x = np.zeros((n_seg + 1, 3))
    x[:, 0] = np.linspace(0.0, length, n_seg + 1)
    return x


def cantilever_tip(n_seg: int, alpha: float, masses: str = "tensor") -> np.ndarray:
    """Relative tip error of the DR cantilever under P = alpha EI / L^2."""
    m = dr.Model(straight_nodes(n_seg))
    m.clamp(0, (1.0, 0.0, 0.0))
    m.add_beam(np.arange(n_seg + 1), EI=EI, EA=EA)
    m.add_load(n_seg, (0.0, 0.0, -alpha * EI / LENGTH**2))
    res = dr.relax(m, tol=1e-8, masses=masses)
    assert res.converged, res.message
    return res.x[-1] / LENGTH


@pytest.mark.parametrize("alpha", [1.0, 3.0, 10.0])
def test_elastica_tip_within_half_percent_at_40_segments(alpha):
    x_ref, z_ref, _ = elastica_cantilever(alpha)
    tip = cantilever_tip(40, alpha)
    err = np.hypot(tip[0] - x_ref, -tip[2] - z_ref) / np.hypot(x_ref, z_ref)
    assert err < 5e-3
    # the tip also moves the right way by the right amount, not just somewhere near
    assert tip[2] < 0 and abs(-tip[2] - z_ref) < 5e-3 * z_ref


def test_elastica_converges_at_second_order():
    """The moving-ghost clamp and the spline beam are second-order accurate (docs/elements.md)."""
    x_ref, z_ref, _ = elastica_cantilever(3.0)
    errors = []
    for n in (10, 20, 40):
        tip = cantilever_tip(n, 3.0)
        errors.append(np.hypot(tip[0] - x_ref, -tip[2] - z_ref))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(orders - 2.0) < 0.15), orders


def test_scalar_and_tensor_masses_reach_the_same_equilibrium():
    a = cantilever_tip(20, 3.0, masses="tensor")
    b = cantilever_tip(20, 3.0, masses="scalar")
    assert np.allclose(a, b, atol=1e-6)


@pytest.mark.parametrize("phi", [np.pi / 2, 3 * np.pi / 2])
def test_both_ends_clamped_on_an_arc_give_the_arc(phi):
    """Clamping the ends of a straight beam at the ends of a circular arc, with the arc's
    tangents, leaves only end moments: the beam must take the arc, M = EI phi / L throughout."""
    n = 24
    m = dr.Model(straight_nodes(n))
    _, radius = arc_under_end_moment(LENGTH, EI, EI * phi / LENGTH)
    # n rest-length chords fit the arc exactly on the radius R' = (L/n) / (2 sin(phi / 2n)),
    # which tends to R at second order; clamping the ends there leaves only end moments
    radius_n = (LENGTH / n) / (2 * np.sin(phi / (2 * n)))
    assert abs(radius_n - radius) / radius < (phi / n) ** 2 / 20
    # start on the arc, unevenly spaced and shaken: the nodes have to find their places
    rng = np.random.default_rng(1)
    u = np.linspace(0.0, 1.0, n + 1) ** 1.3 * phi
    start = np.stack([radius_n * np.sin(u), np.zeros(n + 1), radius_n * (1 - np.cos(u))], axis=1)
    start[1:-1] += rng.normal(scale=0.05 * radius, size=(n - 1, 3))
    m.clamp(0, (1.0, 0.0, 0.0))
    m.clamp(n, (np.cos(phi), 0.0, np.sin(phi)), rest_tangent=(1.0, 0.0, 0.0))
    m.add_beam(np.arange(n + 1), EI=EI, EA=EA)
    res = dr.relax(m, tol=1e-8, x_start=start)
    assert res.converged, res.message
    dist = np.linalg.norm(res.x - np.array([0.0, 0.0, radius_n]), axis=1)
    assert np.max(np.abs(dist - radius_n)) < 1e-5 * radius
    # every node, the half-weight clamp triplets included, carries M = EI / R'
    assert np.allclose(res.info["node_moment"], EI / radius_n, rtol=1e-5)


def test_sliding_cable_over_a_frictionless_pulley():
    span, rest, ea, load = 100.0, 100.0, 1000.0, 1.0
    m = dr.Model([[0.0, 0.0, 0.0], [span / 2, 0.0, 0.0], [span, 0.0, 0.0]])
    m.support([0, 2])
    m.add_cluster([0, 1, 2], EA=ea, rest_length=rest)
    m.add_load(1, (0.0, 0.0, -load))
    # start off-centre: the pulley has to slide to mid-span
    res = dr.relax(m, tol=1e-10, x_start=[[0.0, 0.0, 0.0], [30.0, 0.0, -8.0], [span, 0.0, 0.0]])
    assert res.converged, res.message
    sag, tension = sliding_cable(span, rest, ea, load)
    assert res.x[1, 0] == pytest.approx(span / 2, abs=1e-6 * span)
    assert -res.x[1, 2] == pytest.approx(sag, rel=1e-6)
    assert res.info["cluster_tension"][0] == pytest.approx(tension, rel=1e-6)


def test_a_cluster_slides_where_links_hold():
    """With unequal rest lengths 40 + 60 mm, two links hold the node off-centre with unequal
    tensions; one cluster of the same total rest length lets it slide to mid-span."""
    start = [[0.0, 0.0, 0.0], [40.0, 0.0, -5.0], [100.0, 0.0, 0.0]]
    links = dr.Model(start)
    links.support([0, 2])
    links.add_link([0, 1], [1, 2], EA=1000.0, rest_length=[40.0, 60.0])
    links.add_load(1, (0.0, 0.0, -1.0))
    cable = dr.Model(start)
    cable.support([0, 2])
    cable.add_cluster([0, 1, 2], EA=1000.0, rest_length=100.0)
    cable.add_load(1, (0.0, 0.0, -1.0))
    a, b = dr.relax(links, tol=1e-10), dr.relax(cable, tol=1e-10)
    assert a.converged and b.converged
    t = a.info["link_tension"]
    assert abs(a.x[1, 0] - 50.0) > 5.0 and abs(t[0] - t[1]) > 1e-3 * t.max()
    assert b.x[1, 0] == pytest.approx(50.0, abs=1e-5)


def chain_sag(n_seg: int, span: float = 100.0, length: float = 120.0, weight: float = 0.01) -> float:
    """Mid-span sag of a chain of n_seg stiff links carrying its weight (N/mm) at the nodes."""
    s = np.linspace(0.0, 1.0, n_seg + 1)
    x = np.zeros((n_seg + 1, 3))
    x[:, 0] = span * s
    x[:, 2] = -0.3 * span * np.sin(np.pi * s)  # any hanging start
    m = dr.Model(x)
    m.support([0, n_seg])
    m.add_link(np.arange(n_seg), np.arange(1, n_seg + 1), EA=1e6, rest_length=length / n_seg, tension_only=True)
    for i in range(1, n_seg):
        m.add_load(i, (0.0, 0.0, -weight * length / n_seg))
    res = dr.relax(m, tol=1e-8)
    assert res.converged, res.message
    return float(-res.x[n_seg // 2, 2])


def test_loaded_chain_approaches_the_catenary_at_second_order():
    exact = catenary_sag(100.0, 120.0)
    errors = [abs(chain_sag(n) - exact) for n in (10, 20, 40)]
    assert errors[-1] / exact < 5e-3
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(orders > 1.8), orders
