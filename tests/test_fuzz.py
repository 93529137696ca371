"""Fuzzing: random and hostile scenes, scene files, DR models and command lines end in a named
error (the project's DemesError) or a named status, never in a traceback from inside a
dependency, a hang, or NaN reported as converged.

The suite runs the 'ci' profile: few examples, derandomized, no example database, so a run is
reproducible and short. ``DEMES_FUZZ=long`` runs many more (outside the suite's budget), and
``pytest tests/test_fuzz.py --hypothesis-show-statistics`` counts the outcome classes.
"""

import dataclasses
import math
import os

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, event, given, settings
from hypothesis import strategies as st

import dr
import scenes
from dr.demes_model import build as build_dr
from dr.kernels import energy as dr_energy, gradient as dr_gradient
from fem_reference.model import DemesProblem
from scenes.members import crossings, member_joints, windows
from scenes.mesh import membrane_mesh
from scenes import DemesError, SceneError
from validation.cli import main

QUIET = [HealthCheck.too_slow, HealthCheck.function_scoped_fixture, HealthCheck.filter_too_much]
settings.register_profile("ci", max_examples=25, deadline=None, derandomize=True, database=None,
                          suppress_health_check=QUIET, phases=[Phase.explicit, Phase.generate, Phase.shrink])
settings.register_profile("long", max_examples=500, deadline=None, database=None, suppress_health_check=QUIET)
LONG = os.environ.get("DEMES_FUZZ") == "long"
settings.load_profile("long" if LONG else "ci")

NAMED_STATUSES = {"converged", "max_iterations", "diverged", "not_finite", "self_contact",
                  "membrane_fold", "film_contact", "unstable", "time_limit", "compression", "unreadable"}

BASE = scenes.load("demes_paper")
FIELDS = [f"{key}.{f.name}" for key, section in scenes.Scene.SECTIONS.items()
          for f in dataclasses.fields(section) if f.init]

hostile_numbers = st.sampled_from([0, -1, -0.0, 1e-300, 5e-324, 1e300, 10**30, -10**30, math.nan, math.inf,
                                   -math.inf, 2**63, 0.5, 1, 1.0, 2, 3, 4, 1e-9, 1e9, 1e-3, 0.999, 1.001])
hostile_values = st.one_of(
    hostile_numbers,
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-10**40, max_value=10**40),
    st.text(max_size=12),
    st.booleans(),
    st.none(),
    st.lists(st.one_of(hostile_numbers, st.lists(hostile_numbers, max_size=3)), max_size=5),
    st.dictionaries(st.text(max_size=3), hostile_numbers, max_size=2),
)


def settled(res) -> None:
    """A solver's state: a named status, and never NaN or inf called converged."""
    assert res.status in NAMED_STATUSES, res.status
    event(f"status {res.status}")
    if res.converged:
        assert np.all(np.isfinite(res.x)), res.message
        assert all(np.isfinite(v) for v in res.energy.values()), res.message
        if res.scene is not None:  # a converged state's angle is read, and says which way it went
            assert np.isfinite(res.bending_angle) and res.info["branch"] in ("up", "down", "flat"), res.message


@given(field=st.sampled_from(FIELDS + ["name", "description", "prestretch", "frame.colour"]), value=hostile_values)
def test_every_scene_field_is_checked(field, value):
    try:
        scene = BASE.updated(**{field: value})
    except SceneError:
        event("SceneError")
        return
    event("accepted")
    assert scene.mesh.divisions <= 400 and scene.prestretch <= 10.0


SHAPES = {
    "square": [[0, 0], [40, 0], [40, 40], [0, 40]],
    "L": [[0, 0], [40, 0], [40, 20], [20, 20], [20, 40], [0, 40]],
    "right triangle": [[0, 0], [40, 0], [0, 40]],
    "thin": [[0, 0], [60, 0], [30, 8]],
    "concave": [[0, 0], [40, 0], [40, 40], [20, 10], [0, 40]],
    "crossing": [[0, 0], [40, 40], [40, 0], [0, 40]],
    "collinear": [[0, 0], [20, 0], [40, 0], [20, 30]],
    "repeated": [[0, 0], [40, 0], [40, 0], [20, 30]],
}
outlines = st.one_of(
    st.sampled_from(list(SHAPES.values())),
    st.lists(st.tuples(*[st.integers(min_value=-3, max_value=3).map(lambda v: 10.0 * v)] * 2), min_size=3, max_size=6),
)


@given(vertices=outlines, radius=st.sampled_from([0.0, 0.5, 2.0, 2.1, 2.5, 3.0, 5.0, 8.0]),
       base=st.sampled_from(["taped", "pinned"]), model=st.sampled_from(["paper", "strip"]))
def test_degenerate_outlines_solve_or_are_refused(vertices, radius, base, model):
    """Square, L-shaped, right-triangle and self-crossing outlines, sharp or filleted, on a
    coarse mesh and a short path: a SceneError, or a named status with finite converged states
    (never 'converged' with all-NaN positions, as a sharp corner would give)."""
    try:
        scene = BASE.updated(**{"frame.outline": "polygon", "frame.vertices": [list(v) for v in vertices],
                                "frame.corner_radius": radius, "supports.base": base, "frame.model": model,
                                "mesh.divisions": 4, "dr.max_iterations": 3000, "dr.prestretch_step": 0.0,
                                "prestretch": 1.2})
    except SceneError:
        event("SceneError")
        return
    try:
        DemesProblem(scene, 0, "P1")  # the FEM's mesh and model of the same scene
    except DemesError:
        event("FEM refuses the scene")
    try:
        settled(dr.solve(scene))
    except DemesError:
        event("DR refuses the scene")


star_polygons = st.integers(min_value=3, max_value=8).flatmap(lambda n: st.tuples(
    st.lists(st.floats(min_value=1.0, max_value=2.0), min_size=n, max_size=n),
    st.lists(st.floats(min_value=20.0, max_value=40.0), min_size=n, max_size=n)))
"""Polygons of 3 to 8 vertices round the origin, 20 to 40 mm from it, the turn between two
neighbours 1 to 2 parts of the whole: simple, often concave, sides of many lengths (the scene
refuses those its fillets do not fit)."""


def star_vertices(gaps: list[float], radii: list[float]) -> list[list[float]]:
    """The polygon of :data:`star_polygons` (mm): vertex k at the angle of the first k gaps' share of a turn."""
    angles = 2.0 * math.pi * np.cumsum(gaps) / np.sum(gaps)
    return [[round(r * math.cos(a), 1), round(r * math.sin(a), 1)] for a, r in zip(angles, radii)]


PHYSICAL_STOPS = {"converged", "self_contact", "film_contact", "membrane_fold"}
"""How a DR path on a valid scene may end: at its target, or on a physical event."""


NETS = ["links", "clustered"] if LONG else ["links"]
"""The nets the polygon test throws at: the clustered net only in the long profile (40 examples
there, 4 in the suite's), since one of its membrane folds can take 100 s."""


@settings(max_examples=40 if LONG else 4)
@given(polygon=star_polygons, net=st.sampled_from(NETS))
def test_the_papers_nets_converge_or_stop_physically_on_any_polygon(polygon, net):
    """The paper's nets on drawn polygons (6 divisions, to 1.2 along the path, the default mass
    safety): a scene the checks accept ends converged or on contact or a fold, never diverged,
    out of iterations or non-finite (a stiffness bound too low would diverge)."""
    vertices = star_vertices(*polygon)
    try:
        scene = BASE.updated(**{"frame.outline": "polygon", "frame.vertices": vertices, "frame.corner_radius": 4.0,
                                "dr.membrane_net": net, "mesh.divisions": 6, "prestretch": 1.2})
    except SceneError:
        event("SceneError")
        return
    try:
        res = dr.solve(scene)
    except DemesError:
        event("DR refuses the scene")
        return
    settled(res)
    assert res.status in PHYSICAL_STOPS, res.message


member_ends = st.lists(st.tuples(st.integers(0, 15), st.sampled_from([-1, 0, 0, 0, 1]), st.floats(0.2, 0.8),
                                  st.floats(0.2, 0.8)), min_size=1, max_size=3)
"""Members as (side, offset, fraction, fraction): their ends on two straight pieces of the outline,
the second about halfway round from the first (``offset`` pieces off), at those fractions of
their lengths."""


@settings(max_examples=200 if LONG else 25)
@given(polygon=star_polygons, ends=member_ends, shift=st.sampled_from([0.0, 0.0, 0.5, -3.0]),
       opened=st.integers(0, 7))
def test_members_on_any_polygon_are_meshed_and_modelled_or_refused_by_name(polygon, ends, shift, opened):
    """Cross-members drawn between random points of a random polygon's outline (some moved off
    it): the scene refuses them with a SceneError naming frame.members, or the mesh holds every
    member as a straight line of edges from frame node to frame node with its bond nodes at the
    lever, and neither the FEM's model nor DR's carries a force in the flat state at no pre-stretch.
    With one of its windows open (``opened``), the same, and both solvers' flat pre-stretched
    energies are one discrete problem's."""
    vertices = star_vertices(*polygon)
    try:
        outline = BASE.updated(**{"frame.outline": "polygon", "frame.vertices": vertices, "frame.corner_radius": 4.0,
                                  "mesh.divisions": 6}).outline
    except SceneError:
        event("the outline is refused")
        return
    sides = [p for p in outline.pieces if p.radius == 0.0 and p.length > 0]
    opposite = [(i, i + len(sides) // 2 + offset) for i, offset, _, _ in ends]
    s_ends = [[sides[i % len(sides)].s_start + f * sides[i % len(sides)].length,
               sides[j % len(sides)].s_start + g * sides[j % len(sides)].length]
              for (i, j), (_, _, f, g) in zip(opposite, ends)]
    points = outline.evaluate(np.ravel(s_ends))[0].reshape(-1, 2, 2) + shift
    try:
        scene = BASE.updated(**{"frame.outline": "polygon", "frame.vertices": vertices, "frame.corner_radius": 4.0,
                                "mesh.divisions": 6, "frame.members": points.round(6).tolist(), "prestretch": 1.0})
        mesh = membrane_mesh(scene, 1)
    except SceneError as e:
        assert "frame.members" in str(e) or "bond line" in str(e), str(e)
        event("SceneError")
        return
    event(f"{len(mesh.members)} members meshed")
    found = windows(scene.outline, scene.frame.cross_members, scene.frame.width)
    point = found[opened % len(found)].buffer(-0.5 * scene.frame.width).representative_point()
    scene = scene.updated(**{"frame.open_windows": [[point.x, point.y]]})
    mesh = membrane_mesh(scene, 1)
    assert mesh.strip_band.any() and not mesh.strip_band.all()
    for chain, bonds in zip(mesh.members, mesh.member_bonds):
        p = mesh.nodes[chain]
        u = (p[-1] - p[0]) / np.linalg.norm(p[-1] - p[0])
        left = np.array([-u[1], u[0]])
        assert np.abs((p - p[0]) @ left).max() < 1e-9 * outline.side_length
        assert np.allclose((mesh.nodes[bonds] - p) @ left, scene.frame.lever, atol=1e-9 * outline.side_length)
        assert chain[0] in mesh.frame_nodes and chain[-1] in mesh.frame_nodes
    assert_one_flat_problem(scene)


def assert_one_flat_problem(scene) -> None:
    """Neither the FEM's model of ``scene`` nor DR's (triangles) carries a force in the flat state
    at no pre-stretch (the frame's bending and torsion energies zero), and pre-stretched to 1.2
    both store the same energy there."""
    problem = DemesProblem(scene, 0, "P1")
    flat = problem.evaluate(problem.X.ravel(), order=1)
    assert abs(flat.parts["frame_bending"]) + abs(flat.parts["frame_torsion"]) < 1e-20
    assert np.abs(flat.gradient.reshape(-1, 3)[~problem.held]).max() < 1e-9
    model = build_dr(scene.updated(**{"dr.membrane_net": "triangles"}), 1.0).model
    packed = model.pack()
    X = np.zeros((packed.n_total, 3))
    X[:packed.n] = model.nodes
    G = np.zeros_like(X)
    dr_gradient(X, packed, G, np.zeros((0, 6)))
    assert np.abs(G[:packed.n][~model.fixed]).max() < 1e-9
    stretched = scene.updated(**{"dr.membrane_net": "triangles", "prestretch": 1.2})
    packed = build_dr(stretched, 1.2).model.pack()
    problem = DemesProblem(stretched, 0, "P1")
    assert float(sum(dr_energy(X, packed))) == pytest.approx(problem.energy(problem.X.ravel()), rel=1e-12)


@settings(max_examples=100 if LONG else 12)
@given(width=st.floats(30.0, 80.0), height=st.floats(30.0, 80.0),
       ends=st.tuples(*[st.floats(0.2, 0.8)] * 4), turn=st.sampled_from([0, 1, 2, 3]))
def test_crossing_members_are_meshed_and_modelled_or_refused_by_name(width, height, ends, turn):
    """Two members across a rectangle, one between its left and right sides and one between its
    base and top (at random points, the rectangle's vertices listed from a random corner): refused
    with a SceneError naming frame.members, or crossing, the four points where their lines meet
    are nodes of both members' lines, a joint ties them, and both solvers' models of the flat
    state carry no force at no pre-stretch and store the same energy pre-stretched
    (:func:`assert_one_flat_problem`)."""
    corners = [[-width / 2, 0.0], [width / 2, 0.0], [width / 2, height], [-width / 2, height]]
    corners = corners[turn:] + corners[:turn]
    a, b, c, d = ends
    members = [[[-width / 2, a * height], [width / 2, b * height]], [[(c - 0.5) * width, 0.0], [(d - 0.5) * width, height]]]
    try:
        scene = BASE.updated(**{"frame.outline": "polygon", "frame.vertices": corners, "frame.corner_radius": 4.0,
                                "mesh.divisions": 6, "frame.members": members, "prestretch": 1.0,
                                "dr.membrane_net": "triangles"})
        mesh = membrane_mesh(scene, 1)
    except SceneError as e:
        assert "frame.members" in str(e) or "bond line" in str(e), str(e)
        event("SceneError")
        return
    found = crossings(scene.frame.cross_members, scene.frame.lever)
    event(f"{len(found)} crossings")
    for cross in found:
        for k in cross.pair:
            for line, quarter in zip((mesh.members[k], mesh.member_bonds[k]), cross.on(k)):
                near = np.linalg.norm(mesh.nodes[line][:, None] - cross.points[quarter, :][None], axis=2).min(axis=0)
                assert near.max() < 1e-9 * scene.outline.side_length
    joints = member_joints(mesh.frame_nodes, mesh.bond_nodes, mesh.members, mesh.member_bonds)
    assert len(joints) == 4 + len(found)
    assert_one_flat_problem(scene)


toml_texts = st.one_of(
    st.text(max_size=200),
    st.binary(max_size=200).map(lambda b: b.decode("latin-1")),
    st.integers(min_value=1, max_value=3000).map(lambda n: "x = " + "[" * n + "]" * n),
    st.integers(min_value=1, max_value=3000).map(lambda n: "x = " + "{a = " * n + "1" + "}" * n),
    st.sampled_from([
        "[frame]\nvertices = 0\noutline = 'polygon'", "[frame]\nvertices = [{x = 1}, {x = 2}, {x = 3}]",
        "[mesh]\ndivisions = 99999999999999999999", "[mesh]\ndivisions = 1e9", "[dr]\ntolerance = 5e-324",
        "[loading]\nprestretch = nan", "[loading]\nsweep = [inf]", "frame = 3", "[frame]\nE = 'stiff'",
        "name = '../../etc'", "[frame]\nside_length = 1e160",
    ]),
)


@given(text=toml_texts, raw=st.binary(max_size=40))
def test_scene_files_load_or_give_a_scene_error(tmp_path_factory, text, raw):
    folder = tmp_path_factory.mktemp("toml")
    for name, content in (("a.toml", text.encode("utf-8", "surrogatepass")), ("b.toml", raw)):
        path = folder / name
        path.write_bytes(content)
        try:
            scenes.load(path)
            event("loaded")
        except SceneError:
            event("SceneError")


def test_paths_that_are_not_scene_files_give_a_scene_error(tmp_path):
    for source in (tmp_path, tmp_path / ("x" * 5000), "a\0b", "", tmp_path / "missing.toml"):
        with pytest.raises(SceneError):
            scenes.load(source)


positions = st.integers(min_value=0, max_value=4).map(float)
node_lists = st.lists(st.tuples(positions, positions, positions), min_size=2, max_size=6)


@given(nodes=node_lists, data=st.data())
def test_random_dr_models_end_in_a_named_error_or_status(nodes, data):
    """Random small structures (coincident nodes, zero and huge stiffness, random starts)."""
    n = len(nodes)
    index = st.integers(min_value=0, max_value=n - 1)
    try:
        m = dr.Model(nodes)
        m.support(data.draw(st.lists(index, min_size=1, max_size=2)))
        m.add_link(np.arange(n - 1), np.arange(1, n), EA=1.0)  # a connected chain, then extras
        for _ in range(data.draw(st.integers(min_value=1, max_value=8))):
            kind = data.draw(st.sampled_from(["link", "cluster", "beam", "load"]))
            stiffness = data.draw(st.sampled_from([1.0, 1.0, 1.0, 100.0, 100.0, 1e-9, 1e12, 1e300, 0.0, -1.0, math.nan]))
            if kind == "link":
                i, j = data.draw(st.lists(index, min_size=2, max_size=2, unique=True))
                m.add_link(i, j, EA=stiffness,
                           tension_only=data.draw(st.booleans()))
            elif kind == "cluster":
                m.add_cluster(data.draw(st.lists(index, min_size=2, max_size=4, unique=True)), EA=stiffness)
            elif kind == "beam" and n >= 3:
                m.add_beam(data.draw(st.lists(index, min_size=3, max_size=4, unique=True)), EI=stiffness,
                           EA=data.draw(st.sampled_from([None, 100.0])))
            elif kind == "load":
                m.add_load(data.draw(index), data.draw(st.tuples(positions, positions, positions)))
        start = None
        if data.draw(st.booleans()):
            start = np.array(data.draw(st.lists(st.tuples(positions, positions, positions), min_size=n, max_size=n)))
        settled(dr.relax(m, x_start=start, max_iterations=3000,
                         mass_safety=data.draw(st.sampled_from([2.0, 1.0, 0.3]))))
    except dr.DRError:
        event("DRError")


cli_values = st.sampled_from(["1.1", "1.2", "nan", "inf", "-1", "0.5", "1e308", "abc", "1.1", "11"])
cli_sets = st.sampled_from(["mesh.divisions=1e999", "mesh.divisions=2", "dr.tolerance=1",
                            "frame.corner_radius=0", "frame.vertices=0", "nonsense", "frame=3",
                            "dr.mass_safety=0.5", "name=a/b", "x.y=1", "mesh.divisions=" + "9" * 5000,
                            "frame.E=" + "[" * 2000 + "]" * 2000, "fem.time_limit=-1", "frame.model=strip"])


@given(command=st.sampled_from(["solve", "fem"]), values=st.lists(cli_values, min_size=1, max_size=3),
       sets=st.lists(cli_sets, max_size=2), out_is_file=st.booleans())
def test_the_cli_exits_with_a_code_and_one_line(tmp_path_factory, capsys, command, values, sets, out_is_file):
    """Every project error is one line on stderr and exit code 2; what is accepted runs on a
    tiny mesh and a short path."""
    out = tmp_path_factory.mktemp("cli") / "out"
    if out_is_file:
        out.write_text("not a folder")
    # solve: DR on the one tiny mesh, as the FEM's command runs it
    argv = [command, *(["--solver", "dr", "--mesh-levels", "4"] if command == "solve" else []), "--prestretch", *values, "--out", str(out), "--no-progress",
            "--set", "mesh.divisions=4", "--set", "dr.max_iterations=2000", "--set", "dr.prestretch_step=0",
            "--set", "fem.time_limit=3"]
    for item in sets:
        argv += ["--set", item]
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse: a usage line and code 2
        code = exc.code
    err = capsys.readouterr().err
    assert code in (0, 2), err
    assert "Traceback" not in err
    if code == 2 and err.startswith("demes: "):
        assert len(err.strip().splitlines()) == 1
        event("named error")
    else:
        event(f"exit {code}")
