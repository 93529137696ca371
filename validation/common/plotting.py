"""What every figure of the validation shares: matplotlib off-screen, axis labels, atomic PNGs."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")  # no display: figures are files
import matplotlib.pyplot as plt  # noqa: E402

from results import atomic_write  # noqa: E402

__all__ = ["plt", "label_axes", "save_figure"]


def label_axes(ax: Any, xlabel: str, ylabel: str, fontsize: int = 7, **legend: Any) -> None:
    """Axis titles, a light grid (minor lines too on log axes) and the legend."""
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=fontsize, **legend)


def save_figure(fig: Any, path: Path) -> Path:
    """Write ``fig`` to ``path`` as PNG (atomically) and close it; returns ``path``."""
    def write(tmp: Path) -> None:
        fig.savefig(tmp, dpi=110, bbox_inches="tight", format="png")

    try:
        return atomic_write(path, write)
    finally:
        plt.close(fig)
