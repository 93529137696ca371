"""The coupled DEMES model: tangent vs finite differences, rigid-body invariance, a solved state
(stable, symmetric, apex up, all result fields), contact detection, Richardson, bad input."""

from __future__ import annotations

import meshio
import numpy as np
import pytest
from scipy.spatial import cKDTree

import fem_reference
import scenes
from fem_reference.contact import frame_contact, segment_distances
from fem_reference.frame import Rod, RodProperties
from fem_reference.rod_kernels import PAPER, STRIP, split, vertex_normals, vertex_terms
from fem_reference.model import DemesProblem
from results import ENERGY_KEYS


def coarse(model: str = "strip", **changes) -> scenes.Scene:
    return scenes.paper_demes(1.2, model, **{"mesh.divisions": 6, **changes})


def random_state(pb: DemesProblem, amplitude: float, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    y = pb.initial_guess() + amplitude * rng.standard_normal(pb.n_dofs)
    fixed = np.setdiff1d(np.arange(pb.n_dofs), pb.free)
    y[fixed] = pb.reference()[fixed]
    return y


@pytest.mark.parametrize("element", ["P1", "P2"])
@pytest.mark.parametrize("model,offset,law,volts", [
    ("strip", True, "linear", 0.0), ("paper", True, "linear", 0.0), ("strip", False, "neo-hookean", 0.0),
    ("strip", True, "linear", 3000.0)])  # the offset map carries the dielectric's forces too
def test_coupled_tangent_matches_finite_differences(element, model, offset, law, volts):
    pb = DemesProblem(coarse(model, **{"frame.film_offset": offset, "membrane.law": law,
                                       "loading.voltage": volts}), 0, element)
    y = random_state(pb, 0.05)
    ev = pb.evaluate(y)
    rng = np.random.default_rng(1)
    v = np.zeros(pb.n_dofs)
    v[pb.free] = rng.standard_normal(pb.free.size)
    h = 1e-6
    de = (pb.energy(y + h * v) - pb.energy(y - h * v)) / (2 * h)
    dg = (pb.evaluate(y + h * v, 1).gradient - pb.evaluate(y - h * v, 1).gradient) / (2 * h)
    Kv = ev.tangent @ v
    assert de == pytest.approx(ev.gradient @ v, rel=1e-7)
    assert np.linalg.norm(dg - Kv) <= 1e-6 * np.linalg.norm(Kv)
    assert abs(ev.tangent - ev.tangent.T).max() <= 1e-10 * abs(ev.tangent).max()


@pytest.mark.parametrize("model", ["strip", "paper"])
def test_energy_is_invariant_under_rigid_motion(model):
    # membrane and a free (unsupported) rod with a film offset on the scene's mesh
    pb = DemesProblem(coarse(model, **{"frame.film_offset": True}), 0, "P2")
    fr = pb.scene.frame
    chain = pb.mesh.frame_nodes
    rod = Rod(pb.X, chain, True, np.zeros(pb.X.shape[0], bool),
              RodProperties(model, fr.EA, fr.EI, fr.EI_strong, fr.GJ),
              pb._directors(), fr.film_offset_distance)
    x = random_state(pb, 0.3, seed=2).reshape(-1, 3)
    angle = np.radians(140.0)
    axis = np.array([1.0, 2.0, 0.5]) / np.linalg.norm([1.0, 2.0, 0.5])
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    Q = np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K
    moved = x @ Q.T + [3.0, -7.0, 11.0]
    e0, g0, _ = rod.evaluate(x, order=1)
    e1, g1, _ = rod.evaluate(moved, order=1)
    for key in e0:
        assert e1[key] == pytest.approx(e0[key], rel=1e-10, abs=1e-14)
    assert np.allclose(g1.reshape(-1, 3), g0.reshape(-1, 3) @ Q.T, atol=1e-9 * np.abs(g0).max())
    m0 = pb.membrane.energy(x, 1.2)
    assert pb.membrane.energy(moved, 1.2) == pytest.approx(m0, rel=1e-12)


@pytest.fixture(scope="module")
def strip_states():
    return list(fem_reference.sweep(coarse("strip", **{"mesh.divisions": 8}), [1.0, 1.1]))


def test_flat_state_at_no_prestretch(strip_states):
    flat = strip_states[0]
    assert flat.converged and flat.prestretch == 1.0
    assert np.array_equal(flat.x, flat.x0) and flat.energy["total"] == 0.0


def test_solved_state_is_stable_symmetric_and_curls_up(strip_states):
    res = strip_states[1]
    assert res.converged and res.status == "converged", res.message
    assert res.residual < 1e-8
    assert res.info["stable"] and res.info["lowest_eigenvalue_N_per_mm3"] > 0
    assert 0.0 < res.bending_angle < 180.0  # apex up, as the perturbation asks
    # the scene and the mesh are mirror-symmetric (x -> -x) and so is the state
    x0 = res.x0
    _, mirror = cKDTree(x0).query(x0 * [-1.0, 1.0, 1.0])
    assert np.abs(res.x[mirror] * [-1.0, 1.0, 1.0] - res.x).max() < 1e-6
    # Newton ends quadratically: the last residual is at most a few times the square of the one
    # before (in units of the force scale), for every continuation step that took >= 3 steps,
    # away from where the path left the flat state (near a bifurcation the tangent is nearly
    # singular and Newton's constant, about 1 / its lowest eigenvalue, is large)
    left = max(b for _, b in res.info["snaps"])
    for step in res.info["newton"]:
        r = step["residuals"]
        if len(r) >= 3 and 1e-9 < r[-2] < 1e-3 and step["prestretch"] > left + 0.02:
            assert r[-1] <= 1e3 * r[-2] ** 2 + 1e-9, r


def test_result_fields_and_vtk(strip_states, tmp_path):
    res = strip_states[1]
    assert set(res.energy) == set(ENERGY_KEYS)
    assert res.energy["total"] == pytest.approx(sum(res.energy[k] for k in ENERGY_KEYS[:-1]))
    assert res.energy["frame_torsion"] > 0 and res.energy["membrane"] > 0
    s = res.frame_s
    assert s[0] == 0.0 and np.all(np.diff(s) > 0) and s[-1] < res.scene.outline.length
    assert np.allclose(res.x0[res.frame_nodes, :2], res.scene.outline.evaluate(s)[0])
    assert np.all(res.x0[:, 2] == 0.0)
    mesh = meshio.read(res.write_vtk(tmp_path / "state.vtu"))
    names = set(mesh.cell_data)
    for name in ("strain_energy_density_N_per_mm", "cauchy_stress_1_MPa",
                 "cauchy_stress_2_MPa", "thickness_mm", "bending_moment_N_mm", "axial_force_N"):
        assert name in names
    assert "displacement_mm" in mesh.point_data


def test_membrane_stress_of_flat_prestretch():
    # the flat state at lambda (frame held everywhere) carries the closed-form pre-stress
    pb = DemesProblem(coarse("strip"), 0, "P1")
    pb.lam = 1.3
    tensions, _ = pb.membrane.principal_tensions(pb.X, 1.3)
    assert np.allclose(tensions, 1.5 * 1.0 * 0.05 * 0.3)


def test_film_pull_acts_on_the_strip_at_the_film_offset_lever():
    """Pre-stretched film bonded on the strip's top face (offset d = t/2): through the offset map
    each frame node's film pull f acts on the strip as the couple d n x f, d |f| about the side
    (the moment of the forces it puts on the stencil points: centreline nodes and director
    points; n tilts by the film's lift over the lever, so to O(tilt^2)), and f
    is the film's pre-stress (T0 = 1.5 E h (lambda - 1) per unit length, here within the strain
    that the film's lift to z = d over the b/2 lever puts in it)."""
    lam = 1.3
    scene = coarse("strip", **{"frame.film_offset": True, "mesh.divisions": 8})
    pb = DemesProblem(scene, 0, "P1")
    pb.lam = lam
    x = pb.initial_guess(lift=False).reshape(-1, 3)
    xm, normals, ids = pb._film_positions(x)
    _, g_m, _ = pb.membrane.evaluate(xm, lam, 1)
    outline = scene.outline
    centre, tangent = outline.evaluate(np.array(outline.mid_height_arc_lengths()[:1]))
    t = np.r_[tangent[0], 0.0]
    ring = pb.mesh.frame_nodes
    chain = ring[pb.offset_nodes]
    along = (x[chain, :2] - centre[0]) @ t[:2]
    across = (x[chain, :2] - centre[0]) @ np.array([-t[1], t[0]])
    middle = np.flatnonzero((np.abs(along) < 12.0) & (np.abs(across) < 1e-9))
    pull = -g_m.reshape(-1, 3)[chain[middle]]  # the film's force on the strip (N)
    pos = pb.offset_nodes[middle]  # chain positions: half the chords to both neighbours
    tributary = 0.5 * np.linalg.norm(x[ring[(pos + 1) % ring.size]] - x[ring[pos - 1]], axis=1)
    T0 = 1.5 * scene.membrane.E * scene.membrane.thickness * (lam - 1.0)
    tilt = pb.offset / (0.5 * scene.frame.width)
    assert np.linalg.norm(pull, axis=1) == pytest.approx(T0 * tributary, rel=5 * tilt**2)
    d, points = pb.offset, pb.rod.B @ x
    for k, f in zip(middle, pull):
        forces = d * np.einsum("c,cj->j", f, normals.grad[k]).reshape(-1, 3)  # on the 5 stencil points
        couple = np.cross(points[ids[k]], forces).sum(axis=0)
        assert couple == pytest.approx(d * np.cross(normals.val[k], f), rel=1e-9, abs=1e-12 * d * np.linalg.norm(f))
        assert abs(couple @ t) == pytest.approx(d * np.linalg.norm(f), rel=tilt**2)  # lever d, about the side
        assert np.abs(forces.sum(axis=0)).max() < 1e-12 * np.linalg.norm(f)  # a pure couple


def test_frame_contact_finds_a_crossing_and_ignores_a_circle():
    t = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    circle = np.column_stack([np.cos(t), np.sin(t), np.zeros_like(t)])
    held = np.zeros(t.size, bool)
    assert frame_contact(circle, held, 0.01) is None
    eight = np.column_stack([np.sin(t), np.sin(t) * np.cos(t), 0.001 * np.cos(t)])
    found = frame_contact(eight, held, 0.01)
    assert found is not None and found.value < 0.01 and np.linalg.norm(found.where) < 0.05


def _hairpin(gap: float, h: float) -> np.ndarray:
    """A closed loop of segments about h long: two 2 mm legs ``gap`` apart joined by a half
    circle of diameter ``gap``, and closed round a 2 mm square at the other end."""
    def line(p, q):
        n = max(1, int(np.ceil(np.linalg.norm(np.subtract(q, p)) / h)))
        return np.linspace(p, q, n, endpoint=False)
    turn = np.linspace(-np.pi / 2, np.pi / 2, max(3, int(np.ceil(np.pi * gap / 2 / h))), endpoint=False)
    corners = [(0, gap), (0, 1), (-1, 1), (-1, -1), (0, -1), (0, 0)]
    xy = np.concatenate([line((0, 0), (2, 0)),
                         np.column_stack([2 + 0.5 * gap * np.cos(turn), 0.5 * gap + 0.5 * gap * np.sin(turn)]),
                         line((2, gap), (0, gap))] + [line(p, q) for p, q in zip(corners, corners[1:])])
    return np.column_stack([xy, np.zeros(len(xy))])


@pytest.mark.parametrize("h", [0.02, 0.005])
def test_frame_contact_is_independent_of_the_segment_length(h):
    """Segments shorter than the contact distance do not touch their neighbours' neighbours; two
    legs closer than it are in contact, farther apart they are not, at any segment length."""
    t = 0.127
    held = np.zeros(2, bool)
    for gap, touching in ((0.8 * t, True), (1.2 * t, False)):
        loop = _hairpin(gap, h)
        found = frame_contact(loop, np.resize(held, len(loop)), t)
        assert (found is not None) == touching
        if touching:
            assert found.value == pytest.approx(gap, rel=1e-6)


def test_segment_distance_against_sampling():
    rng = np.random.default_rng(5)
    p0, p1, q0, q1 = rng.standard_normal((4, 50, 3))
    d, _ = segment_distances(p0, p1, q0, q1)
    u = np.linspace(0, 1, 401)
    P = p0[:, None] + u[None, :, None] * (p1 - p0)[:, None]
    Q = q0[:, None] + u[None, :, None] * (q1 - q0)[:, None]
    brute = np.linalg.norm(P[:, :, None] - Q[:, None, :], axis=3).min(axis=(1, 2))
    assert np.all(d <= brute + 1e-12) and np.all(brute - d < 1e-4)


@pytest.mark.parametrize("model", [PAPER, STRIP])
def test_rod_stencil_derivatives_match_finite_differences(model):
    """The compiled forward-mode derivatives of the vertex energies and strip normals against
    central differences of the values (one stencil with a held edge, one free)."""
    rng = np.random.default_rng(6)
    S = 2
    P = np.array([[-1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [1.0, 0.2, 0.0], [-0.5, 1.0, 0.0], [0.5, 1.0, 0.0]])
    P = P + 0.2 * rng.standard_normal((S, 5, 3))
    held_a, held_b = np.array([True, False]), np.zeros(S, bool)
    rest = np.tile(np.eye(3), (S, 1, 1))
    kappa0 = 0.1 * rng.standard_normal((S, 3))
    w = np.array([0.7, 1.3])

    def energy(Q, order):
        _, b, t = vertex_terms(Q, held_a, held_b, rest, rest, kappa0, w, model, 2.0, 5.0, 1.5, True, order)
        return b + t

    def normals(Q, order):
        return vertex_normals(Q, held_a, held_b, rest, rest, order)

    h = 1e-5
    for f in (energy, normals):
        jets = split(f(P, 2))
        for i in range(15):
            e = np.zeros(15)
            e[i] = h
            up, down = P + e.reshape(5, 3), P - e.reshape(5, 3)
            assert np.allclose((f(up, 0)[..., 0] - f(down, 0)[..., 0]) / (2 * h), jets.grad[..., i], atol=1e-7)
            assert np.allclose((split(f(up, 2)).grad - split(f(down, 2)).grad) / (2 * h), jets.hess[..., i],
                               atol=1e-6)


def test_richardson_recovers_order_and_limit():
    q = [7.0 + 3.0 * h**1.5 for h in (1.0, 0.5, 0.25)]
    est = fem_reference.richardson(q)
    assert est.observed and est.order == pytest.approx(1.5)
    assert est.extrapolated == pytest.approx(7.0, abs=1e-12)
    assert est.error == pytest.approx(1.25 * abs(7.0 - q[-1]), rel=1e-12)


@pytest.mark.parametrize("changes,field", [
    ({"refinement": -1}, "fem.refinement"),
    ({"prestretches": [0.8]}, "pre-stretch"),
])
def test_bad_input_names_the_field(changes, field):
    scene = coarse()
    with pytest.raises(scenes.SceneError, match=field):
        list(fem_reference.sweep(scene, changes.get("prestretches", [1.1]), changes.get("refinement")))


def test_neo_hookean_compression_is_measured():
    from fem_reference.output import compressed_fraction, slack_fractions

    pb = DemesProblem(coarse("strip", **{"membrane.law": "neo-hookean"}), 0, "P1")
    pb.lam = 1.3
    flat = pb.reference()
    assert compressed_fraction(pb, flat) == 0.0
    squeezed = (pb.X * [0.6, 0.6, 1.0]).ravel()  # 0.6 * 1.3 < 1: compressed everywhere
    assert compressed_fraction(pb, squeezed) == pytest.approx(1.0)
    lin = DemesProblem(coarse("strip"), 0, "P1")
    lin.lam = 1.3
    assert slack_fractions(lin, squeezed) == pytest.approx((1.0, 1.0))
    assert slack_fractions(lin, flat) == (0.0, 0.0)
    # the lattice families at 0, 60 and 120 deg: squeezed across the base, the inclined ones
    # stretch by 1.3 |(0.5, 0.866 f)|, taut for f = 0.7 (1.02) and slack for f = 0.5 (0.86)
    one_way = (pb.X * [1.0, 0.7, 1.0]).ravel()
    assert slack_fractions(lin, one_way) == (0.0, 0.0)
    across = (pb.X * [1.0, 0.5, 1.0]).ravel()
    assert slack_fractions(lin, across) == pytest.approx((1.0, 0.0))


def test_a_spent_time_limit_stops_the_path_with_a_named_status():
    scene = scenes.paper_demes(1.3, "strip", **{"mesh.divisions": 8, "fem.time_limit": 1e-6})
    res = fem_reference.solve(scene)
    assert res.status == "time_limit" and not res.converged
    assert res.prestretch == 1.0  # the last state the path reached: the flat one
    assert "fem.time_limit" in res.message and "the requested lambda = 1.300 was not reached" in res.message


def test_solve_from_a_state_of_the_path_stays_there_and_names_bad_starts():
    """Newton from the path's own converged state stays on it (the polish of a DR state);
    a start of the wrong shape is refused with the argument named."""
    scene = coarse("strip")
    path = fem_reference.solve(scene, refinement=0)
    again = fem_reference.solve_from(scene, path.x, refinement=0)
    assert again.converged and again.info["stable"]
    assert np.abs(again.x - path.x).max() < 1e-8 * scene.outline.side_length
    assert again.iterations <= 3
    with pytest.raises(scenes.SceneError, match="x_start"):
        fem_reference.solve_from(scene, path.x[:-1], refinement=0)


def test_a_state_does_not_depend_on_what_the_process_solved_before():
    """The same sweep before and after another problem of the same size (a thicker strip on the
    same mesh) gives the same bits: the factorisation's ordering is made for each matrix's own
    structure, not for the structures earlier problems left behind (a worker process and this
    one then agree to the last bit)."""
    scene = scenes.load("demes_paper").updated(**{"mesh.divisions": 8, "fem.element": "P1"})
    path = [1.0, 1.15, 1.3]
    first = [res.x.copy() for res in fem_reference.sweep(scene, path)]
    list(fem_reference.sweep(scene.updated(**{"frame.thickness": 0.381}), path))
    again = [res.x for res in fem_reference.sweep(scene, path)]
    for a, b in zip(first, again):
        assert np.array_equal(a, b)
