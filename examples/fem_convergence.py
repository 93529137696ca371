"""Mesh convergence of the FEM reference: observed orders and the extrapolated reference.

Run:  python examples/fem_convergence.py [prestretch]  (several minutes: the finest level has
~28 000 unknowns per state). DEMES_QUICK=1 runs two levels of a coarse mesh in seconds (what the
tests do).

Prints, per quantity, the values on the nested meshes (element size halved each level), the
observed order, the Richardson extrapolation and its error estimate (GCI) - what the validation
calls "the reference".
"""

import os
import sys

import fem_reference
import scenes

quick = os.environ.get("DEMES_QUICK") == "1"
lam = float(sys.argv[1]) if len(sys.argv) > 1 else 1.3
scene = scenes.paper_demes(prestretch=lam, frame_model="strip", **({"mesh.divisions": 4} if quick else {}))
study = fem_reference.convergence_study(scene, lam, levels=(0, 1) if quick else (0, 1, 2), elements=("P1",))
print(study.table())
value, error, element = study.reference["bending_angle"]
print(f"\nreference bending angle at lambda = {lam:g}: {value:.3f} +- {error:.2g} deg ({element})")
