"""The solver-independent result interface: state fields, measures, VTK and atomic output.

Both solvers (``dr``, ``fem_reference``) return :class:`Result`; the validation compares them
through the measures defined once in :mod:`results.metrics`.
"""

from .atomic import atomic_write, atomic_write_text
from .labels import level_label
from .state import ENERGY_DEFINITION, ENERGY_KEYS, SUMMARY_COLUMNS, Result
from .store import load_result, save_result
from .vtk import CellBlock, write_pvd, write_vtu

__all__ = [
    "Result",
    "ENERGY_KEYS",
    "ENERGY_DEFINITION",
    "SUMMARY_COLUMNS",
    "CellBlock",
    "write_vtu",
    "write_pvd",
    "atomic_write",
    "atomic_write_text",
    "save_result",
    "load_result",
    "level_label",
]
