"""The film's per-triangle fields (results.film): closed forms of flat stretched films, the
solvers' own laws at arbitrary deformations, and both solvers' ParaView output."""

import dataclasses
import warnings

import numpy as np
import pytest
import pyvista as pv

import dr
import fem_reference
import scenes
from dr.triangles import DIRECTIONS
from fem_reference.laws import LAW_IDS, point_stress, prestretch_row
from fem_reference.membrane import LATTICE_ANGLES_DEG as FEM_ANGLES
from fem_reference.model import DemesProblem
from results.film import (LATTICE_ANGLES_DEG, PARTLY_SLACK, SLACK, TAUT, FilmLaw, film_fields,
                          triangle_gradients)
from scenes.electric import EPSILON_0
from scenes.prestretch import PrestretchPath
from validation.cli import main
from validation.actuation.electromechanics import maxwell_stress

E, H, JM, EPS_R = 1.0, 0.05, 10.0, 4.65
FIELDS = ("stretch_1", "stretch_2", "cauchy_stress_1_MPa", "cauchy_stress_2_MPa", "thickness_mm",
          "slack_state", "maxwell_pressure_MPa")


def film(law: str, lam: float, tension_only: bool = True, voltage: float = 0.0) -> FilmLaw:
    return FilmLaw(law, E, H, lam, tension_only, JM, EPSILON_0 * EPS_R, voltage, H)


def fields(F, law, lam, **kw):
    return film_fields(np.asarray(F, float).reshape(-1, 3, 2), film(law, lam, **kw))


def in_plane(*diagonal):
    return np.diag(diagonal)[:, :2] if len(diagonal) == 3 else np.eye(3, 2) * diagonal


# ----------------------------------------------------------------------------- closed forms


@pytest.mark.parametrize("lam", [1.1, 1.5, 2.0])
@pytest.mark.parametrize("law", ["linear", "neo-hookean", "gent"])
def test_flat_equibiaxial_prestretch(law, lam):
    """No deformation from the mounted state: stretches lambda, thickness h0 / lambda^2 = h_m and
    the law's equibiaxial stress."""
    f = fields(np.eye(3, 2), law, lam)
    mu = E / 3
    sigma = {"linear": 1.5 * E * (lam - 1),
             "neo-hookean": mu * (lam**2 - lam**-4),
             "gent": mu * (lam**2 - lam**-4) / (1 - (2 * lam**2 + lam**-4 - 3) / JM)}[law]
    np.testing.assert_allclose([f["stretch_1"], f["stretch_2"]], lam, rtol=1e-14)
    np.testing.assert_allclose(f["thickness_mm"], (H * lam**2) / lam**2, rtol=1e-14)
    np.testing.assert_allclose([f["cauchy_stress_1_MPa"], f["cauchy_stress_2_MPa"]], sigma, rtol=1e-12)
    assert f["slack_state"][0] == TAUT and f["maxwell_pressure_MPa"][0] == 0.0


@pytest.mark.parametrize("law", ["neo-hookean", "gent"])
@pytest.mark.parametrize("s", [1.2, 2.0, 3.0])
def test_uniaxial_incompressible_film(law, s):
    """Uniaxial tension from rest (lambda = 1, lateral and thickness stretch 1/sqrt(s)): sigma_1 =
    mu f' (s^2 - 1/s), no lateral stress (one family slack), thickness h / sqrt(s)."""
    f = fields(in_plane(s, s**-0.5, 1.0), law, 1.0)
    x = s**2 + 2 / s - 3
    df = 1.0 if law == "neo-hookean" else 1 / (1 - x / JM)
    assert f["cauchy_stress_1_MPa"][0] == pytest.approx(E / 3 * df * (s**2 - 1 / s), rel=1e-12)
    assert abs(f["cauchy_stress_2_MPa"][0]) < 1e-12
    assert f["thickness_mm"][0] == pytest.approx(H / np.sqrt(s), rel=1e-14)
    assert (f["stretch_1"][0], f["stretch_2"][0]) == pytest.approx((s, s**-0.5), rel=1e-14)
    assert f["slack_state"][0] == PARTLY_SLACK


@pytest.mark.parametrize("angle", [0.0, 17.0, 60.0])
def test_uniaxial_linear_film_is_isotropic_with_poisson_one_third(angle):
    """At small strain the link-net law is the isotropic film E, nu = 1/3 (docs/elements.md): a
    uniaxial strain e with lateral -e/3 in any direction carries sigma_1 = E e, sigma_2 = 0."""
    e, a = 1e-6, np.radians(angle)
    R = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    F = np.eye(3, 2)
    F[:2] = R @ np.diag([1 + e, 1 - e / 3]) @ R.T
    f = fields(F, "linear", 1.0, tension_only=False)
    assert f["cauchy_stress_1_MPa"][0] == pytest.approx(E * e, rel=1e-5)
    assert abs(f["cauchy_stress_2_MPa"][0]) < 1e-5 * E * e


def test_slack_codes_of_the_linear_law():
    """Lattice families: all in tension (taut); 60 and 120 deg shortened (partly slack); all
    shortened (slack)."""
    F = np.stack([1.1 * np.eye(3, 2), in_plane(1.1, 0.9, 1.0), 0.9 * np.eye(3, 2)])
    f = film_fields(F, film("linear", 1.0))
    assert list(f["slack_state"]) == [TAUT, PARTLY_SLACK, SLACK]
    assert f["cauchy_stress_1_MPa"][2] == 0.0 and f["cauchy_stress_2_MPa"][2] == 0.0


@pytest.mark.parametrize("s", [1.0, 1.5])
def test_maxwell_pressure_is_eps_e_squared_on_the_current_thickness(s):
    """Flat film stretched equibiaxially by s from its mounted state: thickness h_m / s^2 and
    p = eps0 eps_r (V / h)^2."""
    f = fields(s * np.eye(3, 2), "neo-hookean", 1.3, voltage=3000.0)
    assert f["thickness_mm"][0] == pytest.approx(H / s**2, rel=1e-14)
    assert f["maxwell_pressure_MPa"][0] == pytest.approx(maxwell_stress(3000.0, H / s**2, EPS_R), rel=1e-12)


def test_rigid_motion_changes_nothing_and_the_incompressible_laws_are_isotropic():
    rng = np.random.default_rng(3)
    F = np.eye(3, 2) + 0.2 * rng.normal(size=(20, 3, 2))
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    a = 0.7
    R = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    for law in ("linear", "neo-hookean", "gent"):
        base = film_fields(F, film(law, 1.2))
        moved = film_fields(Q @ F, film(law, 1.2))
        for k in FIELDS:
            np.testing.assert_allclose(moved[k], base[k], rtol=1e-12, atol=1e-14, err_msg=k)
        if law != "linear":  # the lattice law has directions, the others none
            turned = film_fields(F @ R, film(law, 1.2))
            np.testing.assert_allclose(turned["cauchy_stress_1_MPa"], base["cauchy_stress_1_MPa"], rtol=1e-12)


# ----------------------------------------------------------------------------- the solvers' laws


def test_the_lattice_is_the_solvers_lattice():
    np.testing.assert_array_equal(LATTICE_ANGLES_DEG, FEM_ANGLES)
    np.testing.assert_allclose(np.column_stack([np.cos(np.radians(LATTICE_ANGLES_DEG)),
                                                np.sin(np.radians(LATTICE_ANGLES_DEG))]), DIRECTIONS, atol=1e-15)


@pytest.mark.parametrize("pair", [None, (1.3, 1.05)], ids=["isotropic", "unequal"])
@pytest.mark.parametrize("law, tension_only", [("linear", True), ("linear", False), ("neo-hookean", False),
                                               ("gent", False)])
def test_stress_is_the_fem_laws_p_ft_over_h(law, tension_only, pair):
    """At arbitrary deformations (some families compressed) the principal Cauchy stresses are
    those of P F^T / h_m with P = dW/dF of fem_reference.laws (the DR triangles' law too:
    tests/test_one_problem.py gives both one energy), at an isotropic and an unequal pre-stretch
    (axes turned by 25 deg): in-plane trace and determinant agree."""
    rng = np.random.default_rng(4)
    F = np.eye(3, 2) + 0.25 * rng.normal(size=(200, 3, 2))
    lam = 1.3
    path = PrestretchPath() if pair is None else PrestretchPath.of(pair, 25.0)
    P = point_stress(F, LAW_IDS[law], prestretch_row(path, lam), E, H, tension_only, JM)
    sigma = P @ np.swapaxes(F, 1, 2) / H  # (t, 3, 3), symmetric, normal component zero
    law_of_film = film(law, lam, tension_only)
    if pair is not None:
        law_of_film = dataclasses.replace(law_of_film, prestretch_tensor=path.tensor(lam))
    f = film_fields(F, law_of_film)
    s1, s2 = f["cauchy_stress_1_MPa"], f["cauchy_stress_2_MPa"]
    trace = np.trace(sigma, axis1=1, axis2=2)
    minors = 0.5 * (trace**2 - np.einsum("tij,tji->t", sigma, sigma))
    scale = np.abs(trace).max()
    np.testing.assert_allclose(s1 + s2, trace, atol=1e-11 * scale)
    np.testing.assert_allclose(s1 * s2, minors, atol=1e-11 * scale**2)
    assert np.all(s1 >= s2)


def test_triangle_gradients_of_an_affine_map():
    rng = np.random.default_rng(5)
    flat = rng.normal(size=(6, 2))
    tri = np.array([[0, 1, 2], [3, 4, 5], [1, 3, 5]])
    A = rng.normal(size=(3, 2))
    x = flat @ A.T + [1.0, 2.0, 3.0]
    np.testing.assert_allclose(triangle_gradients(flat, x, tri), np.broadcast_to(A, (3, 3, 2)), atol=1e-12)


def test_a_fem_p2_flat_prestretched_film_has_the_closed_form_fields():
    """The FEM evaluates its elements at their centroids: on the flat mounted state (x = X) of a
    P2 mesh (curved boundary elements) every element has F = I."""
    scene = scenes.paper_demes(prestretch=1.3, **{"mesh.divisions": 8, "membrane.law": "neo-hookean"})
    pb = DemesProblem(scene, 0, "P2")
    F = pb.membrane.centroid_gradient(pb.X)
    assert F.shape == (pb.mesh.cells.shape[0], 3, 2)
    np.testing.assert_allclose(F, np.broadcast_to(np.eye(3, 2), F.shape), atol=1e-12)
    f = film_fields(F, FilmLaw.of_scene(scene, pb.electrode_cover))
    np.testing.assert_allclose(f["cauchy_stress_1_MPa"], E / 3 * (1.3**2 - 1.3**-4), rtol=1e-10)
    np.testing.assert_allclose(f["thickness_mm"], scene.membrane.thickness, rtol=1e-12)


# ----------------------------------------------------------------------------- both solvers


def test_dr_triangles_and_the_fem_give_one_film_on_one_discrete_problem():
    """Refinement 0, P1, strip frame: DR's triangles and the FEM minimise one energy, so their
    film fields of the solved state agree element by element (to the states' agreement)."""
    scene = scenes.paper_demes(prestretch=1.2, frame_model="strip", **{
        "dr.membrane_net": "triangles", "mesh.divisions": 8})
    d = dr.solve(scene)
    f = next(fem_reference.sweep(scene, [1.2], refinement=0))
    assert d.converged and f.converged
    a, b = d.blocks["membrane_surface"], f.blocks["membrane"]
    np.testing.assert_array_equal(np.sort(a.connectivity, axis=1), np.sort(b.connectivity, axis=1))
    for k in FIELDS:
        np.testing.assert_allclose(a.cell_data[k], b.cell_data[k], rtol=1e-4, atol=1e-6, err_msg=k)
    assert np.ptp(a.cell_data["cauchy_stress_1_MPa"]) > 0.05  # a curled state, not the flat one


def _film_cells(path, time: float):
    """The cell data of the state at ``time`` in a .pvd series, and which cells are the film's
    (the only triangles: linear or quadratic)."""
    series = pv.get_reader(path)
    series.set_active_time_value(time)
    grid = series.read()[0]
    return grid.cell_data, np.isin(grid.celltypes, [pv.CellType.TRIANGLE, pv.CellType.QUADRATIC_TRIANGLE])


@pytest.mark.parametrize("command, label", [
    (["solve", "--solver", "dr", "--mesh-levels", "8"], "dr_strip"),
    (["solve", "--solver", "dr", "--mesh-levels", "8", "--set", "dr.membrane_net=links"], "dr_strip"),
    (["solve", "--mesh-levels", "8"], "fem_strip"),
    (["fem", "--set", "fem.element=P2", "--refinement", "0"], "fem_strip_r0"),
])
def test_paraview_reads_the_film_fields_from_the_pvd(tmp_path, capsys, command, label):
    out = tmp_path / "run"
    assert main([*command, "--prestretch", "1.1", "--set", "mesh.divisions=8", "--out", str(out),
                 "--no-progress"]) == 0
    cells, film_cells = _film_cells(out / f"{label}.pvd", 1.1)
    assert film_cells.sum() > 50
    for k in FIELDS:
        assert k in cells, k
        assert np.isfinite(cells[k][film_cells]).all(), k
    assert np.all(cells["stretch_1"][film_cells] >= cells["stretch_2"][film_cells])
    assert np.all(cells["cauchy_stress_1_MPa"][film_cells] > 0)
    assert set(np.unique(cells["slack_state"][film_cells])) <= {TAUT, PARTLY_SLACK, SLACK}
    assert np.all(cells["maxwell_pressure_MPa"][film_cells] == 0.0)  # no voltage


@pytest.mark.parametrize("solver", ["dr", "fem"])
def test_an_actuated_film_carries_its_maxwell_pressure(tmp_path, capsys, solver):
    """At V the film's pressure is eps0 eps_r (V / h)^2 on each element's own current thickness."""
    out = tmp_path / "act"
    assert main(["actuate", "--voltage", "0,1000", "--solver", solver, "--prestretch", "1.2",
                 "--set", "mesh.divisions=8", "--set", "dr.membrane_net=links", "--out", str(out),
                 "--no-progress"]) in (0, 2)
    pvd = next(out.rglob("*.pvd"))
    cells, film_cells = _film_cells(pvd, 1000.0)
    h = cells["thickness_mm"][film_cells]
    assert cells["maxwell_pressure_MPa"][film_cells].min() > 0
    np.testing.assert_allclose(cells["maxwell_pressure_MPa"][film_cells], EPSILON_0 * EPS_R * (1000.0 / h) ** 2,
                               rtol=1e-9)


@pytest.mark.parametrize("law", LAW_IDS)
def test_a_triangle_collapsed_in_a_fold_has_infinite_thickness_and_no_warning(law):
    """A fold collapses triangles to a line (F of rank 1, J = 0): the film there is infinitely
    thick (h / J) for every law, said in the field, not as a numpy warning on the console."""
    collapsed = np.array([[1.2, 0.6], [0.0, 0.0], [0.0, 0.0]])  # both edges along x
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        f = fields(collapsed, law, 1.2)
    assert f["thickness_mm"][0] == np.inf
