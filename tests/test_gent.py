"""The Gent film (``membrane.law = "gent"``) in both solvers against its closed forms.

W = -mu h Jm / 2 ln(1 - (I1 - 3) / Jm): neo-Hookean as Jm -> infinity (the difference is
mu h / 4 (I1 - 3)^2 / Jm to first order), and for the free equibiaxial film under voltage the
ideal-dielectric closed form of validation.actuation.electromechanics, whose pull-in peak moves up for
moderate Jm and disappears for small Jm (the curve then rises monotonically to the lock). The
gradients are checked by finite differences in tests/test_one_problem.py (DR triangle) and
tests/test_fem_membrane.py (FEM law), the DR-FEM energy identity there too.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_actuation import EPS_R, FreeFilm, dr_quarter_film, coefficient, square_basis

import dr
from dr.kernels import energy as dr_energy
import scenes
from fem_reference.actuation import VoltagePath
from fem_reference.model import DemesProblem
from fem_reference.membrane import Membrane
from fem_reference.newton import newton
from scipy.optimize import brentq

from validation.actuation.electromechanics import (free_film_pull_in, free_film_stretch, free_film_voltage,
                                         gent_lock_stretch)

MU, H = 0.015, 0.1  # MPa, mm: the neo-Hookean free film pulls in near 1311 V


def test_gent_tends_to_neo_hookean_as_jm_grows():
    """FEM and DR triangle energies: (W_gent - W_neo) Jm tends to mu h / 4 (I1 - 3)^2 integrated."""
    basis = square_basis(2)
    x = Membrane(basis, "neo-hookean", 3 * MU, H, False).X
    rng = np.random.default_rng(11)
    y = x * 1.4 + 0.3 * rng.standard_normal(x.shape)
    neo = Membrane(basis, "neo-hookean", 3 * MU, H, False).energy(y, 1.2)
    scaled = []
    for jm in (1e2, 1e3, 1e4):
        gent = Membrane(basis, "gent", 3 * MU, H, False, jm)
        m = dr.Model(x)
        m.add_triangles(basis.mesh.t.T, E=3 * MU, thickness=H, prestretch=1.2, law="gent", gent_jm=jm)
        P = m.pack()
        assert dr_energy(y, P)[0] == pytest.approx(gent.energy(y, 1.2), rel=1e-12)
        scaled.append((gent.energy(y, 1.2) - neo) * jm)
    assert scaled[0] > 0  # Gent is stiffer
    # first-order convergence in 1 / Jm: the scaled differences settle to their limit
    assert abs(scaled[2] - scaled[1]) < 0.11 * abs(scaled[1] - scaled[0])
    assert scaled[2] == pytest.approx(scaled[1], rel=1e-2)


def test_free_gent_film_pull_in_moves_up_and_disappears():
    """Closed form: Jm = 10 peaks later and higher than neo-Hookean; Jm = 5 has no peak."""
    lam_n, v_n = free_film_pull_in(MU, H, EPS_R)
    lam_g, v_g = free_film_pull_in(MU, H, EPS_R, 10.0)
    assert lam_g > lam_n and v_g > v_n
    near = free_film_voltage(np.linspace(1.0001, lam_g + 0.2, 4001), MU, H, EPS_R, 10.0)
    assert near.max() <= v_g * (1 + 1e-9)  # the first peak
    assert free_film_voltage(2.5, MU, H, EPS_R, 10.0) > v_g  # it rises again before the lock (2.55)
    assert free_film_pull_in(MU, H, EPS_R, 5.0) is None
    v5 = free_film_voltage(np.linspace(1.0001, 1.99, 4001), MU, H, EPS_R, 5.0)
    assert np.all(np.diff(v5) > 0)


def _upper_branch_stretch(voltage: float, jm: float) -> float:
    """Equibiaxial stretch on the re-stiffened branch (past the valley, before the lock)."""
    lam = np.linspace(1.0001, gent_lock_stretch(jm) - 1e-6, 20001)
    valley = lam[np.argmin(np.where(lam > free_film_pull_in(MU, H, EPS_R, jm)[0],
                                    free_film_voltage(lam, MU, H, EPS_R, jm), np.inf))]
    return brentq(lambda l: free_film_voltage(l, MU, H, EPS_R, jm) - voltage, valley,
                  gent_lock_stretch(jm) - 1e-9, xtol=1e-14)


def test_fem_gent_free_film_matches_closed_form_and_snaps_through_at_the_moved_peak():
    """Jm = 10: the stable branch up to the (moved) peak, then the re-stiffened branch past it
    (the snap-through of Zhao, Hong & Suo 2007) instead of a pull-in."""
    jm = 10.0
    film = FreeFilm(2, MU, H, "gent", jm)
    lam_p, v_p = free_film_pull_in(MU, H, EPS_R, jm)
    for V in (0.5 * v_p, 0.95 * v_p):
        film.dielectric.coefficient = coefficient(V, H)
        start = film.X * free_film_stretch(0.8 * V, MU, H, EPS_R, jm)
        nr = newton(film, start.ravel(), tol=1e-10)
        assert nr.converged and nr.positive_definite
        assert film.stretch(nr.y) == pytest.approx(free_film_stretch(V, MU, H, EPS_R, jm), rel=1e-8)
    film.dielectric.coefficient = 0.0
    path = VoltagePath(film, film.X.ravel(), lambda v: coefficient(v, H), neutral=1e-12,
                       snap_iterations=30)
    _, stop = path.advance(0.999 * v_p, step=0.1 * v_p)
    assert stop is None
    assert film.stretch(path.y) == pytest.approx(free_film_stretch(0.999 * v_p, MU, H, EPS_R, jm), rel=1e-7)
    _, stop = path.advance(1.1 * v_p, step=0.1 * v_p)
    assert stop is None
    assert film.stretch(path.y) == pytest.approx(_upper_branch_stretch(1.1 * v_p, jm), rel=1e-7)


def test_small_jm_film_passes_the_neo_hookean_pull_in_in_both_solvers():
    jm = 5.0
    _, v_neo = free_film_pull_in(MU, H, EPS_R)
    V = 1.3 * v_neo
    expected = free_film_stretch(V, MU, H, EPS_R, jm)
    film = FreeFilm(2, MU, H, "gent", jm)
    path = VoltagePath(film, film.X.ravel(), lambda v: coefficient(v, H), neutral=1e-12,
                       snap_iterations=15)
    _, stop = path.advance(V, step=0.1 * v_neo)
    assert stop is None and path.voltage == pytest.approx(V)
    assert film.stretch(path.y) == pytest.approx(expected, rel=1e-7)
    _, stretch = dr_quarter_film(MU, H, 1.0, V, "gent", jm)
    assert stretch == pytest.approx(expected, rel=1e-6)


@pytest.mark.parametrize("value", [0.0, -3.0])
def test_bad_gent_jm_is_named(value):
    with pytest.raises(scenes.SceneError, match=r"membrane\.gent_jm") as info:
        scenes.paper_demes(**{"membrane.law": "gent", "membrane.gent_jm": value})
    assert "must be positive" in str(info.value)


def test_dr_states_of_a_gent_demes_are_fem_equilibria():
    """One discrete problem: DR's states of the strip DEMES with a Gent film at 150 % and 0 / 3 kV
    are equilibria of the FEM's energy (Newton from them stays put). (The FEM's own path may end
    on a neighbouring equilibrium: the film's compressed corners make them many.)"""
    scene = scenes.paper_demes(prestretch=1.5, frame_model="strip", **{
        "dr.membrane_net": "triangles", "mesh.divisions": 8, "membrane.law": "gent",
        "membrane.gent_jm": 10.0, "dr.tolerance": 1e-10})
    states = list(dr.voltage_sweep(scene, [0.0, 3000.0]))
    assert len(states) == 2 and states[1].bending_angle < states[0].bending_angle - 1.0
    for d in states:
        assert d.converged, d.message
        problem = DemesProblem(scene.updated(**{"loading.voltage": d.info["voltage_V"]}), 0, "P1")
        nr = newton(problem, d.x.ravel(), tol=1e-10)
        assert nr.converged and nr.iterations <= 3
        assert np.abs(nr.y - d.x.ravel()).max() <= 1e-6 * scene.outline.side_length
        # DR's total is the strain energy E_DR; the FEM's adds the dielectric's -E_cap
        assert problem.energy(d.x.ravel()) == pytest.approx(
            d.energy["total"] + d.info["electrostatic_energy"], rel=1e-10)
