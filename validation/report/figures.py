"""Figures of the validation report: matplotlib plots and pyvista renders (off-screen)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from results import atomic_write, render

from ..common.plotting import label_axes, plt, save_figure
from .analysis import Analysis

STYLE = {
    "dr_paper": dict(color="tab:red", marker="s", label="DR, paper's model (clustered, Table I frame)"),
    "dr_matched": dict(color="tab:blue", marker="o", label="DR, matched (triangles, strip)"),
    "dr_clustered_strip": dict(color="tab:purple", marker="^", label="DR, clustered net, strip"),
    "reference": dict(color="k", marker="D", label="FEM reference (extrapolated)"),
}


def bending_angle(a: Analysis, path: Path) -> Path:
    """Bending angle against pre-stretch (the paper's Fig. 2 as a curve)."""
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for label in ("dr_paper", "dr_matched", "dr_clustered_strip"):
        pts = sorted((lam, r.bending_angle, r.converged) for lam, r in a.states[label].items())
        if pts:
            lam, th, ok = map(np.array, zip(*pts))
            st = STYLE[label]
            ax.plot(lam, th, "-", color=st["color"], label=st["label"])
            ax.plot(lam[ok], th[ok], st["marker"], color=st["color"])
            ax.plot(lam[~ok], th[~ok], st["marker"], color=st["color"], mfc="none")
    for k in a.plan.reference_levels:
        pts = sorted((lam, r.bending_angle) for lam, r in a.states[f"fem_r{k}"].items() if r.converged)
        if pts:
            ax.plot(*zip(*pts), ":", color="0.5", lw=1, label=f"FEM refinement levels {a.plan.reference_levels[0]}-{k}" if k == a.plan.reference_levels[-1] else None)
    refs = sorted(a.references.items())
    if refs:
        lam = [l for l, _ in refs]
        ax.errorbar(lam, [r.values["bending_angle"] for _, r in refs], yerr=[r.errors["bending_angle"] for _, r in refs],
                    fmt="D-", color="k", ms=4, label=STYLE["reference"]["label"])
    ax.set_title("Bending angle vs pre-stretch (open markers: stopped states)")
    label_axes(ax, "pre-stretch ratio [-]", "bending angle [deg]")
    return save_figure(fig, path)


def energy_stroke(a: Analysis, path: Path) -> Path:
    """Strain energy against stroke, split into membrane and frame (the paper's Fig. 5).

    Stroke is the change of bending angle from the most bent converged state of each model,
    as a voltage relaxing the membrane would produce it.
    """
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), sharey=False)
    series = {"dr_paper": a.states["dr_paper"], "dr_matched": a.states["dr_matched"],
              "reference": {lam: r for lam, (_, r) in a.finest_fem.items()}}
    for key, states in series.items():
        ok = sorted((lam, r) for lam, r in states.items() if r.converged)
        if len(ok) < 2:
            continue
        theta = np.array([r.bending_angle for _, r in ok])
        i_bent = int(np.argmax(np.abs(theta)))
        stroke = np.abs(theta[i_bent] - theta)
        e_mem = np.array([r.energy["membrane"] for _, r in ok])
        e_frame = np.array([r.energy["total"] - r.energy["membrane"] for _, r in ok])
        st = STYLE[key]
        label = st["label"] if key != "reference" else "FEM, finest level"
        axes[0].plot(stroke, e_mem + e_frame, st["marker"] + "-", color=st["color"], label=label)
        axes[1].plot(stroke, e_mem, st["marker"] + "-", color=st["color"], label=f"membrane, {label}")
        paper = np.array([r.info.get("energy_membrane_paper_formula", np.nan) for _, r in ok], dtype=float)
        if np.isfinite(paper).any():
            axes[1].plot(stroke, paper, ":", color=st["color"], label=f"membrane by the paper's formula, {label}")
        axes[1].plot(stroke, e_frame, st["marker"] + "--", color=st["color"], mfc="none", label=f"frame, {label}")
    axes[0].set_title("Total strain energy vs stroke (exact)")
    axes[1].set_title("Energy split: membrane (solid) and frame (dashed)")
    for ax in axes:
        label_axes(ax, "stroke [deg] (from the most bent converged state)", "energy [N mm]", fontsize=6)
    return save_figure(fig, path)


def frame_curves(a: Analysis, path: Path) -> Path:
    """Side view (y, z) of the frame curves of DR and the FEM reference at each pre-stretch."""
    lams = [lam for lam in a.plan.sweep if lam in a.references]
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), sharex=True, sharey=True)
    cmap = plt.get_cmap("viridis")
    for i, lam in enumerate(lams):
        c = cmap(i / max(len(lams) - 1, 1))
        ref = a.references[lam]
        for ax, label in zip(axes, ("dr_paper", "dr_matched")):
            ax.plot(np.append(ref.curve[:, 1], ref.curve[0, 1]), np.append(ref.curve[:, 2], ref.curve[0, 2]), "-", color=c, lw=1.5)
            res = a.states[label].get(lam)
            if res is not None:
                cur = res.frame_curve(256)
                ax.plot(np.append(cur[:, 1], cur[0, 1]), np.append(cur[:, 2], cur[0, 2]), "--", color=c, lw=1)
    for ax, label in zip(axes, ("dr_paper", "dr_matched")):
        ax.set_title(f"{STYLE[label]['label']} (dashed) vs FEM (solid)", fontsize=8)
        ax.set_xlabel("y [mm]")
        ax.set_aspect("equal")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("z [mm]")
    return save_figure(fig, path)


def renders(a: Analysis, lam: float, path: Path) -> Path | None:
    """pyvista renders of DR (matched, paper) and FEM states at ``lam``: top, side, perspective;
    None (and a note on stderr) where nothing can render off-screen."""
    fem = a.finest_fem.get(lam, (None, None))[1]
    shown = [("FEM reference (finest level)", fem), ("DR matched", a.states["dr_matched"].get(lam)),
             ("DR, paper's model", a.states["dr_paper"].get(lam))]
    shown = [(t, r) for t, r in shown if r is not None]
    if not shown:
        return None
    views = (("top", "xy"), ("side", "yz"), ("perspective", "iso"))
    try:
        pl = render.plotter(shape=(len(shown), 3), window_size=(1050, 330 * len(shown)))
    except render.RenderUnavailable as exc:
        print(f"demes: the report has no renders: {exc}", file=sys.stderr)
        return None
    for i, (title, res) in enumerate(shown):
        for j, (vname, cam) in enumerate(views):
            pl.subplot(i, j)
            render.add_state(pl, res)
            pl.add_text(f"{title}, {vname}", font_size=8)
            if cam == "xy":
                pl.view_xy()
            elif cam == "yz":
                pl.view_yz()
            else:
                pl.view_isometric()
    def write(tmp: Path) -> None:
        pl.screenshot(str(tmp))

    atomic_write(path, write)
    pl.close()
    return path
