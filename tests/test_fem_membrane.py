"""The FEM membrane: closed-form pre-stress, a pressurised square against the linear membrane
solution (and its convergence order), the patch test, and the tangent against finite differences."""

from __future__ import annotations

import numpy as np
import pytest
import triangle as tr
from skfem import Basis, ElementTriP1, ElementTriP2, ElementVector, LinearForm, MeshTri

from fem_reference.membrane import Membrane
from fem_reference.model import MembraneProblem
from fem_reference.newton import newton

E, H = 1.0, 0.05  # MPa, mm
JM = 10.0  # Gent's Jm: a strongly stiffening film (VHB about 33)
ELEMENTS = {"P1": ElementTriP1, "P2": ElementTriP2}


def prestress(law: str, lam: float) -> float:
    """Isotropic membrane tension (N/mm) of the flat pre-stretched state, by hand from W."""
    if law == "linear":  # sum_k m_k m_k^T = 3/2 I for three directions 60 deg apart
        return 1.5 * E * H * (lam - 1.0)
    neo = E / 3.0 * H * (lam**2 - lam**-4)  # mu h (lambda^2 - lambda^-4)
    return neo if law == "neo-hookean" else neo / (1.0 - (2 * lam**2 + lam**-4 - 3.0) / JM)


def square_membrane(n: int, element: str, law: str, tension_only: bool = True):
    mesh = MeshTri.init_tensor(np.linspace(0, 10.0, n + 1), np.linspace(0, 10.0, n + 1))
    basis = Basis(mesh, ElementVector(ELEMENTS[element](), 3))
    return Membrane(basis, law, E, H, tension_only, JM)


def pressure_centre_deflection(n: int, element: str, law: str, lam: float, p: float) -> float:
    mem = square_membrane(n, element, law)
    X = mem.X
    on_edge = (np.isclose(X[:, 0], 0) | np.isclose(X[:, 0], 10) | np.isclose(X[:, 1], 0)
               | np.isclose(X[:, 1], 10))
    loads = LinearForm(lambda v, w: p * v[2]).assemble(mem.basis)  # dead load p per flat area
    res = newton(MembraneProblem(mem, lam, on_edge, loads), X.ravel(), tol=1e-10)
    assert res.converged, res.status
    centre = np.argmin(np.linalg.norm(X[:, :2] - 5.0, axis=1))
    return res.y.reshape(-1, 3)[centre, 2]


def series_centre_deflection(a: float, T: float, p: float, terms: int = 201) -> float:
    """T lap(w) = -p on an a x a square, w = 0 on the edges: the double sine series at the centre."""
    m = np.arange(1, terms + 1, 2)
    M, N = np.meshgrid(m, m)
    signs = (-1.0) ** ((M - 1) // 2 + (N - 1) // 2)
    return float(16 * p * a**2 / (np.pi**4 * T) * np.sum(signs / (M * N * (M**2 + N**2))))


@pytest.mark.parametrize("law", ["linear", "neo-hookean", "gent"])
def test_flat_prestress_matches_closed_form(law):
    mem = square_membrane(4, "P1", law)
    lam = 1.4
    tensions, J = mem.principal_tensions(mem.X, lam)
    assert np.allclose(tensions, prestress(law, lam), rtol=1e-12)
    assert np.allclose(J, 1.0)


@pytest.mark.parametrize("law", ["linear", "neo-hookean"])
def test_pressurised_square_matches_linear_membrane(law):
    lam, p = 1.3, 1e-5  # centre deflection ~1e-3 mm on 10 mm: linear regime
    exact = series_centre_deflection(10.0, prestress(law, lam), p)
    w = pressure_centre_deflection(16, "P2", law, lam, p)
    assert w == pytest.approx(exact, rel=2e-3)


def test_pressurised_square_converges_at_second_order_with_p1():
    lam, p = 1.3, 1e-5
    exact = series_centre_deflection(10.0, prestress("linear", lam), p)
    errors = [abs(pressure_centre_deflection(n, "P1", "linear", lam, p) - exact) for n in (8, 16, 32)]
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all((orders > 1.8) & (orders < 2.3)), orders


def irregular_patch(element: str, law: str) -> Membrane:
    rng = np.random.default_rng(3)
    box = np.array([[0, 0], [6, 0], [6, 4], [0, 4]], float)
    inner = rng.uniform([0.5, 0.5], [5.5, 3.5], size=(12, 2))
    out = tr.triangulate({"vertices": np.vstack([box, inner]),
                          "segments": [[0, 1], [1, 2], [2, 3], [3, 0]]}, "pq25")
    mesh = MeshTri(out["vertices"].T.copy(), out["triangles"].T.copy())
    return Membrane(Basis(mesh, ElementVector(ELEMENTS[element](), 3)), law, E, H, True)


@pytest.mark.parametrize("element", ["P1", "P2"])
@pytest.mark.parametrize("law", ["linear", "neo-hookean"])
def test_patch_reproduces_homogeneous_deformation(element, law):
    mem = irregular_patch(element, law)
    lam = 1.2
    # a homogeneous stretch with shear, tilted out of the plane and moved
    R = np.array([[np.cos(0.4), 0, np.sin(0.4)], [0, 1, 0], [-np.sin(0.4), 0, np.cos(0.4)]])
    A = R @ np.array([[1.1, 0.15], [0.0, 0.95], [0.0, 0.0]])
    exact = mem.X[:, :2] @ A.T + [1.0, -2.0, 0.5]
    boundary = mem.basis.mesh.boundary_nodes()
    held = np.zeros(mem.n_nodes, bool)
    held[boundary] = True
    if element == "P2":  # edge nodes on the boundary too
        held[mem.basis.mesh.p.shape[1] + mem.basis.mesh.boundary_facets()] = True
    y0 = exact + 0.2 * np.random.default_rng(4).standard_normal(exact.shape)  # disturbed inside
    y0[held] = exact[held]
    res = newton(MembraneProblem(mem, lam, held, np.zeros(3 * mem.n_nodes)), y0.ravel(), tol=1e-11)
    assert res.converged
    assert np.abs(res.y.reshape(-1, 3) - exact).max() < 1e-9
    F = mem.deformation_gradient(res.y.reshape(-1, 3))
    assert np.abs(F - A[:, :, None, None]).max() < 1e-9


@pytest.mark.parametrize("element", ["P1", "P2"])
@pytest.mark.parametrize("law,tension_only", [("linear", True), ("linear", False), ("neo-hookean", False),
                                             ("gent", False)])
def test_tangent_and_forces_match_finite_differences(element, law, tension_only):
    mem = square_membrane(3, element, law, tension_only)
    rng = np.random.default_rng(7)
    x = mem.X + 0.15 * rng.standard_normal(mem.X.shape)  # large, partly compressed state
    lam = 1.3
    _, g, K = mem.evaluate(x, lam)
    v = rng.standard_normal(x.shape)
    h = 1e-6
    de = (mem.energy(x + h * v, lam) - mem.energy(x - h * v, lam)) / (2 * h)
    dg = (mem.evaluate(x + h * v, lam, 1)[1] - mem.evaluate(x - h * v, lam, 1)[1]) / (2 * h)
    assert de == pytest.approx(g @ v.ravel(), rel=1e-7)
    assert np.linalg.norm(dg - K @ v.ravel()) <= 1e-6 * np.linalg.norm(K @ v.ravel())
    assert abs(K - K.T).max() <= 1e-12 * abs(K).max()


def test_tension_only_film_carries_no_compression():
    mem = square_membrane(3, "P1", "linear", tension_only=True)
    lam = 1.2
    squeezed = mem.X * [0.7, 0.7, 1.0]  # 0.7 * 1.2 < 1: every link slack
    e, g, K = mem.evaluate(squeezed, lam)
    assert e == 0.0 and np.abs(g).max() == 0.0 and abs(K).max() == 0.0
