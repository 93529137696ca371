"""Dynamic relaxation (kinetic damping) with links, clustered cables, spline beams and strips.

>>> import dr, scenes
>>> res = dr.solve(scenes.paper_demes(prestretch=1.5))     # the paper's DEMES
>>> m = dr.Model(nodes); m.support([0]); ...; out = dr.relax(m)   # any structure
"""

from .contact import FrameContact, MembraneFold
from .errors import DRError
from .model import Model
from .demes import build, solve, sweep
from .relax import relax
from .actuation import voltage_sweep

__all__ = ["Model", "relax", "solve", "sweep", "voltage_sweep", "build", "DRError", "FrameContact", "MembraneFold"]
