"""Frames with windows: cross-members in the scene, the mesh and both solvers."""

import copy
import re

import numpy as np
import pytest
import shapely

import scenes
from scenes import Scene, SceneError
from scenes.members import crossings, member_joints, windows
from scenes.mesh import membrane_mesh

LADDER = {"name": "ladder", "frame": {"outline": "polygon", "vertices": [[-12, 0], [12, 0], [12, 90], [-12, 90]],
                                      "corner_radius": 3, "members": [[[-12, 30], [12, 30]], [[-12, 60], [12, 60]]]},
          "mesh": {"divisions": 6}}


def _scene(members, divisions=6):
    data = copy.deepcopy(LADDER)
    data["frame"]["members"] = members
    data["mesh"]["divisions"] = divisions
    return Scene.from_dict(data)


@pytest.mark.parametrize("members, words", [
    ([[[-12, 30], [11, 30]]], "frame.members[0] ends at [11, 30], 1 mm from the frame's outline"),
    ([[[-12, 30], [12, 30]], [[-12, 32], [12, 32]]], "frame.members[0] and frame.members[1] come closer"),
    ([[[-12, 30], [12, 36]], [[-12, 36], [12, 30]]], "frame.members[0] and frame.members[1] cross at 28.1 deg"),
    ([[[-12, 30], [12, 30]], [[-12, 34], [8, 0]]], "frame.members[0] and frame.members[1] cross at [-9.65, 30], where "
                                                   "their strips come 1.18 mm from the outline"),
    ([[[-12, 45], [12, 45]], [[-12, 30], [12, 60]], [[-12, 60], [12, 30]]],
     "frame.members: the crossings of members (0, 1) and (0, 2) are 0 mm apart"),
    ([[[-12, 10], [-12, 80]]], "frame.members[0] meets the outline at 0 deg"),
    ([[[-12, 30], [0, 90]]], "frame.members[0] meets the outline at 11.3 deg"),
    ([[[-12, 86], [12, 86]]], "frame.members: the window round [0, 88] is narrower than the strip"),
    ([[[-12, 30], [12]]], "frame.members[0][1] = [12]"),
    ("across", "frame.members must be a list"),
])
def test_members_a_scene_cannot_model_are_refused_by_name(members, words):
    with pytest.raises(SceneError, match="^" + re.escape(words)):
        _scene(members)


def test_members_leaving_a_concave_frame_are_refused():
    data = copy.deepcopy(LADDER)
    data["frame"]["vertices"] = [[-30, 0], [30, 0], [30, 60], [0, 20], [-30, 60]]
    data["frame"]["members"] = [[[-30, 50], [30, 50]]]
    with pytest.raises(SceneError, match=r"frame\.members\[0\] leaves the frame"):
        Scene.from_dict(data)


def test_members_survive_a_round_trip_and_cut_the_film_into_windows():
    scene = _scene(LADDER["frame"]["members"])
    again = Scene.from_dict(scene.to_dict())
    assert again.frame.members == scene.frame.members
    found = windows(scene.outline, scene.frame.cross_members, scene.frame.width)
    assert len(found) == 3
    film = shapely.Polygon(scene.outline.polyline(0.05)[0])
    assert sum(w.area for w in found) == pytest.approx(film.area, rel=1e-3)
    assert [round(w.centroid.y) for w in found] == [15, 45, 75]


@pytest.mark.parametrize("members", [[[[-12, 30], [12, 30]], [[-12, 60], [12, 60]]],
                                     [[[-12, 30], [12, 45]], [[0, 90], [12, 70]]],
                                     [[[-12, 30], [12, 60]], [[-12, 60], [12, 30]], [[-12, 75], [12, 75]]]])
def test_member_lines_are_straight_mesh_edges_with_bond_nodes_at_the_lever(members):
    """Each member's centreline is a line of mesh edges from frame node to frame node, its bond
    nodes lie frame.bond_lever to its left at every refinement, and refining only puts nodes
    between the coarse ones (nested meshes). Where two members cross, the four points where their
    lines meet are nodes of both, and a joint ties them there."""
    scene = _scene(members)
    lever = scene.frame.lever
    previous = None
    for k in range(3):
        mesh = membrane_mesh(scene, k)
        edges = {tuple(e) for e in np.sort(np.vstack([mesh.triangles[:, [0, 1]], mesh.triangles[:, [1, 2]],
                                                      mesh.triangles[:, [2, 0]]]), axis=1).tolist()}
        assert len(mesh.members) == len(members)
        for chain, bonds in zip(mesh.members, mesh.member_bonds):
            assert all((min(a, b), max(a, b)) in edges for a, b in zip(chain[:-1].tolist(), chain[1:].tolist()))
            assert chain[0] in mesh.frame_nodes and chain[-1] in mesh.frame_nodes
            p = mesh.nodes[chain]
            u = (p[-1] - p[0]) / np.linalg.norm(p[-1] - p[0])
            left = np.array([-u[1], u[0]])
            assert np.abs((p - p[0]) @ left).max() < 1e-12 * scene.outline.side_length
            assert np.all(np.diff((p - p[0]) @ u) > 0)
            assert np.allclose((mesh.nodes[bonds] - p) @ left, lever, atol=1e-12 * scene.outline.side_length)
        for cross in crossings(scene.frame.cross_members, lever):
            i, j = cross.pair
            lines = {k: (np.vstack([mesh.nodes[mesh.members[k]]]), mesh.nodes[mesh.member_bonds[k]]) for k in (i, j)}
            for k in (i, j):
                for row, quarter in zip(lines[k], cross.on(k)):
                    for q in quarter:
                        assert np.linalg.norm(row - cross.points[q], axis=1).min() < 1e-12 * scene.outline.side_length
        joints = member_joints(mesh.frame_nodes, mesh.bond_nodes, mesh.members, mesh.member_bonds)
        assert len(joints) == 2 * len(members) + len(crossings(scene.frame.cross_members, lever))
        if previous is not None:
            assert all(np.array_equal(fine[::2], coarse) for fine, coarse in zip(mesh.members, previous))
        previous = mesh.members


def test_a_frame_without_members_meshes_as_before():
    scene = scenes.load("square").updated(**{"mesh.divisions": 6})
    mesh = membrane_mesh(scene, 1)
    assert mesh.members == () and mesh.member_bonds == ()


def _rotation(angle: float, axis: np.ndarray) -> np.ndarray:
    axis = axis / np.linalg.norm(axis)
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def test_member_rods_and_joints_are_stress_free_flat_objective_and_have_exact_gradients():
    """The flat frame carries no frame energy; a rigid rotation of a bent state changes no
    frame energy (the joints measure relative rotations only); the gradient is the energy's
    derivative (central differences)."""
    from fem_reference.model import DemesProblem

    scene = _scene([[[-12, 30], [12, 45]], [[-12, 70], [12, 70]]])
    problem = DemesProblem(scene, 0, "P1")
    rods = problem.member_rods
    assert len(rods) == 6  # two members, two joints each
    X = problem.X
    assert all(abs(sum(r.evaluate(X, order=0)[0].values())) < 1e-20 for r in rods)
    rng = np.random.default_rng(3)
    x = X + np.where(problem.held[:, None], 0.0, 0.4 * rng.standard_normal(X.shape))
    Q = _rotation(0.7, np.array([1.0, -2.0, 0.5]))
    for rod in rods:
        e = sum(rod.evaluate(x, order=0)[0].values())
        assert e > 0
        assert sum(rod.evaluate(x @ Q.T + [3.0, -1.0, 2.0], order=0)[0].values()) == pytest.approx(e, rel=1e-9)
        _, g, _ = rod.evaluate(x, order=1)
        d = np.where(problem.held[:, None], 0.0, rng.standard_normal(X.shape))
        h = 1e-6
        slope = (sum(rod.evaluate(x + h * d, order=0)[0].values()) - sum(rod.evaluate(x - h * d, order=0)[0].values())) / (2 * h)
        assert slope == pytest.approx(g @ d.ravel(), rel=1e-6)


def test_the_paper_nets_refuse_members_by_name():
    import dr

    scene = scenes.load("multisegment_gripper").updated(**{"dr.membrane_net": "links"})
    with pytest.raises(SceneError, match="frame.members .* dr.membrane_net"):
        dr.solve(scene, 1.05)


def test_segment_turns_of_a_circular_arc_are_its_turn_shared_by_arc_length():
    """A frame bent to a circular arc (both sides on it, a base and a top across), turning
    `total` deg from the base to the apex: each segment between the given fractions of the way
    turns by its share of `total`, whatever the bounds; the whole turn is twice the bending angle."""
    from results.metrics import bending_angle, segment_turns

    R, half, total = 40.0, 5.0, 100.0
    phi = np.radians(np.linspace(0.0, total, 201))
    side = np.column_stack([R * np.sin(phi), R * (1 - np.cos(phi))])  # (y, z) along the arc
    top = np.linspace(half, -half, 21)[1:-1]
    base = np.linspace(-half, half, 21)[1:-1]
    x = np.vstack([np.column_stack([np.full(201, half), side]),
                   np.column_stack([top, np.tile(side[-1], (top.size, 1))]),
                   np.column_stack([np.full(201, -half), side[::-1]]),
                   np.column_stack([base, np.zeros((base.size, 2))])])
    arc = R * np.radians(total)
    s = np.concatenate([np.linspace(0, arc, 201), arc + half - top, arc + 2 * half + np.linspace(0, arc, 201),
                        2 * arc + 3 * half + base])
    s = np.mod(s + half, 2 * arc + 4 * half)  # from the base midpoint, counter-clockwise
    length, s_apex = 2 * arc + 4 * half, arc + 2 * half
    bounds = [0.3, 0.55]
    turns = segment_turns(x, s, length, s_apex, 2 * half, bounds)
    # the fraction t of the way to the apex is s / s_apex on the right side: the arc is t0..t1
    t0, t1 = half / s_apex, (arc + half) / s_apex
    expected = total * np.diff(np.clip((np.r_[0.0, bounds, 1.0] - t0) / (t1 - t0), 0, 1))
    assert turns == pytest.approx(expected, abs=0.5)
    assert turns.sum() == pytest.approx(2 * bending_angle(x, s, length, s_apex, 2 * half), abs=0.5)


def test_dr_and_the_fem_agree_on_a_frame_with_windows_and_one_window_driven_unbends_most():
    """The multi-segment gripper (two members, symmetric), coarsened: DR's triangles and the FEM
    P1 solve one discrete problem and end on one state at its pre-stretch, on the lift's side,
    energies within 1e-4. With its middle window's electrode driven to 3 kV, the middle segment
    unbends, more than the base and tip segments move either way, and the two solvers give each
    window's turn within 0.1 deg at every voltage, past the tip segment's snap near 2.4 kV too
    (DR's voltage steps follow the branch, as the FEM's continuation does)."""
    from fem_reference.actuation import voltage_sweep
    import dr

    scene = scenes.load("multisegment_gripper").updated(**{"mesh.divisions": 6})
    voltages = [0.0, 1500.0, 3000.0]
    fem = list(voltage_sweep(scene, voltages, 0, electrodes=["middle"]))
    relaxed = list(dr.voltage_sweep(scene, voltages, electrodes=["middle"]))
    assert all(r.converged for r in fem + relaxed)
    assert fem[0].branch == relaxed[0].branch == "up"
    assert relaxed[0].energy["total"] == pytest.approx(fem[0].energy["total"], rel=1e-4)
    assert fem[0].energy["frame_bending"] > 0 and "members" in fem[0].blocks and "members" in relaxed[0].blocks
    for a, b in zip(fem, relaxed):
        assert b.segment_turns == pytest.approx(a.segment_turns, abs=0.1)
    stroke = fem[0].segment_turns - fem[-1].segment_turns
    assert stroke[1] > 0 and abs(stroke[1]) > 3 * max(abs(stroke[0]), abs(stroke[2]))


def test_dr_and_the_fem_agree_on_a_frame_whose_members_cross():
    """A square frame with a cross of members (four windows, a rigid junction of four strips at
    its centre), P1 on 8 divisions: DR's triangles and the FEM solve one discrete problem (the
    same energy at the same positions) and, asked for 1.1 from flat at once, both locate where
    the flat state buckles (near 1.007) and end on one state on the lift's side, within 0.1 deg
    and 1e-6 in energy. Without the secant test (results.path.strayed) DR's step from 1.0175 to
    1.025 stopped on a nearer stable state of another branch, and it ended at 1.1 on that
    branch: 79.5 deg, E 1.4355 N mm against the FEM's 92.0 deg, 1.3988."""
    import dr
    import fem_reference
    from dr.demes_model import build as build_dr
    from dr.kernels import energy as dr_energy
    from fem_reference.model import DemesProblem
    from results.path import LOCATE

    scene = Scene.from_dict({"name": "cross", "frame": {
        "outline": "polygon", "vertices": [[-30, 0], [30, 0], [30, 60], [-30, 60]], "corner_radius": 4,
        "members": [[[-30, 30], [30, 30]], [[0, 0], [0, 60]]]}, "mesh": {"divisions": 8},
        "loading": {"prestretch": 1.1}, "dr": {"membrane_net": "triangles"}, "fem": {"element": "P1"}})
    levels = [1.1]
    fem = list(fem_reference.sweep(scene, levels))
    relaxed = list(dr.sweep(scene, levels))
    packed = build_dr(scene).model.pack()
    problem = DemesProblem(scene, 0, "P1")
    X = np.zeros((packed.n_total, 3))
    X[:packed.n] = fem[0].x
    assert float(sum(dr_energy(X, packed))) == pytest.approx(problem.energy(fem[0].x.ravel()), rel=1e-12)
    for a, b in zip(fem, relaxed):
        assert a.converged and b.converged and a.branch == b.branch == "up"
        assert b.bending_angle == pytest.approx(a.bending_angle, abs=0.1)
        assert b.energy["total"] == pytest.approx(a.energy["total"], rel=1e-6)
        (a0, a1), (b0, b1) = a.info["snaps"][0], b.info["snaps"][0]
        assert max(a0, b0) <= min(a1, b1) + 2 * LOCATE  # the same buckling, located in both


def test_dr_passes_a_saddle_too_weak_to_leave_and_meets_the_fem_on_a_frame_with_double_members():
    """The gripper's frame with two members 12 mm apart between its film windows (the gap
    covered, 8 divisions, P1): just past the flat state's buckling near 1.02 the saddle is so
    weak (w = -1.3e-7 in units of the masses) that the energy along its mode falls only within
    0.005 mm of it, and five pushes each relax back within 1e-9 mm. DR's path steps on from the
    pushed state instead of stopping 'unstable' at 1.0203, and at 1.1 both solvers are on one
    state (within 0.1 deg and 1e-6 in energy) on the lift's side."""
    import dr
    import fem_reference

    ys = [22, 34, 56, 68]
    bands = {"base": (0, 22), "middle": (34, 56), "tip": (68, 90)}
    scene = scenes.load("multisegment_gripper").updated(**{
        "frame.members": [[[-12, y], [12, y]] for y in ys], "fem.element": "P1",
        "electrodes": [{"name": k, "region": [[-12, a], [12, a], [12, b], [-12, b]]} for k, (a, b) in bands.items()]})
    (relaxed,) = list(dr.sweep(scene, [1.1]))
    (fem,) = list(fem_reference.sweep(scene, [1.1]))
    assert relaxed.converged and fem.converged and relaxed.branch == fem.branch == "up"
    assert relaxed.bending_angle == pytest.approx(fem.bending_angle, abs=0.1)
    assert relaxed.energy["total"] == pytest.approx(fem.energy["total"], rel=1e-6)
