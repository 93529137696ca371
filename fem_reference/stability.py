"""Whether a FEM state is stable: the lowest eigenvalue of its tangent over the free DOFs (against
:func:`results.path.neutral_stiffness`)."""

from __future__ import annotations

import numpy as np

from .model import DemesProblem
from .newton import lowest_mode


def lowest_free_mode(problem: DemesProblem, y: np.ndarray) -> tuple[float, np.ndarray]:
    """Lowest eigenvalue (N/mm^3) and mode of the tangent at y over the free DOFs, against the
    film's mass matrix (per unit area)."""
    K = problem.evaluate(y, 2).tangent
    f = problem.free
    return lowest_mode(K[f][:, f].tocsc(), problem.mass[f][:, f].tocsc())
