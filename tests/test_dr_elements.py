"""Element forces are the exact gradient of the element energies (finite differences)."""

import numpy as np
import pytest

import dr
from dr.kernels import energy, gradient, place_virtual


def fd_gradient(model: dr.Model, x: np.ndarray, h: float = 1e-6) -> np.ndarray:
    P = model.pack()
    X = np.zeros((P.n_total, 3))
    out = np.zeros((P.n, 3))
    for i in range(P.n):
        for c in range(3):
            e = []
            for sign in (1, -1):
                X[: P.n] = x
                X[i, c] += sign * h
                e.append(sum(energy(X, P)))
            out[i, c] = (e[0] - e[1]) / (2 * h)
    return out


def kernel_gradient(model: dr.Model, x: np.ndarray) -> np.ndarray:
    P = model.pack()
    X = np.zeros((P.n_total, 3))
    X[: P.n] = x
    G = np.zeros_like(X)
    gradient(X, P, G, np.zeros((0, 6)))
    return G[: P.n]


def strip_model(taped_end: bool, offset: float, strip: bool = True) -> dr.Model:
    """A curved strip of 7 nodes on the membrane's edge, orientation nodes inside, cables
    attached through offset nodes, a taped clamp at one end."""
    k = 7
    angle = np.linspace(0.0, 1.2, k)
    frame = np.stack([10 * np.cos(angle), 10 * np.sin(angle), np.zeros(k)], axis=1)
    mid = 0.5 * (angle[1:] + angle[:-1])
    inner = np.stack([8 * np.cos(mid), 8 * np.sin(mid), np.zeros(k - 1)], axis=1)
    hub = np.array([[0.0, 0.0, 0.0]])
    m = dr.Model(np.vstack([frame, inner, hub]))
    orient = np.arange(k, 2 * k - 1)
    if taped_end:
        m.clamp(0, (-np.sin(0.0), np.cos(0.0), 0.0), taped=True)
    m.support([2 * k - 1])
    kwargs = dict(EI_strong=30.0, GJ=2.0) if strip else {}
    m.add_beam(np.arange(k), EI=1.5, EA=200.0, orientation=orient, **kwargs)
    m.add_link(orient, np.full(k - 1, 2 * k - 1), EA=5.0)  # orientation nodes held by links
    attach = [m.offset_node(i, offset) for i in range(1, k - 1)] if offset else list(range(1, k - 1))
    for a, o in zip(attach, orient):
        m.add_cluster([a, o, 2 * k - 1], EA=3.0, rest_length=0.8 * (10.0))
    m.add_link(attach[0], attach[-1], EA=2.0, rest_length=5.0, tension_only=True)
    return m


@pytest.mark.parametrize("taped_end", [False, True])
@pytest.mark.parametrize("offset", [0.0, 0.3])
def test_strip_forces_are_the_gradient_of_its_energy(taped_end, offset):
    m = strip_model(taped_end, offset)
    rng = np.random.default_rng(3)
    x = m.nodes + rng.normal(scale=0.4, size=m.nodes.shape)
    g = kernel_gradient(m, x)
    g_fd = fd_gradient(m, x)
    free = ~m.fixed
    scale = np.abs(g_fd).max()
    assert np.max(np.abs(g - g_fd)[free]) < 1e-6 * scale
    # the orientation nodes do get forces from the strip (its plane hangs on them)
    assert np.abs(g[7:13]).max() > 1e-3 * scale


def test_isotropic_beam_with_offsets_is_consistent_where_it_has_an_energy():
    """Offsets and cables are energy-based; pulled back through the strip normal they must
    match finite differences also on an isotropic (paper) frame."""
    m = strip_model(taped_end=True, offset=0.3, strip=False)
    rng = np.random.default_rng(4)
    x = m.nodes + rng.normal(scale=0.3, size=m.nodes.shape)
    # compare without the spline beam's bending (Adriaenssens-Barnes shears are not an exact
    # gradient of M^2 L / 2EI), i.e. on the other nodes' forces only through offsets/cables
    m.beams[0].EI = 1e-30
    g, g_fd = kernel_gradient(m, x), fd_gradient(m, x)
    free = ~m.fixed
    assert np.max(np.abs(g - g_fd)[free]) < 1e-6 * np.abs(g_fd).max()


@pytest.mark.parametrize("part", ["weak", "strong", "twist"])
def test_each_part_of_the_strip_energy_has_its_exact_gradient(part):
    """Per energy part, on random bent and twisted node geometries, so that a small but wrong
    term cannot hide behind a large right one."""
    from dr.strips import EIS, EIW, GJ, KB, KT, strip_local

    column = {"weak": EIW, "strong": EIS, "twist": GJ}[part]
    rng = np.random.default_rng(5)
    for _ in range(40):
        xl = np.zeros((5, 3))
        xl[1] = [1.0, 0.0, 0.0] + 0.3 * rng.normal(size=3)
        xl[2] = xl[1] + [1.0, 0.0, 0.0] + rng.uniform(0.0, 1.2) * rng.normal(size=3)
        xl[3] = 0.5 * (xl[0] + xl[1]) + [0.0, 1.0, 0.0] + 0.3 * rng.normal(size=3)
        xl[4] = 0.5 * (xl[1] + xl[2]) + [0.0, 1.0, 0.0] + 0.3 * rng.normal(size=3)
        par = np.zeros(9)
        par[KB], par[KT], par[column] = 0.7, 0.9, 1.0
        par[5:8] = 0.3 * rng.normal(size=3)  # rest curvatures and twist
        g = np.zeros((5, 3))
        strip_local(xl, False, False, par, g, True)
        g_fd = np.zeros((5, 3))
        for r in range(5):
            for c in range(3):
                for sign in (1, -1):
                    x2 = xl.copy()
                    x2[r, c] += sign * 1e-6
                    g_fd[r, c] += sign * sum(strip_local(x2, False, False, par, np.zeros((5, 3)), False)[:2]) / 2e-6
        assert np.abs(g - g_fd).max() < 1e-6 * np.abs(g_fd).max()


def test_flat_reference_of_a_strip_is_stress_free():
    m = strip_model(taped_end=True, offset=0.3)
    P = m.pack()
    X = np.zeros((P.n_total, 3))
    X[: P.n] = m.nodes
    e_mem, e_bend, e_twist, e_ax = energy(X, P)
    assert e_bend < 1e-20 and e_twist < 1e-20 and e_ax < 1e-20


def test_ghost_mirrors_across_the_clamp_plane():
    m = dr.Model([[0, 0, 0], [1, 0.2, 0.3], [2, 0, 0]])
    m.clamp(0, (1.0, 0.0, 0.0))
    m.add_beam([0, 1, 2], EI=1.0)
    P = m.pack()
    X = np.zeros((4, 3))
    X[:3] = m.nodes
    place_virtual(X, P)
    assert np.allclose(X[3], [-1.0, 0.2, 0.3])
