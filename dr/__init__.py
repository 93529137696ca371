"""Dynamic relaxation (kinetic damping) with links, clustered cables, spline beams and strips.

The paper's DEMES on a coarse mesh (8 lattice divisions per side; the scene's 28 take ~10 s):

>>> import dr, scenes
>>> res = dr.solve(scenes.paper_demes(prestretch=1.2, **{"mesh.divisions": 8}))
>>> res.status, round(res.bending_angle, 1), round(res.energy["total"], 3)   # deg, N mm
('converged', 84.0, 1.522)

Any structure: see :class:`dr.Model`. The theory is in docs/dynamic_relaxation.md and
docs/elements.md.
"""

from .contact import FilmCrossing, FrameContact, MembraneFold
from .errors import DRError
from .model import Model
from .demes import solve, sweep
from .demes_model import build
from .relax import relax
from .actuation import voltage_sweep
from . import cache as _cache

_cache.guard(__name__)  # before any kernel runs: a cached kernel may inline an edited function

__all__ = ["Model", "relax", "solve", "sweep", "voltage_sweep", "build", "DRError", "FrameContact", "MembraneFold",
           "FilmCrossing"]
