"""Finite-element reference for DEMES form-finding (scikit-fem), independent of the DR solver.

>>> import scenes, fem_reference
>>> scene = scenes.paper_demes(prestretch=1.3, frame_model="strip")
>>> res = fem_reference.solve(scene, refinement=1)        # continuation from lambda = 1 inside
>>> for res in fem_reference.sweep(scene, [1.1, 1.3, 1.5]):
...     print(res.prestretch, res.bending_angle, res.status)
>>> study = fem_reference.convergence_study(scene, 1.3, levels=(0, 1, 2), elements=("P1",))
>>> study.reference["bending_angle"]                     # (value, error estimate, element)

Membrane: total-Lagrangian triangles on the flat mesh (P1/P2, 3 displacement components), the DR
link-net law or an incompressible neo-Hookean law; frame: a geometrically exact discrete rod on
the boundary nodes ('paper' isotropic or 'strip' with weak/strong bending and torsion, optional
film offset); Newton with line search, continuation in pre-stretch, eigenmode steps off unstable
states, a stop at self-contact, and mesh sequencing for refined levels.
"""

from .convergence import ConvergenceStudy, Estimate, convergence_study, richardson
from .errors import FEMError
from .solve import solve, sweep

__all__ = ["solve", "sweep", "convergence_study", "richardson", "ConvergenceStudy", "Estimate", "FEMError"]
