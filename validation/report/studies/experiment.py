"""The validation report's "Against the experiment": voltage sweeps of the strip DEMES with
Table I's values and calibrated, beside the paper's observations (docs/actuation.md).

The study plugs into ``demes validate`` as :data:`STUDY` (:class:`validation.report.study.Study`):
its runs are part of the validation plan (group 'experiment', :func:`experiment_runs`) and are
executed by :mod:`validation.report.runner` through :func:`execute`: a voltage run is one warm-started
path (:func:`validation.actuation.actuate.voltage_states`), so an interrupted one is redone whole, and a
complete one is kept. The calibrated run first fits ``membrane.E`` and ``frame.E``
(:func:`validation.actuation.calibrate.fit`) and keeps the fit in ``calibration.json``. Nothing here
solves at analysis time: :func:`analyse` reads the stored states.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from results import Result, atomic_write_text, level_label, load_result, save_result, write_pvd
from scenes import Scene

from ...actuation.actuate import (
    EXPERIMENT,
    PAPER_FLAT_V,
    PAPER_STEEP_STROKE,
    PAPER_SUBSTANTIAL_V,
    UNITS,
    characteristics,
    compare,
    row,
    voltage_states,
)
from ...actuation.calibrate import CHECK_VOLTAGES, Calibration, describe, fit, flattening_voltage, residuals
from ...actuation.figures import energy_stroke, stroke_voltage
from ...common.document import Section, Table
from ..plan import MATCHED, REFERENCE, Run, Settings
from ..study import Study
from ..verdicts import Verdict

GROUP = "experiment"
"""The plan's group of the voltage runs."""

CALIBRATION = "calibration.json"
"""File of a calibrated run's fit, beside its states."""

CALIBRATED = "exp_fem_calibrated"
"""The run whose moduli are fitted to the experiment."""


def _grid(stop: float, step: float) -> tuple[float, ...]:
    return tuple(float(v) for v in np.arange(0.0, stop + step / 2, step))


QUICK_MESH = {"mesh.divisions": 6}
"""The quick plan's experiment runs: a coarse mesh (at 4 divisions the FEM and DR angles differ by 360 deg)."""


def experiment_runs(s: Settings) -> list[Run]:
    """The plan's voltage runs: FEM and matched DR with Table I's values (flat near 6.75 kV),
    the FEM calibrated to the experiment (flat at 2.25 kV)."""
    mesh = QUICK_MESH if s.quick else s.coarse
    table = _grid(7000.0, 1000.0 if s.quick else 500.0)
    calibrated = _grid(3000.0, 500.0) if s.quick else CHECK_VOLTAGES
    return [
        Run("exp_fem_table1", "fem", {**mesh, **REFERENCE}, group=GROUP, voltages=table,
            title="FEM, strip frame, Table I"),
        Run("exp_dr_table1", "dr", {**mesh, **MATCHED}, group=GROUP, voltages=table,
            title="DR matched (triangles), strip frame, Table I"),
        Run(CALIBRATED, "fem", {**mesh, **REFERENCE}, group=GROUP, voltages=calibrated,
            calibrate=True, title="FEM, strip frame, calibrated (membrane.E, frame.E)"),
    ]


def _state_file(run_dir: Path, voltage: float) -> Path:
    return run_dir / f"{level_label(voltage)}V.npz"


def execute(run: Run, scene: Scene, run_dir: Path) -> dict[float, Result]:
    """Solve one voltage run into ``run_dir`` (states by voltage, VTK series, the fit); the
    states by voltage (V)."""
    for stale in [*run_dir.glob("*V.npz"), *run_dir.glob("*.vtu"), *run_dir.glob("*.pvd")]:
        stale.unlink()  # a path is redone whole
    if run.calibrate:
        scene, cal, theta_target = fit(scene, run.refinement, progress=lambda _: None)
        atomic_write_text(run_dir / CALIBRATION, json.dumps(
            {"calibration": asdict(cal), "theta_target": theta_target, "scene": scene.to_dict()}, indent=1))
    states: dict[float, Result] = {}
    entries: list[tuple[float, Path]] = []
    for res in voltage_states(scene, run.solver, run.voltages, run.refinement):
        v = float(res.info["voltage_V"])
        save_result(_state_file(run_dir, v), res)
        entries.append((v, res.write_vtk(run_dir / f"{run.label}_{level_label(v)}V.vtu")))
        write_pvd(run_dir / f"{run.label}.pvd", entries)
        states[v] = res
    return states


@dataclass
class Experiment:
    """The section's numbers: the sweeps' rows per run, one summary row per run, the fit."""

    sweeps: dict[str, list[dict[str, Any]]] = field(default_factory=dict)
    summary: list[dict[str, Any]] = field(default_factory=list)
    calibration: dict[str, Any] | None = None


def load_sweep(run_dir: Path) -> list[Result]:
    """A voltage run's stored states, by increasing voltage."""
    states = [load_result(p) for p in run_dir.glob("*V.npz")]
    return sorted(states, key=lambda r: r.info["voltage_V"])


def analyse(a: Any, out_dir: Path) -> Experiment | None:
    """Read the plan's experiment runs from ``out_dir`` (None if it has none; ``a``: the core
    analysis, whose plan lists them)."""
    runs = a.plan.by_group(GROUP)
    if not runs:
        return None
    ex = Experiment()
    for run in runs:
        run_dir = out_dir / "runs" / run.label
        states = load_sweep(run_dir)
        if not states:
            continue
        rows: list[dict] = []
        for res in states:
            rows.append(row(res, rows[0] if rows else None))
        ex.sweeps[run.label] = rows
        c = characteristics(rows)
        fit_file = run_dir / CALIBRATION
        scene = states[0].scene
        closed_form = flattening_voltage(scene) if scene.prestretch_path.isotropic else np.nan  # none for a pair
        summary = {"run": run.label, "model": run.title, "theta0": c.theta0,
                   "stroke_at_1kV": c.stroke_at_1kV, "flat_voltage": c.flat_voltage,
                   "flat_closed_form": closed_form, "pull_in_voltage": c.pull_in_voltage,
                   "steep_stroke": c.steep_stroke, "membrane_E": scene.membrane.E,
                   "frame_E": scene.frame.E, "end": f"{rows[-1]['status']} at {rows[-1]['voltage']:.0f} V"}
        if fit_file.exists():
            data = json.loads(fit_file.read_text())
            data["calibration"]["residuals"] = residuals(c, data["theta_target"])
            ex.calibration = data["calibration"]
        ex.summary.append(summary)
    return ex


SUMMARY = (("model", "model", ""), ("theta0", "angle at 0 V [deg]", ".1f"),
           ("stroke_at_1kV", "stroke at 1 kV [deg]", ".2f"), ("flat_voltage", "flat at [V]", ".0f"),
           ("flat_closed_form", "closed form [V]", ".0f"), ("pull_in_voltage", "pull-in after [V]", ".0f"),
           ("steep_stroke", "E_cap steep from [deg]", ".0f"), ("membrane_E", "membrane.E [MPa]", ".4g"),
           ("frame_E", "frame.E [MPa]", ".4g"), ("end", "path end", ""))

PAPER_ROW = {"model": "experiment (paper, Fig. 4 and 5)", "stroke_at_1kV": float("nan"), "flat_voltage": PAPER_FLAT_V,
             "steep_stroke": PAPER_STEEP_STROKE["physical"],
             "end": f"substantial change at about {PAPER_SUBSTANTIAL_V:.0f} V; steep rise {PAPER_STEEP_STROKE['numerical']:.0f} deg "
                    f"(numerical), {PAPER_STEEP_STROKE['physical']:.0f} deg (physical)"}


FIGURES = ("experiment_stroke_voltage", "experiment_energy_stroke")
LEGEND = {"exp_fem_table1": "FEM, Table I", "exp_dr_table1": "DR, Table I", "exp_fem_calibrated": "FEM, calibrated"}


def figures(ex: Experiment, fig_dir: Path) -> dict[str, Path]:
    """Stroke against voltage and energies against stroke, every run in one figure each."""
    runs = {LEGEND.get(label, label): rows for label, rows in ex.sweeps.items()}
    draw = dict(zip(FIGURES, (stroke_voltage, energy_stroke)))
    return {name: draw[name](runs, fig_dir / f"{name}.png") for name in FIGURES}


def tables(ex: Experiment) -> dict[str, list[dict[str, Any]]]:
    """``experiment`` (every state of every sweep) and ``experiment_summary``."""
    states = [{"run": label, **{k: v for k, v in r.items() if k != "message"}}
              for label, rows in ex.sweeps.items() for r in rows]
    return {"experiment": states, "experiment_summary": ex.summary}


def findings(ex: Experiment) -> list[str]:
    """Sentences: each model beside the experiment's observations, and DR against the FEM."""
    out = []
    for r in ex.summary:
        flat = (f"flat at {r['flat_voltage']:.0f} V ({r['flat_voltage'] / PAPER_FLAT_V:.2f} times the "
                f"experiment's {PAPER_FLAT_V:.0f} V)" if np.isfinite(r["flat_voltage"])
                else f"not flat ({r['end']}; closed form {r['flat_closed_form']:.0f} V)")
        steep = (f"E_cap's slope against stroke doubles from {r['steep_stroke']:.0f} deg" if np.isfinite(r["steep_stroke"])
                 else "E_cap's slope against stroke never doubles on the path")
        out.append(f"{r['model']}: {flat}; stroke at 1 kV {r['stroke_at_1kV']:.1f} deg of {r['theta0']:.1f} deg "
                   f"(experiment: a substantial change); {steep} (paper: steep rise near "
                   f"{PAPER_STEEP_STROKE['numerical']:.0f} / {PAPER_STEEP_STROKE['physical']:.0f} deg).")
    if {"exp_dr_table1", "exp_fem_table1"} <= set(ex.sweeps):
        out.append(compare(ex.sweeps["exp_dr_table1"], ex.sweeps["exp_fem_table1"]) + " (Table I).")
    return out


def section(ex: Experiment, figs: dict[str, Path | None]) -> Section:
    """The report section "Against the experiment" (figures by the names of :data:`FIGURES`)."""
    parts: list[Any] = [
        EXPERIMENT,
        "Voltage sweeps of the strip DEMES at the scene's pre-stretch, each warm-started from the 0 V "
        "equilibrium (docs/actuation.md): the FEM and DR on the FEM's own mesh with Table I's values, and the "
        "FEM with the film modulus fitted to the experiment's flattening voltage and the frame modulus scaled "
        "by the same factor, which keeps the 0 V shape exactly (`demes calibrate`). 'flat at': bending angle below 1 deg (interpolated linearly "
        "in V^2); 'closed form': the voltage whose Maxwell stress cancels the flat film's tension; "
        "'E_cap steep from': the stroke where the capacitor energy's slope against stroke first doubles.",
        Table(SUMMARY, [*ex.summary, PAPER_ROW]),
        *findings(ex),
    ]
    if ex.calibration is not None:
        cal = Calibration(**{k: v for k, v in ex.calibration.items()})
        parts.append("Calibration: " + "; ".join(line.strip() for line in describe(cal).splitlines()))
    parts += [figs[name] for name in FIGURES if figs.get(name) is not None]
    return Section("Against the experiment", parts)


FLAT_MATCH = 0.1
"""A model reproduces the experiment's flattening voltage when within this fraction of it."""


def verdicts(ex: Experiment) -> list[Verdict]:
    """The row of the verdict table: each model's flattening voltage against the experiment's."""
    claim = f"The model reproduces the experiment's flattening voltage ({PAPER_FLAT_V:.0f} V)"
    rows = [r for r in ex.summary if np.isfinite(r["flat_voltage"])]
    if not rows:
        return [Verdict(claim, "; ".join(f"{r['model']}: {r['end']}" for r in ex.summary) or "no voltage runs",
                        "not measured")]
    measured = "; ".join(f"{r['model']}: flat at {r['flat_voltage']:.0f} V ({r['flat_voltage'] / PAPER_FLAT_V:.2f}x)"
                         for r in rows)
    fitted = [r for r in rows if r["run"] == CALIBRATED]
    as_given = [r for r in rows if r["run"] != CALIBRATED]
    matched = [abs(r["flat_voltage"] / PAPER_FLAT_V - 1.0) <= FLAT_MATCH for r in as_given]
    verdict = ("reproduced with Table I's moduli" if matched and all(matched)
               else "not reproduced with Table I's moduli" if as_given else "")
    if fitted:
        verdict += ("; " if verdict else "") + "met by the calibrated model (its two moduli fitted to it)"
    return [Verdict(claim, measured, verdict)]


STUDY = Study(name="experiment", runs=experiment_runs, analyse=analyse, section=section, tables=tables,
              units={**UNITS, "theta0": "deg", "stroke_at_1kV": "deg", "flat_voltage": "V", "flat_closed_form": "V",
                     "pull_in_voltage": "V", "steep_stroke": "deg", "membrane_E": "MPa", "frame_E": "MPa"},
              figures=figures, verdicts=verdicts, group=GROUP, execute=execute)
"""The voltage runs against the experiment, as ``demes validate`` plugs them in."""
