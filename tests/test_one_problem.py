"""DR membrane triangles and the FEM's discrete rod: exact gradients, and one discrete energy.

The DR triangle and rod elements are checked against finite differences of their own energies,
then against the FEM reference term by term (the same mesh, law, rod, bond and supports give
the same energy at any state), and finally the two solvers' equilibria against each other.
"""

import numpy as np
import pytest

import dr
import fem_reference
import scenes
from dr.kernels import energy
from fem_reference.model import DemesProblem
from scenes.mesh import membrane_mesh
from scenes.transfer import locate, transfer_linear
from test_dr_elements import fd_gradient, kernel_gradient


@pytest.mark.parametrize("law, tension_only", [("linear", True), ("linear", False), ("neo-hookean", False),
                                               ("gent", False)])
def test_triangle_forces_are_the_gradient_of_its_energy(law, tension_only):
    nodes = np.array([[0, 0, 0], [10, 0, 0], [5, 8, 0], [15, 8, 0], [-3, 7, 0]], float)
    m = dr.Model(nodes)
    m.support([0])
    m.add_triangles([[0, 1, 2], [1, 3, 2], [0, 2, 4]], E=1.0, thickness=0.05, prestretch=1.3,
                    law=law, tension_only=tension_only, gent_jm=10.0)  # a strongly stiffening Gent film
    x = nodes + np.random.default_rng(0).normal(scale=1.0, size=nodes.shape)
    g = kernel_gradient(m, x)
    assert np.abs(g).max() > 1e-3
    np.testing.assert_allclose(g, fd_gradient(m, x), atol=1e-7 * np.abs(g).max())


@pytest.mark.parametrize("strip", [True, False])
@pytest.mark.parametrize("closed", [True, False])
def test_rod_forces_are_the_gradient_of_its_energy(strip, closed):
    k = 9
    angle = np.linspace(0.0, 2 * np.pi, k, endpoint=False)
    ring = np.stack([np.cos(angle), np.sin(angle), np.zeros(k)], axis=1)
    nodes = np.vstack([10 * ring, 8 * ring])
    m = dr.Model(nodes)
    m.support([0, 1, 2])  # two held edges: their frames stay flat
    extra = dict(EI_strong=30.0, GJ=2.0, bond=np.arange(k, 2 * k)) if strip else {}
    m.add_rod(np.arange(k), EA=100.0, EI=1.5, closed=closed, **extra)
    x = nodes + np.random.default_rng(1).normal(scale=0.5, size=nodes.shape)
    x[:3] = nodes[:3]
    g = kernel_gradient(m, x)
    np.testing.assert_allclose(g, fd_gradient(m, x), atol=1e-7 * np.abs(g).max())


def _coarse(model: str, law: str = "linear", **changes) -> scenes.Scene:
    return scenes.paper_demes(prestretch=1.3, frame_model=model, **{
        "dr.membrane_net": "triangles", "mesh.divisions": 8, "membrane.law": law, "membrane.gent_jm": 10.0,
        **changes})


@pytest.mark.parametrize("model, law", [("strip", "linear"), ("paper", "linear"), ("strip", "neo-hookean"),
                                        ("strip", "gent")])
def test_dr_triangles_and_fem_have_one_energy(model, law):
    """At an arbitrary state the DR model and the FEM problem store the same energy, part by
    part: the same mesh, membrane law, rod, bond and supports."""
    assert_dr_and_fem_store_the_same_energy(_coarse(model, law, **{"frame.bond_lever": 1.5}), seed=2)


def assert_dr_and_fem_store_the_same_energy(scene: scenes.Scene, *, seed: int) -> DemesProblem:
    """DR's model and the FEM's P1 problem of ``scene`` have the same nodes and supports, and
    at a random state (normal, 0.2 mm, held nodes in place) the same energy part by part.
    Returns the FEM problem."""
    dm = dr.build(scene)
    pb = DemesProblem(scene, 0, "P1")
    np.testing.assert_allclose(dm.model.nodes, pb.X, atol=1e-12)
    np.testing.assert_array_equal(dm.model.fixed.all(axis=1), pb.held)
    x = pb.X + np.random.default_rng(seed).normal(scale=0.2, size=pb.X.shape)
    x[pb.held] = pb.X[pb.held]
    fem = pb.evaluate(x.ravel(), 1).parts
    P = dm.model.pack()
    X = np.zeros((P.n_total, 3))
    X[: P.n] = x
    for name, value in zip(("membrane", "frame_bending", "frame_torsion", "frame_axial"), energy(X, P)):
        assert value == pytest.approx(fem[name], rel=1e-12, abs=1e-12), name
    return pb


def test_the_mesh_is_shared_and_bond_nodes_sit_at_the_lever():
    scene = _coarse("strip", **{"frame.bond_lever": 1.5})
    for k in (0, 1):
        mesh = membrane_mesh(scene, k)
        fem = fem_reference.mesh.build_mesh(scene, k)
        np.testing.assert_allclose(mesh.nodes, fem.nodes, atol=1e-12)
        np.testing.assert_array_equal(mesh.frame_nodes, fem.frame_nodes)
        np.testing.assert_allclose(mesh.frame_bond, fem.frame_inner, atol=1e-12)
    # on the coarse mesh every bond node lies at the lever; refined ones halve its chords
    coarse = membrane_mesh(scene, 0)
    np.testing.assert_allclose(scene.outline.distance(coarse.frame_bond), 1.5, atol=1e-9)
    assert np.isin(coarse.bond_nodes, mesh.bond_nodes).all()


@pytest.mark.slow
def test_dr_triangles_and_fem_find_the_same_states():
    """Refinement 0 at 110, 130 and 150 %: the two solvers minimise one discrete energy, so
    their states agree to the solvers' tolerances (coarse mesh: the test budget)."""
    scene = _coarse("strip")
    side = scene.outline.side_length
    lams = [1.1, 1.3, 1.5]
    pairs = zip(dr.sweep(scene, lams), fem_reference.sweep(scene, lams, refinement=0))
    for d, f in pairs:
        assert d.converged and f.converged, (d.message, f.message)
        gap = d.x[d.frame_nodes] - f.x[f.frame_nodes]
        assert np.sqrt(np.mean(np.sum(gap**2, axis=1))) <= 1e-4 * side
        assert abs(d.bending_angle - f.bending_angle) <= 0.05
        assert d.energy["total"] == pytest.approx(f.energy["total"], rel=1e-5)
        assert f.bending_angle > 30.0  # a curled state, not the flat one


def test_a_refined_fem_state_is_a_dr_equilibrium_of_the_same_energy():
    """Refinement 1 (its Newton starts from the coarse state, transferred): the supports stay
    where they are, and DR started at the FEM's state stays there with the FEM's energy."""
    scene = _coarse("strip", **{"fem.refinement": 1})
    f = next(fem_reference.sweep(scene, [1.3], refinement=1))
    pb = DemesProblem(scene, 1, "P1")
    np.testing.assert_array_equal(f.x[pb.held], pb.X[pb.held])
    d = dr.solve(scene, 1.3, x_start=f.x, from_prestretch=1.3)
    assert d.converged and f.converged
    assert np.abs(d.x - f.x).max() <= 1e-6 * scene.outline.side_length
    for part in ("membrane", "frame_bending", "frame_torsion", "frame_axial", "total"):
        assert d.energy[part] == pytest.approx(f.energy[part], rel=1e-9, abs=1e-12), part


def test_bad_bond_and_unsupported_offset_are_named():
    with pytest.raises(scenes.SceneError, match="frame.bond_lever"):
        scenes.paper_demes(**{"frame.bond_lever": 5.0})
    with pytest.raises(scenes.SceneError, match="frame.bond_lever"):
        scenes.paper_demes(**{"frame.bond_lever": 0.0})
    with pytest.raises(scenes.SceneError, match="film_offset"):
        dr.build(_coarse("strip", **{"frame.film_offset": True}))


def test_linear_transfer_reproduces_an_affine_field_on_the_refined_mesh():
    """P1 interpolation is exact for an affine map of the flat coordinates, and so is its
    extension past the coarse mesh's straight edges to the refined outline nodes."""
    scene = _coarse("strip")
    coarse, fine = membrane_mesh(scene, 0), membrane_mesh(scene, 2)
    A = np.array([[1.1, 0.2], [-0.3, 0.9], [0.4, -0.7]])

    def affine(p):
        return p @ A.T + [1.0, -2.0, 3.0]

    outside = locate(coarse.nodes, coarse.triangles, fine.nodes)[1] != fine.nodes
    assert outside.any()  # the refined outline bulges past the coarse edges
    np.testing.assert_allclose(transfer_linear(coarse, affine(coarse.nodes), fine.nodes), affine(fine.nodes),
                               atol=1e-12 * scene.outline.side_length)


def test_the_adaptive_path_and_the_coarse_start_reach_the_fixed_paths_state():
    """Steps growing to dr.prestretch_step_max, and the default coarse start (the path on
    refinement 0, its state interpolated onto refinement 1 and relaxed there), end at the state
    the fixed path (fixed steps on refinement 1) ends at. Their gap shrinks with the tolerance (measured: 1e-3,
    5e-5, 2e-6 deg at 1e-6, 1e-7, 1e-8), so at 1e-8 it shows one equilibrium; the supports stay
    where they are."""
    scene = _coarse("strip", **{"fem.refinement": 1, "dr.tolerance": 1e-8})
    fixed = dr.solve(scene.updated(**{"dr.coarse_start": False}), 1.2)
    adaptive = dr.solve(scene.updated(**{"dr.coarse_start": False, "dr.prestretch_step_max": 0.1}), 1.2)
    started = dr.solve(scene, 1.2)
    held = dr.build(scene, 1.2).model.fixed.all(axis=1)
    assert fixed.bending_angle > 45.0  # the curled state, not the flat one
    assert adaptive.info["prestretch_steps"] < fixed.info["prestretch_steps"]
    assert 0 < started.info["coarse_iterations"] < started.iterations
    for res in (adaptive, started):
        assert fixed.converged and res.converged, (fixed.message, res.message)
        np.testing.assert_array_equal(res.x[held], fixed.x0[held])
        assert abs(res.bending_angle - fixed.bending_angle) <= 1e-4
        assert res.shape_error(fixed)[0] <= 1e-6
