"""Plots of a design study: each measure against each swept field (matplotlib, PNG)."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from ..common.plotting import plt, save_figure
from ..common.tables import header
from .grid import Grid

PLOTTED = ("bending_angle", "apex_z", "mid_height_width", "energy_total", "iterations", "wall_time")
"""The measures plotted against every swept field."""

MAX_LEGEND = 10
"""More lines than this get no legend (one line per combination of the other fields)."""


def measure_plots(table: pd.DataFrame, grid: Grid, out_dir: Path) -> dict[str, Path]:
    """One figure per swept field (pre-stretch included when it has several values), a panel
    per measure, a line per combination of the other swept fields; filled markers are
    converged points, open ones stopped. Returns {field: png path}."""
    swept = [*grid.fields, *(["prestretch"] if len(grid.prestretches) > 1 else [])]
    return {field: _plot(table, field, [f for f in swept if f != field], out_dir / f"{field}.png")
            for field in swept}


def _plot(table: pd.DataFrame, field: str, others: list[str], path: Path) -> Path:
    fig, axes = plt.subplots(2, 3, figsize=(12, 6.5), layout="constrained")
    groups = list(table.groupby(others, sort=False)) if others else [((), table)]
    for ax, measure in zip(axes.flat, PLOTTED):
        for i, (values, rows) in enumerate(groups):
            rows = rows[rows[measure].notna()]
            values = values if isinstance(values, tuple) else (values,)
            label = ", ".join(f"{f} = {v}" for f, v in zip(others, values)) or None
            color = f"C{i % 10}"
            ax.plot(rows[field], rows[measure], "-", color=color, lw=1,
                    label=label if len(groups) <= MAX_LEGEND else None)
            ok = rows["converged"].astype(bool)
            ax.plot(rows[field][ok], rows[measure][ok], "o", color=color, ms=4)
            ax.plot(rows[field][~ok], rows[measure][~ok], "o", color=color, ms=4, mfc="none")
        ax.set_xlabel(header(field))
        ax.set_ylabel(header(measure))
        ax.grid(alpha=0.3)
    if 1 < len(groups) <= MAX_LEGEND:
        axes.flat[0].legend(fontsize=7)
    note = f"; {len(groups)} lines, one per {' x '.join(others)}" if len(groups) > 1 else ""
    fig.suptitle(f"measures against {field} (open markers: path stopped{note})", fontsize=10)
    return save_figure(fig, path)
