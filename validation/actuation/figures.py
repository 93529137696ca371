"""The voltage sweep's figures: stroke against voltage (the paper's Fig. 4) and the energies
against stroke (Fig. 5), with the experiment's observations marked."""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np

from ..common.plotting import label_axes, plt, save_figure
from .actuate import PAPER_FLAT_V, PAPER_STEEP_STROKE, PAPER_SUBSTANTIAL_V, characteristics

COLORS = {"dr": "tab:blue", "fem": "k"}


def _name(solver: str) -> str:
    """Legend name: 'DR' / 'FEM' for a solver, other run names as given."""
    return solver.upper() if solver in COLORS else solver


def _series(rows: Sequence[dict], key: str) -> np.ndarray:
    return np.array([r[key] for r in rows], dtype=float)


def stroke_voltage(runs: dict[str, Sequence[dict]], path: Path) -> Path:
    """Stroke (deg) against voltage (kV) per solver; the experiment's 1 kV and 2.25 kV marked."""
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    top = 0.0
    for solver, rows in runs.items():
        v, stroke = _series(rows, "voltage") / 1000, _series(rows, "stroke")
        ax.plot(v, stroke, "o-", ms=3, color=COLORS.get(solver), label=_name(solver))
        if rows and rows[-1]["status"] == "pull_in":
            ax.plot(v[-1], stroke[-1], "x", ms=10, color="tab:red", label=f"{_name(solver)} pull-in")
        top = max(top, float(np.nanmax(np.abs(_series(rows, "bending_angle")[:1]))) if rows else 0.0)
    ax.axvline(PAPER_SUBSTANTIAL_V / 1000, color="tab:orange", ls=":", label="experiment: substantial change (~1 kV)")
    ax.axvline(PAPER_FLAT_V / 1000, color="tab:green", ls="--", label="experiment: flat (~2.25 kV)")
    if top:
        ax.axhline(top, color="0.6", lw=0.8, label="stroke at flat (bending angle at 0 V)")
    ax.set_title("Stroke vs voltage (the paper's Fig. 4)")
    label_axes(ax, "voltage [kV]", "stroke [deg]")
    return save_figure(fig, path)


def energy_stroke(runs: dict[str, Sequence[dict]], path: Path) -> Path:
    """E_cap and E_DR (film, frame) against stroke per solver; the paper's steep rises marked,
    and the model's (:func:`validation.actuation.actuate.steep_rise`, a triangle on E_cap)."""
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for solver, rows in runs.items():
        stroke, c = _series(rows, "stroke"), COLORS.get(solver)
        cap = _series(rows, "energy_capacitor")
        lines = ax.plot(stroke, cap, "o-", ms=3, color=c, label=f"{_name(solver)} E_cap")
        steep = characteristics(rows).steep_stroke if rows else float("nan")
        if np.isfinite(steep):
            ax.plot(steep, np.interp(steep, stroke, cap), "v", ms=9, color=lines[0].get_color(),
                    label=f"{_name(solver)}: E_cap steep from {steep:.0f} deg")
        c = lines[0].get_color()
        ax.plot(stroke, _series(rows, "energy_DR"), "s--", ms=3, color=c, mfc="none", label=f"{_name(solver)} E_DR")
        ax.plot(stroke, _series(rows, "energy_frame"), ":", color=c, label=f"{_name(solver)} E_DR, frame")
    for kind, s in PAPER_STEEP_STROKE.items():
        ax.axvline(s, color="tab:orange" if kind == "numerical" else "tab:green", ls=":",
                   label=f"paper: steep rise, {kind} ({s:.0f} deg)")
    ax.set_title("Energy vs stroke (the paper's Fig. 5)")
    label_axes(ax, "stroke [deg]", "energy [N mm]", fontsize=6)
    return save_figure(fig, path)
