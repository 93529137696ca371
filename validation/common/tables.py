"""Tables of state summaries: aligned text for the terminal, CSV with units in the header."""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from results import SUMMARY_COLUMNS, atomic_write_text, level_label

UNITS = dict(SUMMARY_COLUMNS)

LEVEL_COLUMNS = ("prestretch", "voltage")
"""Columns of levels a user types: written as typed, without the round-off of their grid."""


def header(name: str, units: dict[str, str] | None = None) -> str:
    """Column header with its unit: 'bending_angle [deg]'."""
    unit = {**UNITS, **(units or {})}.get(name, "-")
    return name if unit == "-" else f"{name} [{unit}]"


def _fmt(v: Any, column: str = "") -> str:
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, (float, np.floating)):
        # every digit: the CSV is data, the tables round for reading; levels as typed
        return level_label(v) if column in LEVEL_COLUMNS else repr(float(v))
    return str(v)


def write_csv(path: str | Path, rows: Sequence[dict[str, Any]], columns: Sequence[str] | None = None,
              units: dict[str, str] | None = None) -> Path:
    """Write rows (dicts) as CSV, headers carrying units (the state summary's, and ``units``
    for further columns); atomically."""
    # every key of every row: rows may differ (a reference with more refinement levels)
    columns = list(columns or dict.fromkeys(k for r in rows for k in r))
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow([header(c, units) for c in columns])
    for r in rows:
        w.writerow([_fmt(r.get(c, ""), c) for c in columns])
    return atomic_write_text(path, buf.getvalue())


def format_cell(v: Any, spec: str = "") -> str:
    """A value for a human-readable table: '-' for missing or NaN, yes/no for booleans; spec
    'level' writes a pre-stretch or voltage as typed (see :func:`results.level_label`)."""
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return "-"
    if isinstance(v, (bool, np.bool_)):
        return "yes" if v else "no"
    if spec == "level" and isinstance(v, (int, float, np.integer, np.floating)):
        return level_label(v)
    if isinstance(v, (int, float, np.integer, np.floating)) and spec:
        return format(float(v) if spec[-1] in "efg%" else int(v), spec)
    return str(v)


def format_table(rows: Sequence[dict[str, Any]], columns: Sequence[tuple[str, str, str]]) -> str:
    """Aligned text table. ``columns``: (key, title, format spec) triples."""
    head = [title for _, title, _ in columns]
    body = [[format_cell(r.get(key, ""), spec) for key, _, spec in columns] for r in rows]
    widths = [max(len(h), *(len(b[i]) for b in body)) if body else len(h) for i, h in enumerate(head)]
    out = ["  ".join(h.rjust(w) for h, w in zip(head, widths))]
    out += ["  ".join(c.rjust(w) for c, w in zip(b, widths)) for b in body]
    return "\n".join(out)


STATE_TABLE = (
    ("prestretch", "lambda", "level"),
    ("bending_angle", "theta[deg]", ".2f"),
    ("branch", "branch", ""),
    ("apex_y", "apex_y[mm]", ".2f"),
    ("apex_z", "apex_z[mm]", ".2f"),
    ("mid_height_width", "width[mm]", ".2f"),
    ("energy_membrane", "E_mem[Nmm]", ".4g"),
    ("energy_frame_bending", "E_bend[Nmm]", ".4g"),
    ("energy_frame_torsion", "E_tors[Nmm]", ".4g"),
    ("energy_frame_axial", "E_ax[Nmm]", ".3g"),
    ("energy_total", "E_tot[Nmm]", ".4g"),
    ("iterations", "iter", "d"),
    ("wall_time", "time[s]", ".2f"),
    ("status", "status", ""),
)
"""The columns ``demes fem`` prints."""

MESH_ERROR_TABLE = (
    ("prestretch", "lambda", "level"),
    ("bending_angle", "theta[deg]", ".2f"),
    ("branch", "branch", ""),
    ("stable", "stable", ""),
    ("bending_angle_extrapolated", "theta*[deg]", ".2f"),
    ("bending_angle_error", "+-[deg]", ".2g"),
    ("bending_angle_order", "order", ".2f"),
    ("apex_y", "apex_y[mm]", ".2f"),
    ("apex_y_error", "+-[mm]", ".2g"),
    ("apex_z", "apex_z[mm]", ".2f"),
    ("apex_z_error", "+-[mm]", ".2g"),
    ("energy_total", "E_tot[Nmm]", ".4g"),
    ("energy_total_error", "+-[Nmm]", ".2g"),
    ("iterations", "iter", "d"),
    ("wall_time", "time[s]", ".1f"),
    ("status", "status", ""),
    ("mesh_error", "mesh error", ""),
)
"""The columns ``demes solve`` prints: the state on the finest mesh, the extrapolated bending
angle and the error estimates (validation/solve/mesh_error.py)."""
