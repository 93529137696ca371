"""Finite-element reference for DEMES form-finding (scikit-fem), independent of the DR solver.

The paper's DEMES on a coarse mesh (seconds; continuation from lambda = 1 inside):

>>> import scenes, fem_reference
>>> scene = scenes.paper_demes(prestretch=1.1, **{"mesh.divisions": 4})
>>> res = fem_reference.solve(scene, refinement=0)
>>> res.status, round(res.bending_angle, 1)
('converged', 50.3)

``fem_reference.sweep(scene, [1.1, 1.3, 1.5], refinement=1)`` yields a state per pre-stretch
(``sweep_levels``: with the states of the coarser nested levels along the same path);
``fem_reference.convergence_study(scene, 1.3, levels=(0, 1, 2))`` extrapolates the reference
(docs/fem_reference.md, docs/validation.md).

Membrane: total-Lagrangian triangles on the flat mesh (P1/P2, 3 displacement components), the DR
link-net law or an incompressible neo-Hookean law; frame: a geometrically exact discrete rod on
the boundary nodes ('paper' isotropic or 'strip' with weak/strong bending and torsion, optional
film offset); Newton with line search, continuation in pre-stretch, eigenmode steps off unstable
states, a stop at self-contact, and mesh sequencing for refined levels.
"""

from .convergence import ConvergenceStudy, Estimate, convergence_study, richardson
from .errors import FEMError
from .solve import solve, solve_from, sweep, sweep_levels

__all__ = ["solve", "solve_from", "sweep", "sweep_levels", "convergence_study", "richardson", "ConvergenceStudy", "Estimate", "FEMError"]
