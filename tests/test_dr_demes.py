"""DR on DEMES scenes: rest state, symmetry, contact detection, output files."""

import numpy as np
import pytest
import pyvista as pv

import dr
import scenes
from results import write_pvd

COARSE = {"mesh.divisions": 12}


def test_zero_prestretch_relaxes_back_to_flat_with_zero_energy():
    res = dr.solve(scenes.paper_demes(1.0, "strip", **COARSE))
    assert res.converged, res.message
    # the lift (0.5 mm at the apex) is gone; slack membrane nodes carry nothing either way
    assert np.abs(res.frame_curve()[:, 2]).max() < 1e-4
    assert res.energy["total"] < 1e-9
    assert abs(res.bending_angle) < 1e-3


def test_paper_frame_fillets_have_no_first_order_out_of_plane_stiffness():
    """The isotropic spline beam with rest curvature, M = EI (|kappa| - kappa_0), does not see
    a tilt of its curvature plane at first order: on the fillets an out-of-plane lift costs
    energy ~ lift^4. Relaxed at lambda = 1 from the scene's lift, the energy vanishes and the
    lift mostly, not exactly, goes."""
    scene = scenes.paper_demes(1.0, "paper", **COARSE)
    res = dr.solve(scene, x_start=dr.build(scene).start)
    assert res.converged, res.message
    assert res.energy["total"] < 1e-9
    lift = np.abs(res.frame_curve()[:, 2]).max()
    assert lift < 0.02 * scenes.paper_demes(1.0).perturbation.amplitude
    # the leftover sits on the apex fillet, not on the straight sides
    s_apex = res.scene.outline.apex_arc_length()
    s_at_max = res.frame_s[np.argmax(np.abs(res.frame_curve()[:, 2]))]
    assert abs(s_at_max - s_apex) < res.scene.frame.corner_radius * np.pi / 3


def test_pre_stretch_builds_the_rest_lengths():
    """At lambda the cables' rest lengths are their flat lengths / lambda: in the flat start
    every cable carries EA (lambda - 1), EA = E A inside the lattice (the boundary cables'
    carry the film of the frame's margin: tests/test_net_film.py)."""
    scene = scenes.paper_demes(1.25, **COARSE)
    built = dr.build(scene)
    P = built.model.pack()
    start = built.model.nodes
    seg = np.linalg.norm(start[P.clu_seg[:, 1]] - start[P.clu_seg[:, 0]], axis=1)
    length = np.bincount(P.clu_seg_cluster, weights=seg)
    tension = P.clu_EA / P.clu_L0 * (length - P.clu_L0)
    assert np.allclose(tension, P.clu_EA * 0.25)
    assert np.median(P.clu_EA) == pytest.approx(scene.membrane.E * built.cable_area)


def test_cable_area_is_the_film_at_the_papers_spacing():
    """A = sqrt(3)/2 h s gives Table I's 0.08 mm^2 at the paper's ~28 cables per side."""
    built = dr.build(scenes.paper_demes(1.5))
    assert built.cable_area == pytest.approx(0.08, rel=0.01)


def test_symmetric_scene_gives_a_mirror_symmetric_state():
    """Symmetric to within the solver's accuracy: the strip's mass blocks carry round-off
    that is not mirror-exact, so an unconverged remainder may be asymmetric; at tol 1e-8
    it is below 1e-5 mm (the lift is 0.5 mm)."""
    res = dr.solve(scenes.paper_demes(1.3, "strip", **COARSE, **{"dr.tolerance": 1e-8}))
    assert res.converged, res.message
    assert res.info["asymmetry_mm"] < 1e-5
    assert abs(res.apex[0]) < 1e-5


def test_a_stable_state_forgets_an_asymmetric_imperfection():
    """A 2 mm antisymmetric tilt of the start: the curled state is stable, so the ramped
    relaxation returns to the same symmetric state."""
    base = {**COARSE, "dr.tolerance": 1e-8}
    sym = dr.solve(scenes.paper_demes(1.3, "strip", **base))
    tilted = dr.solve(scenes.paper_demes(1.3, "strip", **base, **{"perturbation.asymmetry": 2.0}))
    assert sym.converged and tilted.converged
    assert tilted.info["asymmetry_mm"] < 1e-4
    assert tilted.bending_angle == pytest.approx(sym.bending_angle, abs=1e-3)
    assert sym.bending_angle > 45.0  # it is the curled state, not the flat one


def test_collapsing_paper_frame_stops_at_self_contact():
    """The isotropic frame of Table I with 150 % applied at once, as the paper did: its sides
    are pulled into each other. DR must stop there with a named reason, not pass through or
    return NaN."""
    res = dr.solve(scenes.paper_demes(1.5, "paper", **COARSE, **{"dr.prestretch_step": 0.0}))
    assert not res.converged
    assert res.status == "self_contact"
    assert "frame self-contact" in res.message and "lambda = 1.500" in res.message
    assert np.all(np.isfinite(res.x))


def test_clustered_net_folding_over_is_named():
    """The collapsing paper frame drags the clustered net into a state where its sliding nodes
    have passed each other: an equilibrium of cables over pulleys, not of a membrane."""
    res = dr.solve(scenes.paper_demes(1.3, "paper", **COARSE))
    assert res.status == "membrane_fold" and not res.converged
    assert "membrane folded over" in res.message


def test_fold_check_sees_a_folded_pair_of_triangles():
    x = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], float)
    check = dr.MembraneFold(np.array([[0, 1, 2], [1, 3, 2]]), x.copy())
    assert check(x) is None
    folded = x.copy()
    folded[3] = [-0.5, -0.5, 0.01]  # node 3 pushed through the edge 1-2: the second triangle flips
    assert "folded over" in check(folded)
    met = x.copy()
    met[3] = [1.0, 0.005, 0.0]  # node 3 slid onto node 1
    assert "nodes met" in check(met)


def test_frame_contact_check_sees_two_segments_meet():
    x = np.array([[0, 0, 0], [10, 0, 0], [10, 0.05, 0], [0, 0.05, 0]], float)
    check = dr.FrameContact(np.arange(4), distance=0.1, closed=False)
    assert check(x) is not None
    x[2:, 1] = 0.5
    assert check(x) is None


def test_a_segment_shorter_than_the_contact_distance_is_not_contact_but_a_fold_back_is():
    """A straight frame with a 0.05 mm segment (two landmarks of an outline close together):
    its neighbours are 0.05 mm apart, under the 0.1 mm contact distance, but the frame is
    straight, no contact; the same chain folded back at that segment (a hairpin) is contact.
    A closed chain is checked round its end too."""
    straight = np.array([[0, 0, 0], [10, 0, 0], [10.05, 0, 0], [20, 0, 0]], float)
    check = dr.FrameContact(np.arange(4), distance=0.1, closed=False)
    assert check(straight) is None
    hairpin = np.array([[0, 0, 0], [10, 0, 0], [10, 0.05, 0], [0, 0.05, 0]], float)
    assert check(hairpin) is not None
    square = np.array([[0, 0, 0], [10, 0, 0], [10, 10, 0], [0, 10, 0], [0, 0.05, 0]], float)
    assert dr.FrameContact(np.arange(5), distance=0.1)(square) is None  # 0.05 mm segment at the closure


def test_state_writes_vtk_that_pyvista_reads(tmp_path):
    res = dr.solve(scenes.paper_demes(1.2, "strip", **COARSE))
    path = res.write_vtk(tmp_path / "state.vtu")
    grid = pv.read(path)
    assert grid.n_points == res.x.shape[0]
    assert np.allclose(grid.points, res.x)
    for name in ("tension_N", "axial_force_N", "bending_moment_Nmm", "block"):
        assert name in grid.cell_data
    assert "displacement_mm" in grid.point_data and "bending_moment_Nmm" in grid.point_data
    # the membrane is also a surface of triangles
    assert np.any(grid.celltypes == pv.CellType.TRIANGLE)
    pvd = write_pvd(tmp_path / "sweep.pvd", [(1.2, path)])
    series = pv.get_reader(pvd)
    assert series.time_values == [1.2]


def test_a_sweep_ends_with_the_state_that_stopped_it_where_it_stopped():
    """The paper frame's net folds between 1.1 and 1.3: the stop is reported at the pre-stretch
    the path reached (not the one it was headed for), and nothing is solved past it."""
    states = list(dr.sweep(scenes.paper_demes(1.0, "paper", **COARSE), [1.1, 1.3, 1.5, 1.7]))
    *before, stop = states
    assert before and all(s.converged for s in before)
    assert stop.status == "membrane_fold"
    assert before[-1].prestretch < stop.prestretch <= 1.3
    assert stop.prestretch == stop.info["reached_prestretch"]
    assert f"lambda = {stop.prestretch:.3f}:" in stop.message
    if stop.prestretch < 1.3:
        assert "the requested lambda = 1.300 was not reached" in stop.message


def test_sweep_warm_starts_from_the_previous_state():
    scene = scenes.paper_demes(1.0, "strip", **COARSE)
    states = list(dr.sweep(scene, [1.1, 1.2]))
    assert [s.prestretch for s in states] == [1.1, 1.2]
    cold = dr.solve(scene, 1.2)
    assert states[1].converged and cold.converged
    # the warm start needs fewer steps than starting from flat
    assert states[1].iterations < cold.iterations
