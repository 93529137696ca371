"""``demes actuate``: a warm-started voltage sweep of the pre-stretched DEMES, its table, CSV,
VTK series (time steps in volts), the stroke and energy figures and the characteristic voltages.

Stroke is the bending angle at 0 V minus the bending angle at V (deg; it grows as the voltage
relaxes the film and the frame uncurls). E_DR is the strain energy (film + frame), E_cap the
capacitor energy A C V^2 / 2 with the current area and thickness. See docs/actuation.md.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from decimal import Decimal, InvalidOperation
from pathlib import Path
from typing import Iterator, Sequence

import numpy as np
from tqdm import tqdm

from results import Result, atomic_write_text, write_pvd
from scenes import Scene, SceneError
from scenes.electric import FLAT_DEG

from ..common.document import Section, Table, to_html, to_markdown
from ..common.tables import format_table, write_csv

PAPER_SUBSTANTIAL_V, PAPER_FLAT_V = 1000.0, 2250.0
"""The experiment (docs/actuation.md): substantial change of shape near 1 kV, flat near 2.25 kV."""

PAPER_STEEP_STROKE = {"numerical": 120.0, "physical": 140.0}
"""Strokes (deg) where the paper's energies rise steeply."""

MAX_VOLTAGES = 10_000


@dataclass(frozen=True)
class Voltages:
    """Requested voltages (V) with their labels exactly as typed or on the typed grid."""

    values: tuple[float, ...]
    labels: tuple[str, ...]


def parse_voltages(text: str) -> Voltages:
    """``'0:3000:100'`` (start:stop:step, stop included), ``'0,500,1000'`` or ``'1500'``.

    The grid is built in decimal arithmetic, so a label is '1500' or '0.25', never
    '1500.0000000002'.
    """
    text = str(text).strip()
    try:
        if ":" in text:
            parts = [Decimal(p) for p in text.split(":")]
            if len(parts) != 3:
                raise SceneError(f"--voltage {text!r}: write start:stop:step in volts, e.g. 0:3000:100")
            start, stop, step = parts
            if step <= 0:
                raise SceneError(f"--voltage {text!r}: the step must be positive")
            if stop < start:
                raise SceneError(f"--voltage {text!r}: stop is below start; the sweep raises the voltage")
            n = int((stop - start) / step) + 1
            if n > MAX_VOLTAGES:
                raise SceneError(f"--voltage {text!r}: {n} voltages; use at most {MAX_VOLTAGES} (a larger step)")
            grid = [start + k * step for k in range(n)]
        else:
            grid = [Decimal(p) for p in text.split(",") if p.strip()]
    except InvalidOperation:
        raise SceneError(f"--voltage {text!r}: not a number; write e.g. 0:3000:100 or 0,1000,2250") from None
    if not grid:
        raise SceneError("--voltage is empty: write e.g. 0:3000:100")
    for v in grid:
        if not v.is_finite() or v < 0:
            raise SceneError(f"--voltage {text!r}: {v} V is negative or not finite; voltages are >= 0")
    if any(b <= a for a, b in zip(grid, grid[1:])):
        raise SceneError(f"--voltage {text!r}: voltages must increase (one warm-started path)")
    labels = tuple(format(v.normalize(), "f") for v in grid)
    return Voltages(tuple(float(v) for v in grid), labels)


def voltage_states(scene: Scene, solver: str, voltages: Sequence[float],
                   refinement: int | None = None, electrodes: Sequence[str] | None = None) -> Iterator[Result]:
    """The solver's voltage sweep of ``scene`` ('fem' or 'dr'), driving the named
    ``electrodes`` (default: all)."""
    if solver == "fem":
        from fem_reference.actuation import voltage_sweep

        return voltage_sweep(scene, voltages, refinement, electrodes=electrodes)
    if solver == "dr":
        import dr

        return dr.voltage_sweep(scene, voltages, electrodes=electrodes)
    raise SceneError(f"--solver {solver!r}: use dr, fem or both")


def row(res: Result, first: dict | None) -> dict:
    """One CSV row of a voltage state; ``first`` is the sweep's first row (None: this is it),
    the shape the strokes are counted from. A frame with windows in a row adds each window's
    turn and stroke (``segment_k_turn``, ``segment_k_stroke``, k = 1 at the base)."""
    s = res.summary()
    e = res.energy
    theta0 = first["bending_angle"] if first else s["bending_angle"]
    segments = {}
    for k, turn in enumerate(res.segment_turns if res.scene is not None and res.segment_turns is not None else [], 1):
        segments[f"segment_{k}_turn"] = turn
        segments[f"segment_{k}_stroke"] = (first[f"segment_{k}_turn"] if first else turn) - turn
    return {
        "voltage": res.info["voltage_V"],
        "bending_angle": s["bending_angle"],
        "stroke": theta0 - s["bending_angle"],
        "apex_z": s["apex_z"],
        "energy_membrane": e["membrane"],
        "energy_frame": e["total"] - e["membrane"],
        "energy_DR": e["total"],
        "energy_capacitor": res.info["capacitor_energy"],
        "film_area": res.info["film_area_mm2"],
        "film_thickness": res.info["film_thickness_mm"],
        **segments,
        "converged": res.converged,
        "status": res.status,
        "message": res.message,
    }


UNITS = {"voltage": "V", "stroke": "deg", "energy_frame": "N mm", "energy_DR": "N mm",
         "energy_capacitor": "N mm", "film_area": "mm^2", "film_thickness": "mm"}

TABLE = (("voltage", "V [V]", ".0f"), ("bending_angle", "angle [deg]", ".2f"),
         ("stroke", "stroke [deg]", ".2f"), ("energy_DR", "E_DR [N mm]", ".4f"),
         ("energy_membrane", "film", ".4f"), ("energy_frame", "frame", ".4f"),
         ("energy_capacitor", "E_cap [N mm]", ".4f"), ("film_thickness", "h [mm]", ".4f"),
         ("status", "status", ""))


@dataclass
class Characteristics:
    """What a voltage sweep says about the experiment's observations (NaN: not reached)."""

    flat_voltage: float = float("nan")  # V, bending angle crosses FLAT_DEG (linear in V^2)
    stroke_at_1kV: float = float("nan")  # deg
    pull_in_voltage: float = float("nan")  # V, last stable state before the instability
    steep_stroke: float = float("nan")  # deg, where E_cap rises steeply (see steep_rise)
    theta0: float = float("nan")  # deg, bending angle at 0 V
    notes: list[str] = field(default_factory=list)


EQUILIBRIA = ("converged", "compression")
"""Statuses of the states a sweep's characteristics are read from: 'compression' is a converged
equilibrium of a neo-Hookean or Gent film that is compressed in places (it would wrinkle, which
the status reports); its shape is the solver's answer all the same."""

STEEP_FACTOR = 2.0
"""The energy rises steeply where its slope against stroke is this many times the initial one."""


def steep_rise(stroke: np.ndarray, energy: np.ndarray) -> float:
    """Stroke (deg) from which the energy rises steeply: the start of the first interval whose
    slope dE/dstroke exceeds STEEP_FACTOR times the first interval's (NaN if none, or with
    fewer than 3 points)."""
    ds = np.diff(stroke)
    if stroke.size < 3 or ds[0] <= 0:
        return float("nan")
    slope = np.diff(energy) / np.where(ds > 0, ds, np.nan)
    steep = np.flatnonzero(slope[1:] > STEEP_FACTOR * slope[0]) if slope[0] > 0 else np.array([], int)
    return float(stroke[steep[0] + 1]) if steep.size else float("nan")


def characteristics(rows: Sequence[dict]) -> Characteristics:
    """Flattening and pull-in voltages, stroke at 1 kV and the steep rise, from the CSV rows."""
    ok = [r for r in rows if r["status"] in EQUILIBRIA or r is rows[-1]]
    c = Characteristics()
    if not ok:
        return c
    v = np.array([r["voltage"] for r in ok])
    theta = np.array([r["bending_angle"] for r in ok])
    stroke = np.array([r["stroke"] for r in ok])
    c.theta0 = float(theta[0]) if v[0] == 0 else float("nan")
    below = np.flatnonzero(np.abs(theta) < FLAT_DEG)
    if below.size and below[0] > 0:
        i = below[0]  # the angle is close to linear in V^2 near flat
        t = (theta[i - 1] - FLAT_DEG) / (theta[i - 1] - theta[i])
        c.flat_voltage = float(np.sqrt(v[i - 1] ** 2 + t * (v[i] ** 2 - v[i - 1] ** 2)))
    elif below.size:
        c.flat_voltage = float(v[0])
    if v[0] <= PAPER_SUBSTANTIAL_V <= v[-1]:
        c.stroke_at_1kV = float(np.interp(PAPER_SUBSTANTIAL_V**2, v**2, stroke))
    if rows[-1]["status"] == "pull_in":
        c.pull_in_voltage = float(rows[-1]["voltage"])
    c.steep_stroke = steep_rise(stroke, np.array([r["energy_capacitor"] for r in ok]))
    if np.any(np.diff(stroke) < -1e-6):
        c.notes.append("the stroke is not monotonic in the voltage")
    return c


def describe(c: Characteristics, solver: str, v_max: float) -> str:
    """Sentences on the characteristic voltages, beside the paper's observations."""
    lines = [f"{solver.upper()}: bending angle at 0 V {c.theta0:.1f} deg"]
    if np.isfinite(c.flat_voltage):
        lines.append(f"  flat (bending angle < {FLAT_DEG:g} deg) at {c.flat_voltage:.0f} V "
                     f"(experiment: about {PAPER_FLAT_V:.0f} V)")
    else:
        lines.append(f"  not flat up to {v_max:g} V (experiment: flat at about {PAPER_FLAT_V:.0f} V)")
    lines.append(f"  stroke at 1 kV: {c.stroke_at_1kV:.1f} deg (experiment: a substantial change)")
    if np.isfinite(c.pull_in_voltage):
        lines.append(f"  pull-in (electromechanical instability) after {c.pull_in_voltage:.0f} V")
    else:
        lines.append("  no pull-in on the path")
    lines.append(f"  E_cap rises steeply from a stroke of {c.steep_stroke:.0f} deg "
                 f"(paper: {PAPER_STEEP_STROKE['numerical']:.0f} deg numerical, "
                 f"{PAPER_STEEP_STROKE['physical']:.0f} deg physical)")
    lines += [f"  note: {n}" for n in c.notes]
    return "\n".join(lines)


def run_actuation(scene: Scene, voltages: Voltages, solver: str, out_dir: str | Path,
                  refinement: int | None = None, progress: bool = True,
                  electrodes: Sequence[str] | None = None) -> list[dict]:
    """Run one solver's voltage sweep of the named ``electrodes`` (default: all), writing each
    state as it finishes; the CSV rows."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    label = f"actuate_{solver}_{scene.frame.model}"
    label_of = dict(zip(voltages.values, voltages.labels))
    rows: list[dict] = []
    entries: list[tuple[float, Path]] = []
    bar = tqdm(total=len(voltages.values), desc=label, unit="V", disable=not progress, leave=False)
    try:
        for res in voltage_states(scene, solver, voltages.values, refinement, electrodes):
            v = res.info["voltage_V"]
            name = label_of.get(v, format(Decimal(repr(v)).normalize(), "f"))
            entries.append((v, res.write_vtk(out / f"{label}_{name}V.vtu")))
            rows.append(row(res, rows[0] if rows else None))
            write_pvd(out / f"{label}.pvd", entries)
            write_csv(out / f"{label}.csv", rows, units={**UNITS, **{k: "deg" for k in rows[-1] if k.startswith("segment_")}})
            bar.set_postfix_str(f"V={name} theta={rows[-1]['bending_angle']:.1f} {res.status}")
            bar.update()
    finally:
        bar.close()
    return rows


def compare(a: Sequence[dict], b: Sequence[dict]) -> str:
    """Agreement of two solvers' sweeps at their common voltages: bending-angle and E_cap gaps."""
    vb = {r["voltage"]: r for r in b}
    common = [(r, vb[r["voltage"]]) for r in a if r["voltage"] in vb]
    if not common:
        return "no common voltages to compare"
    d_theta = max(abs(p["bending_angle"] - q["bending_angle"]) for p, q in common)
    d_stroke = max(abs(p["stroke"] - q["stroke"]) for p, q in common)
    rel_cap = max(abs(p["energy_capacitor"] - q["energy_capacitor"])
                  / max(abs(q["energy_capacitor"]), 1e-12) for p, q in common)
    return (f"DR against FEM over {len(common)} voltages: bending angle within {d_theta:.2f} deg, "
            f"stroke within {d_stroke:.2f} deg, E_cap within {100 * rel_cap:.1f} %")


def table(rows: Sequence[dict], title: str) -> str:
    """The printed table of a sweep."""
    return f"{title}\n{format_table(rows, TABLE)}"


def write_summary(out_dir: Path, text: str) -> Path:
    """The printed summary, kept beside the CSV."""
    return atomic_write_text(Path(out_dir) / "actuate.txt", text + "\n")


EXPERIMENT = ("The experiment (docs/actuation.md): all samples change shape substantially at about "
              f"{PAPER_SUBSTANTIAL_V / 1000:g} kV and are flat at about {PAPER_FLAT_V / 1000:g} kV (Fig. 4); "
              f"the energies rise steeply near {PAPER_STEEP_STROKE['numerical']:.0f} deg of stroke "
              f"(numerical) and {PAPER_STEEP_STROKE['physical']:.0f} deg (physical) (Fig. 5).")

SUMMARY = (("solver", "solver", ""), ("theta0", "angle at 0 V [deg]", ".2f"),
           ("stroke_at_1kV", "stroke at 1 kV [deg]", ".2f"), ("flat_voltage", "flat at [V]", ".0f"),
           ("pull_in_voltage", "pull-in after [V]", ".0f"), ("steep_stroke", "E_cap steep from [deg]", ".0f"),
           ("end", "path end", ""))


def write_report(out_dir: Path, scene: Scene, runs: dict[str, Sequence[dict]],
                 figures: Sequence[Path], notes: Sequence[str]) -> dict[str, Path]:
    """``report.md`` and a self-contained ``index.html``: the section "Against the experiment"."""
    rows = []
    for solver, sweep in runs.items():
        c = characteristics(sweep)
        rows.append({"solver": solver.upper(), "theta0": c.theta0, "stroke_at_1kV": c.stroke_at_1kV,
                     "flat_voltage": c.flat_voltage, "pull_in_voltage": c.pull_in_voltage,
                     "steep_stroke": c.steep_stroke, "end": sweep[-1]["status"] if sweep else "-"})
    title = (f"{scene.name}: voltage actuation, frame model '{scene.frame.model}', "
             f"pre-stretch {scene.prestretch:g}")
    sections = [Section("Against the experiment", [EXPERIMENT, Table(SUMMARY, rows), *notes, *figures])]
    sections += [Section(f"{solver.upper()} voltage sweep", [Table(TABLE, sweep)]) for solver, sweep in runs.items()]
    out = Path(out_dir)
    return {"md": atomic_write_text(out / "report.md", to_markdown(sections, title, out)),
            "html": atomic_write_text(out / "index.html", to_html(sections, title))}
