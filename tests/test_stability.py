"""DR's stability check (dr.stability) against Euler's column, and the DEMES leaving its flat saddle."""

import numpy as np
import pytest

import dr
import scenes
from dr import stability
from dr.saddles import leave_saddle

EA, EI, LENGTH = 1300.0, 0.78, 80.0
EULER = np.pi**2 * EI / LENGTH**2  # pinned-pinned buckling load, N


def compressed_column(load: float, n_seg: int = 40) -> tuple[dr.Model, np.ndarray]:
    """A straight pinned-pinned rod shortened to carry ``load`` (N), relaxed: its straight
    equilibrium (both ends held where the shortening puts them)."""
    x = np.zeros((n_seg + 1, 3))
    x[:, 0] = np.linspace(0.0, LENGTH, n_seg + 1)
    m = dr.Model(x)
    m.support([0, n_seg])
    m.add_rod(np.arange(n_seg + 1), EI=EI, EA=EA)
    start = x * [1.0 - load / EA, 1.0, 1.0]
    res = dr.relax(m, tol=1e-10, x_start=start)
    assert res.converged and res.info["masses"] == "frame", res.message
    return m, res.x


@pytest.mark.parametrize("fraction", [0.99, 1.01])
def test_the_straight_column_loses_stability_at_the_euler_load(fraction):
    """The lowest mode's stiffness changes sign within 1 % of pi^2 EI / L^2, and it is the
    half sine."""
    model, x = compressed_column(fraction * EULER)
    mode = stability.lowest_mode(model, x)
    assert mode.found
    assert (mode.eigenvalue > stability.NEUTRAL) if fraction < 1 else (mode.eigenvalue < -stability.NEUTRAL)
    lateral = np.linalg.norm(mode.shape[:, 1:], axis=1)
    sine = np.sin(np.pi * x[:, 0] / x[-1, 0])
    assert abs(lateral @ sine) / np.linalg.norm(lateral) / np.linalg.norm(sine) > 0.999
    assert np.abs(mode.shape[:, 0]).max() < 0.05  # it bends; it does not stretch


def test_the_lowest_mode_is_found_from_a_start_with_no_part_along_it():
    """The column just past Euler's load: its lowest mode (the half sine) is mirror-symmetric
    about the middle; from the antisymmetric full sine as the start, it is still the one
    found, with the eigenvalue the matrix-free Lanczos search finds."""
    model, x = compressed_column(1.01 * EULER)
    full_sine = np.zeros_like(x)
    full_sine[:, 1] = np.sin(2 * np.pi * x[:, 0] / x[-1, 0])
    mode = stability.lowest_mode(model, x, guess=full_sine)
    assert mode.found and mode.eigenvalue < -stability.NEUTRAL
    lateral = np.linalg.norm(mode.shape[:, 1:], axis=1)
    sine = np.sin(np.pi * x[:, 0] / x[-1, 0])
    assert abs(lateral @ sine) / np.linalg.norm(lateral) / np.linalg.norm(sine) > 0.999


def test_the_flat_demes_is_a_saddle_that_dr_leaves_apex_up():
    """The flat state at 110 % (in-plane equilibrium: the frame drawn in, out-of-plane
    displacements held at zero, then released) has a negative-stiffness mode, as the FEM
    finds; DR started there steps off it, apex up as the scene's perturbation asks, to a
    stable state of lower energy (at 8 divisions a shallower one, 20 deg, than the 50 deg the
    path from flat follows: the DEMES has more than one stable state)."""
    scene = scenes.paper_demes(1.1, "strip", **{"dr.membrane_net": "triangles", "mesh.divisions": 8})
    held = dr.build(scene)
    held.model.support(np.arange(held.model.n), "z")
    flat = dr.relax(held.model, tol=1e-8, x_start=held.model.nodes, masses="frame")
    assert flat.converged and np.abs(flat.x[:, 2]).max() == 0.0
    model = dr.build(scene).model
    saddle = stability.lowest_mode(model, flat.x)
    assert saddle.found and saddle.eigenvalue < -stability.NEUTRAL
    left = dr.solve(scene, x_start=flat.x, from_prestretch=1.1)
    assert left.converged and left.info["saddle_steps"] >= 1
    assert left.bending_angle > 1.0
    assert left.energy["total"] < flat.energy["total"]
    after = stability.lowest_mode(model, left.x)
    assert after.found and after.eigenvalue > stability.NEUTRAL


@pytest.mark.slow
def test_the_fine_link_net_solved_to_130_percent_in_one_call_ends_curled():
    """56 divisions, the link net, 1.0 -> 1.3 in one call: every nearly flat state on the way is
    relaxed to the full tolerance and checked for stability, so the path does not pile the load
    up on the flat saddle and snap to the low state; it ends curled, apex up, near the angle
    the 28-division net reaches (the same model, a coarser lattice)."""
    fine = dr.solve(scenes.paper_demes(1.3, "strip", **{"mesh.divisions": 56, "dr.membrane_net": "links"}))
    assert fine.converged, fine.message
    assert fine.info["branch"] == "up"
    coarse = dr.solve(scenes.paper_demes(1.3, "strip", **{"mesh.divisions": 28, "dr.membrane_net": "links"}))
    assert coarse.converged and coarse.info["branch"] == "up"
    assert abs(fine.bending_angle - coarse.bending_angle) < 10.0


def test_the_frame_mass_bounds_the_column_s_spectrum_and_holding_nodes_interlaces_it():
    """Below the Euler load: the largest w is at most 1 (the frame mass is at least f/2 K, f = 2:
    the step is stable), the smallest is the lowest mode's, and holding nodes (here every other
    one) narrows the spectrum from both ends (Cauchy's interlacing: a restriction of the
    Rayleigh quotient)."""
    model, x = compressed_column(0.5 * EULER)
    ends = stability.spectrum(model, x, tolerance=1e-8)
    assert ends.found
    assert 0.5 < ends.w_max <= 1.0 + 1e-6
    # to the noise of K's central differences (NEUTRAL, in units of the stiffest mode)
    assert ends.w_min == pytest.approx(stability.lowest_mode(model, x).eigenvalue, abs=stability.NEUTRAL)
    lateral = np.linalg.norm(ends.bottom[:, 1:], axis=1)
    sine = np.sin(np.pi * x[:, 0] / x[-1, 0])
    assert abs(lateral @ sine) / np.linalg.norm(lateral) / np.linalg.norm(sine) > 0.999
    held = np.zeros(model.n, dtype=bool)
    held[::2] = True
    inner = stability.spectrum(model, x, held=held, tolerance=1e-8)
    assert inner.found and ends.w_min <= inner.w_min and inner.w_max <= ends.w_max + 1e-9
    assert inner.w_min > 2 * ends.w_min  # the half sine is gone: the softest mode left is stiffer
    assert np.abs(inner.bottom[held]).max() == 0.0


def test_a_node_held_by_slack_cables_is_a_null_mode_not_a_saddle():
    """A node hung from a stable column by two slack tension-only cables carries no stiffness:
    the lowest mode is that node's, with a stiffness zero to the differences' round-off. It is
    no saddle, even for a path that knows its state fell off a symmetric one: the energy does
    not drop along it either way, so there is no side to leave by."""
    column, x = compressed_column(0.9 * EULER)
    n = column.n
    nodes = np.vstack([x, [[LENGTH / 2, 5.0, 0.0]]])
    model = dr.Model(nodes)
    model.support([0, n - 1])
    model.add_rod(np.arange(n), EI=EI, EA=EA)
    middle = n // 2
    model.add_link([middle, middle + 1], [n, n], EA=EA, rest_length=[10.0, 10.0], tension_only=True)
    start = nodes.copy()
    start[:n] = x
    mode = stability.lowest_mode(model, start)
    assert mode.found
    assert np.argmax(np.linalg.norm(mode.shape, axis=1)) == n
    assert abs(mode.eigenvalue) <= stability.ROUND_OFF
    assert not stability.is_negative(mode) and not stability.is_saddle(mode, 0.0)
    assert leave_saddle(model, start, mode, sign=1.0, size=1.0) is None
