"""Whether a FEM state is stable: the lowest eigenvalue of its tangent over the free DOFs, and
the tolerance below which an eigenvalue counts as zero (a neutral mode of a slack film)."""

from __future__ import annotations

import numpy as np

from scenes import Scene

from .model import DemesProblem
from .newton import lowest_mode


def lowest_free_mode(problem: DemesProblem, y: np.ndarray) -> tuple[float, np.ndarray]:
    """Lowest eigenvalue (N/mm^3) and mode of the tangent at y over the free DOFs, against the
    film's mass matrix (per unit area)."""
    K = problem.evaluate(y, 2).tangent
    f = problem.free
    return lowest_mode(K[f][:, f].tocsc(), problem.mass[f][:, f].tocsc())


def neutral_tolerance(scene: Scene) -> float:
    """Eigenvalues (N/mm^3) above minus this count as zero: 1e-6 of E h / side^2, far above
    round-off and far below any physical out-of-plane stiffness of the film."""
    return 1e-6 * scene.membrane.E * scene.membrane.thickness / scene.outline.side_length**2
