"""Scenes: geometry of the frame outline, landmarks, loading and round trips."""

import numpy as np
import pytest

import scenes
from scenes.geometry import Outline, equilateral_triangle


def test_paper_scene_holds_table_one():
    s = scenes.load("demes_paper")
    assert s.frame.EA == pytest.approx(2600 * 0.5)
    assert s.frame.EI == pytest.approx(2600 * 0.0003)
    assert s.frame.EI_strong == pytest.approx(2600 * 0.127 * 4.0**3 / 12)
    assert s.membrane.E == 1.0 and s.membrane.thickness == 0.05
    assert s.outline.side_length == pytest.approx(52.0)


def test_rounded_triangle_length_and_height():
    """Fillets of radius r replace each 120 deg-turn corner: length 3 (a - 2 sqrt3 r) + 2 pi r,
    and the apex drops by r (1/sin 30 - 1) = r."""
    a, r = 52.0, 5.0
    o = Outline(equilateral_triangle(a), r)
    assert o.length == pytest.approx(3 * (a - 2 * np.sqrt(3) * r) + 2 * np.pi * r, rel=1e-12)
    assert o.height() == pytest.approx(a * np.sqrt(3) / 2 - r, rel=1e-9)
    assert o.apex_arc_length() == pytest.approx(o.length / 2, rel=1e-6)


def test_the_node_nearest_the_apex_is_the_highest_mesh_frame_node():
    """Both solvers read the apex's side at this node: on the paper scene's mesh it is the frame
    node farthest from the base line (the apex is the highest outline point)."""
    from scenes.mesh import membrane_mesh

    scene = scenes.paper_demes(1.2, "strip", **{"mesh.divisions": 12})
    mesh = membrane_mesh(scene, 0)
    heights = mesh.nodes[mesh.frame_nodes, 1]
    assert scene.outline.nearest_to_apex(mesh.frame_s) == int(np.argmax(heights))


def test_outline_points_are_on_the_outline_with_unit_tangents():
    o = Outline(equilateral_triangle(52.0), 5.0)
    s = np.linspace(0, o.length, 997)
    p, t = o.evaluate(s)
    assert np.allclose(np.linalg.norm(t, axis=1), 1.0)
    # arc length is arc length: chord sums of a fine sampling add up to the length
    assert np.sum(np.linalg.norm(np.diff(np.vstack([p, p[:1]]), axis=0), axis=1)) == pytest.approx(o.length, rel=1e-4)
    assert np.allclose(o.distance(p), 0.0, atol=1e-3)


def test_line_crossings_lie_on_the_outline():
    o = Outline(equilateral_triangle(52.0), 5.0)
    t, s = o.intersect_line(np.array([0.0, 10.0]), np.array([1.0, 0.3]))
    assert t.size == 2
    points = np.array([0.0, 10.0]) + t[:, None] * np.array([1.0, 0.3]) / np.hypot(1, 0.3)
    assert np.allclose(o.evaluate(s)[0], points, atol=1e-9)


def test_any_polygon_is_put_base_down_and_counter_clockwise():
    square_cw = [[0, 0], [0, 10], [10, 10], [10, 0]]
    o = Outline(np.array(square_cw, float), 1.0)
    v = o.vertices
    assert np.allclose(v[0], [-5, 0]) and np.allclose(v[1], [5, 0])
    area2 = np.sum(v[:, 0] * np.roll(v[:, 1], -1) - np.roll(v[:, 0], -1) * v[:, 1])
    assert area2 > 0
    assert o.contains(np.array([[0.0, 5.0]]))[0] and not o.contains(np.array([[0.0, -1.0]]))[0]


def test_scene_round_trips_through_a_mapping():
    s = scenes.paper_demes(1.3, "strip", **{"mesh.divisions": 16})
    again = scenes.Scene.from_dict(s.to_dict())
    assert again.to_dict() == s.to_dict()
    assert again.prestretch == 1.3 and again.frame.model == "strip"


def test_landmarks_of_the_taped_base():
    s = scenes.load("demes_paper")
    s_right, s_left = s.base_region()
    (c1, t1), (c2, t2) = s.clamps()
    assert (c1, c2) == (s_right, s_left)
    # clamps sit where the base fillets meet the sides, tangents along the sides
    assert np.allclose(t1[:2], [-0.5, np.sqrt(3) / 2]) and np.allclose(t2[:2], [-0.5, -np.sqrt(3) / 2])
    pinned = s.updated(**{"supports.base": "pinned"})
    assert pinned.clamps() == [] and pinned.base_region()[0] < s_right


def curled_frame(scene, turn: float, y0: float = 2.0, radius: float = 5.0, samples: int = 400):
    """Frame points of ``scene``'s outline curled about the x axis: above y0 the midline turns by
    ``turn`` rad on a circle of ``radius`` and then runs straight (a tight curl near the base
    and a straight apex, the shape of a DEMES curled past 270 deg). Returns (points, arc
    lengths, apex angle atan2(dz, dy) in [0, 360) deg from the closed form)."""
    o = scene.outline
    s = np.linspace(0.0, o.length, samples, endpoint=False)
    xy = o.evaluate(s)[0]

    def midline(u):
        bent = np.minimum(u, turn * radius)
        straight = u - bent
        psi = bent / radius
        return (y0 + radius * np.sin(psi) + straight * np.cos(turn),
                radius * (1.0 - np.cos(psi)) + straight * np.sin(turn))

    u = np.clip(xy[:, 1] - y0, 0.0, None)
    y, z = midline(u)
    pts = np.column_stack([xy[:, 0], np.where(xy[:, 1] > y0, y, xy[:, 1]), z])
    ya, za = midline(np.array(o.height() - y0))
    return pts, s, np.degrees(np.arctan2(za, ya)) % 360.0


def test_bending_angle_is_continuous_past_270_degrees():
    """Ever tighter curls: the angle grows through 180 and 270 deg without a jump (it read -79
    for a 281 deg curl when it wrapped at 270)."""
    from results import Result

    scene = scenes.load("demes_paper")
    angles = []
    for turn in np.radians(np.linspace(0.0, 330.0, 34)):
        pts, s, closed_form = curled_frame(scene, turn)
        res = Result(solver="test", x=pts, x0=pts, converged=True, status="converged", message="",
                     iterations=0, residual=0.0, wall_time=0.0, energy={}, frame_nodes=np.arange(len(s)),
                     frame_s=s, scene=scene)
        theta = res.bending_angle
        assert theta % 360.0 == pytest.approx(closed_form, abs=0.05)
        angles.append(theta)
    assert angles[0] == pytest.approx(0.0, abs=1e-9) and max(angles) > 300.0
    assert np.all(np.diff(angles) > 0)
    # along a sweep, the turn nearest the previous state's angle
    res.info["previous_bending_angle"] = angles[-1] - 350.0
    assert res.bending_angle == pytest.approx(angles[-1] - 360.0)


def test_bending_angle_ignores_the_flat_base_stepping_back():
    """A taped base whose corner chords make the midline step back in the flat plane (as a
    coarse net's frame does) is no half turn: a 30 deg curl reads 30 deg, not 390."""
    from results import Result

    scene = scenes.load("demes_paper")
    pts, s, closed_form = curled_frame(scene, np.radians(30.0))
    corner = (pts[:, 1] > 0.5) & (pts[:, 1] < 1.5)  # in the taped fillets, below the curl
    pts[corner, 1] -= 0.4
    res = Result(solver="test", x=pts, x0=pts, converged=True, status="converged", message="",
                 iterations=0, residual=0.0, wall_time=0.0, energy={}, frame_nodes=np.arange(len(s)),
                 frame_s=s, scene=scene)
    assert res.bending_angle == pytest.approx(closed_form, abs=0.05)


def profiled_frame(scene, knots: np.ndarray, turn: float, radius: float = 5.0):
    """Frame points of ``scene``'s outline whose symmetric midline follows the polyline ``knots``
    (rows: reference height Y, y, z; mm) and then curls by ``turn`` rad on a circle of ``radius``
    and runs straight. Returns (points, arc lengths, the apex angle atan2(dz, dy) from the
    closed form, deg)."""
    o = scene.outline
    s = np.linspace(0.0, o.length, 2000, endpoint=False)
    xy = o.evaluate(s)[0]
    Y0, y0, z0 = knots[-1]
    d0 = np.arctan2(*(knots[-1, 2:0:-1] - knots[-2, 2:0:-1]))  # direction at the curl's start

    def midline(Y):
        u = np.clip(Y - Y0, 0.0, None)
        bent = np.minimum(u, turn * radius)
        psi = d0 + bent / radius
        y = y0 + radius * (np.sin(psi) - np.sin(d0)) + (u - bent) * np.cos(d0 + turn)
        z = z0 - radius * (np.cos(psi) - np.cos(d0)) + (u - bent) * np.sin(d0 + turn)
        return (np.where(Y < Y0, np.interp(Y, knots[:, 0], knots[:, 1]), y),
                np.where(Y < Y0, np.interp(Y, knots[:, 0], knots[:, 2]), z))

    y, z = midline(xy[:, 1])
    ya, za = midline(np.array(o.height()))
    return np.column_stack([xy[:, 0], y, z]), s, float(np.degrees(np.arctan2(za, ya)))


@pytest.mark.parametrize("curl", [60.0, 120.0])
def test_bending_angle_skips_a_lifted_base_stepping_back(curl):
    """A coarse taped base lifted 0.3 mm off the plane (a 4-division FEM state at 1.1 dips
    0.3 mm) whose midline steps forward, back (175 deg) and forward again (-10 deg): unwrapped,
    the second near half turn reads +175 and the angle a whole turn too many (50.3 deg read
    410.3). The turn is read from where the midline leaves the plane by 1e-2 of the side."""
    from results import Result

    scene = scenes.load("demes_paper")
    back, fore = np.radians(175.0), np.radians(-10.0)
    knots = np.array([[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [2.0, 2.0, 0.3], [2.5, 2.5, 0.3]])
    knots = np.vstack([knots, knots[-1] + [0.5, 0.5 * np.cos(back), 0.5 * np.sin(back)]])
    knots = np.vstack([knots, knots[-1] + [1.0, 1.0 * np.cos(fore), 1.0 * np.sin(fore)]])
    assert np.abs(knots[:, 2]).max() < 1e-2 * scene.outline.side_length
    pts, s, closed_form = profiled_frame(scene, knots, np.radians(curl))
    res = Result(solver="test", x=pts, x0=pts, converged=True, status="converged", message="",
                 iterations=0, residual=0.0, wall_time=0.0, energy={}, frame_nodes=np.arange(len(s)),
                 frame_s=s, scene=scene)
    assert 0.0 < closed_form < 180.0
    assert res.bending_angle == pytest.approx(closed_form, abs=0.05)
