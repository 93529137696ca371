"""Voltage actuation: the ideal dielectric's energy against its closed forms, in the FEM.

The closed forms (validation.actuation.electromechanics) are the Maxwell stress eps0 eps_r (V/h)^2 of a flat
film, the capacitor energy A C V^2 / 2, and the free equibiaxial film of Zhao & Suo (2007) with
its pull-in peak; none of them comes from a solver.
"""

from __future__ import annotations

import numpy as np
import pytest
from skfem import Basis, ElementTriP1, ElementTriP2, ElementVector, MeshTri

import scenes
from fem_reference.actuation import VoltagePath
from fem_reference.dielectric import Dielectric, area_ratio_squared
from fem_reference.membrane import Membrane
from fem_reference.model import Evaluation, mass_form
from fem_reference.newton import newton
from scenes.electric import EPSILON_0, check_voltages, dielectric_coefficient
from validation.actuation.electromechanics import (capacitor_energy, free_film_pull_in, free_film_stretch,
                                         free_film_voltage, gent_jm, maxwell_stress)

EPS_R = 4.65
L = 10.0  # mm, side of the test square


def square_basis(n: int, element=ElementTriP1) -> Basis:
    mesh = MeshTri.init_tensor(np.linspace(0, L, n + 1), np.linspace(0, L, n + 1))
    return Basis(mesh, ElementVector(element(), 3))


def coefficient(voltage: float, h: float) -> float:
    return EPSILON_0 * EPS_R * voltage**2 / (2 * h)


# ----------------------------------------------------------------------------- closed forms


def test_units_maxwell_stress_in_mpa():
    # 45 V/um across VHB: eps0 eps_r E^2 = 8.854e-12 * 4.65 * (4.5e7 V/m)^2 = 8.34e4 Pa
    assert maxwell_stress(2250.0, 0.05, EPS_R) == pytest.approx(0.0834, rel=1e-3)


def test_free_film_pull_in_is_the_classical_peak():
    mu, H = 0.015, 0.5
    lam, v = free_film_pull_in(mu, H, EPS_R)
    assert lam == pytest.approx(4 ** (1 / 6))
    assert v / (H * np.sqrt(mu / (EPSILON_0 * EPS_R))) == pytest.approx(0.6874, abs=1e-4)
    stretches = np.linspace(1.0001, 2.0, 2001)
    assert free_film_voltage(stretches, mu, H, EPS_R).max() <= v * (1 + 1e-9)
    # a locking stretch stiffens the film: pull-in comes later
    lam_g, v_g = free_film_pull_in(mu, H, EPS_R, gent_jm(6.0))
    assert lam_g > lam and v_g > v


# ----------------------------------------------------------------------------- FEM term


def test_area_ratio_derivatives_against_finite_differences():
    rng = np.random.default_rng(3)
    F = np.eye(3, 2)[:, :, None] + 0.3 * rng.standard_normal((3, 2, 4))
    j2, d, h = area_ratio_squared(F)
    a1, a2 = F[:, 0], F[:, 1]
    assert np.allclose(j2, np.sum(np.cross(a1, a2, axis=0) ** 2, axis=0))
    step = 1e-6
    for i in range(3):
        for j in range(2):
            dF = np.zeros_like(F)
            dF[i, j] = step
            jp, dp, _ = area_ratio_squared(F + dF, 1)
            jm, dm, _ = area_ratio_squared(F - dF, 1)
            assert np.allclose((jp - jm) / (2 * step), d[i, j], rtol=1e-7, atol=1e-9)
            assert np.allclose((dp - dm) / (2 * step), h[:, :, i, j], rtol=1e-6, atol=1e-8)


def test_dielectric_gradient_and_tangent_against_finite_differences():
    basis = square_basis(2, ElementTriP2)
    diel = Dielectric(basis, coefficient(1500.0, 0.05))
    rng = np.random.default_rng(1)
    x = diel.X * 1.2 + 0.3 * rng.standard_normal(diel.X.shape)
    e, g, K = diel.evaluate(x)
    v = rng.standard_normal(x.size)
    step = 1e-5
    ep, gp, _ = diel.evaluate(x + step * v.reshape(-1, 3), 1)
    em, gm, _ = diel.evaluate(x - step * v.reshape(-1, 3), 1)
    assert (ep - em) / (2 * step) == pytest.approx(g @ v, rel=1e-7)
    assert np.allclose((gp - gm) / (2 * step), K @ v, rtol=1e-6, atol=1e-9 * np.abs(K @ v).max())


@pytest.mark.parametrize("stretch", [1.0, 1.3])
def test_flat_film_electrostatic_stress_is_maxwell(stretch):
    """A flat film (mounted thickness h_m) stretched equibiaxially by s: the voltage lowers its
    tension by eps0 eps_r (V/h)^2 h with h = h_m / s^2, and its energy is -E_cap."""
    h_m, V = 0.05, 2000.0
    diel = Dielectric(square_basis(3), coefficient(V, h_m))
    x = diel.X * stretch
    e, g, _ = diel.evaluate(x, 1)
    h = h_m / stretch**2
    edge = np.isclose(diel.X[:, 0], L)
    tension = g.reshape(-1, 3)[edge, 0].sum() / (stretch * L)  # N per current mm
    assert tension == pytest.approx(-maxwell_stress(V, h, EPS_R) * h, rel=1e-12)
    assert -e == pytest.approx(capacitor_energy(V, (stretch * L) ** 2, h, EPS_R), rel=1e-12)
    assert diel.capacitor_energy(x) == pytest.approx(-e)


class FreeFilm:
    """A square quarter of a free film in its plane: symmetry planes x = 0, y = 0, z held."""

    def __init__(self, n: int, mu: float, H: float, law: str = "neo-hookean", jm: float = np.inf):
        basis = square_basis(n)
        self.membrane = Membrane(basis, law, 3 * mu, H, tension_only=False, jm=jm)
        self.dielectric = Dielectric(basis)
        X = self.membrane.X
        fixed = np.zeros(X.shape, bool)
        fixed[:, 2] = True
        fixed[np.isclose(X[:, 0], 0), 0] = True
        fixed[np.isclose(X[:, 1], 0), 1] = True
        self.X, self.n_dofs = X, X.size
        self.free = np.flatnonzero(~fixed.ravel())
        self.mass = mass_form.assemble(basis).tocsr()

    def energy(self, y):
        x = y.reshape(-1, 3)
        return self.membrane.energy(x, 1.0) + self.dielectric.energy(x)

    def evaluate(self, y, order=2):
        x = y.reshape(-1, 3)
        e, g, K = self.membrane.evaluate(x, 1.0, order)
        ed, gd, Kd = self.dielectric.evaluate(x, order)
        scale = float(np.abs(g).max()) or 1.0
        return Evaluation(e + ed, {}, g + gd, K + Kd if order >= 2 else None, scale)

    def stretch(self, y) -> float:
        x = y.reshape(-1, 3)
        corner = np.argmax(self.X[:, 0] + self.X[:, 1])
        return x[corner, 0] / L


def test_free_film_stretch_and_pull_in_match_zhao_suo():
    mu, H = 0.015, 0.1  # MPa, mm: pull-in near 1311 V
    film = FreeFilm(2, mu, H)
    lam_p, v_p = free_film_pull_in(mu, H, EPS_R)
    for V in (0.5 * v_p, 0.95 * v_p):
        film.dielectric.coefficient = coefficient(V, H)
        start = film.X * free_film_stretch(0.8 * V, mu, H, EPS_R)
        nr = newton(film, start.ravel(), tol=1e-10)
        assert nr.converged and nr.positive_definite
        assert film.stretch(nr.y) == pytest.approx(free_film_stretch(V, mu, H, EPS_R), rel=1e-8)
    film.dielectric.coefficient = 0.0
    path = VoltagePath(film, film.X.ravel(), lambda v: coefficient(v, H), neutral=1e-12,
                       snap_iterations=15)
    _, stop = path.advance(1.2 * v_p, step=0.1 * v_p)
    assert stop is not None and stop.status == "pull_in"
    assert v_p - 2.0 < path.voltage <= v_p * (1 + 1e-9)  # the last stable state: the peak
    assert film.stretch(path.y) == pytest.approx(lam_p, rel=0.02)


# ----------------------------------------------------------------------------- scenes


def test_scene_fields_and_coefficient():
    scene = scenes.paper_demes(prestretch=1.5, **{"loading.voltage": 1000.0})
    assert scene.membrane.permittivity == 4.65
    c = dielectric_coefficient(scene)
    assert c == pytest.approx(EPSILON_0 * 4.65 * 1000.0**2 / (2 * scene.membrane.thickness))
    s2 = scene.updated(**{"membrane.unstretched_thickness": 0.5})
    assert dielectric_coefficient(s2) == pytest.approx(c * scene.membrane.thickness / (0.5 / 1.5**2))


@pytest.mark.parametrize("field, value, words", [
    ("membrane.unstretched_thickness", 0.0, "must be positive"),
    ("membrane.unstretched_thickness", -0.1, "must be positive"),
    ("membrane.permittivity", 0.5, "at least 1"),
    ("loading.voltage", -100.0, "zero or positive"),
])
def test_bad_fields_named(field, value, words):
    with pytest.raises(scenes.SceneError, match=field.replace(".", r"\.")) as info:
        scenes.paper_demes(**{field: value})
    assert words in str(info.value)


@pytest.mark.parametrize("volts", [[-100.0, 0.0], [0.0, 200.0, 100.0], [], [float("nan")]])
def test_bad_voltage_lists(volts):
    with pytest.raises(scenes.SceneError, match="voltage"):
        check_voltages(volts)


# ----------------------------------------------------------------------------- DR element


def _random_triangle(rng):
    xl = np.array([[0.0, 0.0, 0.0], [2.0, 0.1, 0.0], [0.3, 1.7, 0.0]]) * 1.3
    return xl + 0.4 * rng.standard_normal((3, 3))


def test_dr_dielectric_gradient_and_hessian_against_finite_differences():
    from dr.dielectric import dielectric_hessian, dielectric_local

    rng = np.random.default_rng(7)
    xl = _random_triangle(rng)
    par = np.array([1.9, coefficient(2000.0, 0.05)])
    g = np.zeros((3, 3))
    dielectric_local(xl, par, g, True)
    H = np.zeros((9, 9))
    dielectric_hessian(xl, par, H)
    step = 1e-6
    for k in range(9):
        d = np.zeros(9)
        d[k] = step
        gp, gm = np.zeros((3, 3)), np.zeros((3, 3))
        ep = dielectric_local(xl + d.reshape(3, 3), par, gp, True)
        em = dielectric_local(xl - d.reshape(3, 3), par, gm, True)
        assert (ep - em) / (2 * step) == pytest.approx(g.ravel()[k], rel=1e-6, abs=1e-12)
        assert np.allclose((gp - gm).ravel() / (2 * step), H[:, k], rtol=1e-6, atol=1e-10)


def test_dr_and_fem_dielectric_energies_agree():
    """The DR triangles and the FEM's P1 film carry the same electrostatic energy."""
    import dr

    basis = square_basis(3)
    c = coefficient(1800.0, 0.05)
    diel = Dielectric(basis, c)
    rng = np.random.default_rng(5)
    x = diel.X * 1.1 + 0.2 * rng.standard_normal(diel.X.shape)
    m = dr.Model(diel.X)
    m.add_dielectric(basis.mesh.t.T, c)
    assert m.dielectric_energy(x)[0] == pytest.approx(diel.energy(x), rel=1e-12)
    assert m.dielectric_energy(x)[1] == pytest.approx(diel.current_area(x), rel=1e-12)


def dr_quarter_film(mu: float, H: float, prestretch: float, voltage: float | None,
                     law: str = "neo-hookean", jm: float = np.inf):
    """A DR quarter film of neo-Hookean (or Gent) triangles (symmetry planes x = 0, y = 0,
    z held), with the dielectric at ``voltage`` (None: no dielectric term at all)."""
    import dr

    basis = square_basis(2)
    X = Dielectric(basis).X
    m = dr.Model(X)
    m.add_triangles(basis.mesh.t.T, E=3 * mu, thickness=H / prestretch**2, prestretch=prestretch,
                    law=law, tension_only=False, gent_jm=jm)
    if voltage is not None:
        m.add_dielectric(basis.mesh.t.T, coefficient(voltage, H / prestretch**2))
    m.support(np.arange(len(X)), axes="z")
    m.support(np.flatnonzero(np.isclose(X[:, 0], 0)), axes="x")
    m.support(np.flatnonzero(np.isclose(X[:, 1], 0)), axes="y")
    res = dr.relax(m, tol=1e-9, force_scale=mu * H * L)
    assert res.converged, res.message
    corner = np.argmax(X[:, 0] + X[:, 1])
    return res.x, res.x[corner, 0] / L


def test_dr_free_film_stretch_matches_zhao_suo():
    """DR relaxes a free neo-Hookean quarter film under voltage to the closed form; at 0 V the
    dielectric term changes nothing, bit for bit."""
    mu, H = 0.015, 0.1
    _, v_p = free_film_pull_in(mu, H, EPS_R)
    _, stretch = dr_quarter_film(mu, H, 1.0, 0.9 * v_p)
    assert stretch == pytest.approx(free_film_stretch(0.9 * v_p, mu, H, EPS_R), rel=1e-6)
    # mounted at pre-stretch 1.2, released: at 0 V it shrinks back to its rest state, with or
    # without the (zero-voltage) dielectric
    x_none, s_none = dr_quarter_film(mu, H, 1.2, None)
    x_zero, _ = dr_quarter_film(mu, H, 1.2, 0.0)
    assert np.array_equal(x_none, x_zero) and s_none == pytest.approx(1 / 1.2, rel=1e-6)


def test_flattening_voltage_closed_form_and_sensitivities():
    """Table I's film (link-net law, E h = 0.05 N/mm, 150 %) loses its tension at
    V = sqrt(3/2 E h (lambda - 1) h / eps) (the FEM sweep of the strip DEMES ends flat at 6748 V)."""
    from validation.actuation.calibrate import fit_membrane_modulus, flattening_voltage, sensitivity

    scene = scenes.paper_demes(1.5, "strip")
    hand = np.sqrt(1.5 * 1.0 * 0.05 * 0.5 * 0.05 / (EPSILON_0 * 4.65))
    assert flattening_voltage(scene) == pytest.approx(hand, rel=1e-12)
    assert hand == pytest.approx(6748.4, abs=0.1)
    expected = {"membrane.E": 0.5, "loading.prestretch": 0.5 * 1.5 / 0.5, "membrane.thickness": 1.0,
                "frame.E": 0.0}
    for key, value in expected.items():
        assert sensitivity(scene, key) == pytest.approx(value, abs=1e-6)
    e_fit = fit_membrane_modulus(scene, 2250.0)
    assert e_fit == pytest.approx((2250.0 / hand) ** 2, rel=1e-9)


def test_the_closed_form_flattening_voltage_refuses_an_unequal_pair_and_takes_an_equal_one():
    """The closed form is that of an equibiaxially stretched film: an equal pair is the single
    pre-stretch to round-off, an unequal one (whose tensions vanish at two voltages) a
    SceneError naming loading.prestretch, before the calibration solves anything."""
    from validation.actuation.calibrate import fit, flattening_voltage

    scene = scenes.paper_demes(1.5, "strip")
    assert flattening_voltage(scene.updated(**{"loading.prestretch": [1.5, 1.5]})) == pytest.approx(
        flattening_voltage(scene), rel=1e-14)
    unequal = scene.updated(**{"loading.prestretch": [1.5, 1.2]})
    for call in (flattening_voltage, fit):
        with pytest.raises(scenes.SceneError, match=r"loading.prestretch = \[1.5, 1.2\]"):
            call(unequal)


def test_a_voltage_sweep_whose_prestretch_path_stopped_says_so_and_is_not_flat():
    """DR's pre-stretch path given too few time steps stops nearly flat, short of its
    pre-stretch: the voltage sweep reports that stop with its own status, not converged, and
    never as the regular flat end of an actuated DEMES (which the nearly flat state would pass
    for)."""
    import dr
    import scenes

    scene = scenes.paper_demes(1.2, "strip", **{"dr.membrane_net": "triangles", "mesh.divisions": 6,
                                                "dr.max_iterations": 20})
    states = list(dr.voltage_sweep(scene, [0.0, 500.0]))
    assert len(states) == 1
    (first,) = states
    assert not first.converged and first.status not in ("flat", "converged")
    assert not first.info["flat"] and "the pre-stretched state" in first.message
