"""The film's torque scales with its volume. Every film law stores W = E h w(F) per flat area and
every frame stiffness is linear in the frame's modulus, so scaling the film's thickness (its
volume, on a given planform) and the frame's modulus by one factor scales every force by it: the
same shapes along the same path, every energy part scaled by the factor. Put the other way, at a
given shape the torque the film puts on the frame is linear in the film's volume (Wang et al.,
Smart Mater. Struct. 2020). Both solvers, on the rectangular DEMES, its film pre-stretched
unequally."""

from __future__ import annotations

import pytest

import dr
import fem_reference
import scenes

FACTOR = 3.0


@pytest.mark.parametrize("solver", ["dr", "fem"])
def test_film_volume_and_frame_stiffness_scaled_together_keep_the_shape_and_scale_the_energies(solver):
    base = scenes.load("rectangular_demes").updated(**{"mesh.divisions": 6, "fem.element": "P1",
                                                       "dr.membrane_net": "triangles"})
    scaled = base.updated(**{"membrane.thickness": FACTOR * base.membrane.thickness,
                             "frame.E": FACTOR * base.frame.E})
    sweep = dr.sweep if solver == "dr" else fem_reference.sweep
    levels = [1.15]
    for a, b in zip(sweep(base, levels), sweep(scaled, levels)):
        assert a.converged and b.converged
        assert b.bending_angle == pytest.approx(a.bending_angle, abs=1e-6)
        assert abs(b.x - a.x).max() < 1e-7 * base.outline.side_length
        for part in ("membrane", "frame_bending", "frame_torsion", "total"):
            assert b.energy[part] == pytest.approx(FACTOR * a.energy[part], rel=1e-6, abs=1e-12), part
