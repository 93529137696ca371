"""The ``demes`` command line: solve (DR), fem (reference), actuate, calibrate, bench, validate."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any, Sequence

import scenes
from results import atomic_write_text

from .sweep import print_table, run_sweep, stop_notes


def _parse_value(text: str) -> Any:
    """A --set value: TOML-like literals (numbers, true/false, lists) or a bare string."""
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        return text


def load_scene(args: argparse.Namespace) -> scenes.Scene:
    """The scene named on the command line, with --frame-model and --set changes applied."""
    scene = scenes.load(args.scene)
    changes: dict[str, Any] = {}
    for item in args.set or []:
        if "=" not in item:
            raise scenes.SceneError(f"--set {item!r}: write it as section.field=value, e.g. mesh.divisions=20")
        key, value = item.split("=", 1)
        changes[key.strip()] = _parse_value(value.strip())
    if getattr(args, "frame_model", None):
        changes["frame.model"] = args.frame_model
    return scene.updated(**changes) if changes else scene


def _prestretches(args: argparse.Namespace, scene: scenes.Scene) -> list[float]:
    values = args.prestretch if args.prestretch else list(scene.loading.sweep)
    for v in values:
        if v < 1.0:
            raise scenes.SceneError(f"--prestretch {v:g} is below 1: pre-stretch is a ratio (1.5 = 150 %)")
    return sorted(values)


def _common(p: argparse.ArgumentParser, out_default: str) -> None:
    p.add_argument("scene", nargs="?", default="demes_paper", help="scene .toml or built-in name (default: demes_paper)")
    p.add_argument("--prestretch", type=float, nargs="+", help="pre-stretch ratios, e.g. 1.1 1.3 1.5 (default: the scene's sweep)")
    p.add_argument("--out", default=out_default, help=f"output folder (default: {out_default})")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="change a scene field, e.g. --set mesh.divisions=20")
    p.add_argument("--frame-model", choices=("paper", "strip"), help="override frame.model")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")


def _run_solver(args: argparse.Namespace, solver: str) -> int:
    scene = load_scene(args)
    lams = _prestretches(args, scene)
    out = Path(args.out)
    if solver == "dr":
        import dr

        states = dr.sweep(scene, lams)
        label = f"dr_{scene.frame.model}"
    else:
        import fem_reference

        refinement = scene.fem.refinement if args.refinement is None else args.refinement
        states = fem_reference.sweep(scene, lams, refinement=refinement)
        label = f"fem_{scene.frame.model}_r{refinement}"
    results = run_sweep(states, lams, out, label, progress=not args.no_progress)
    title = f"{scene.name}: {solver.upper()}, frame model '{scene.frame.model}'"
    text = print_table(results, title) + stop_notes(results, lams)
    atomic_write_text(out / f"{label}.txt", text + "\n")
    print(f"wrote {out / (label + '.csv')}, {out / (label + '.pvd')} and {len(results)} .vtu states")
    return 0 if all(r.converged for r in results) else 2


def cmd_solve(args: argparse.Namespace) -> int:
    return _run_solver(args, "dr")


def cmd_fem(args: argparse.Namespace) -> int:
    return _run_solver(args, "fem")


def cmd_actuate(args: argparse.Namespace) -> int:
    from . import actuate
    from .actuation_figures import energy_stroke, stroke_voltage

    scene = load_scene(args)
    if args.prestretch:
        scene = scene.updated(prestretch=_prestretches(args, scene)[-1])
    volts = actuate.parse_voltages(args.voltage)
    out = Path(args.out)
    solvers = ("fem", "dr") if args.solver == "both" else (args.solver,)
    runs, texts = {}, []
    for solver in solvers:
        rows = actuate.run_actuation(scene, volts, solver, out, args.refinement, not args.no_progress)
        runs[solver] = rows
        title = (f"{scene.name}: {solver.upper()} voltage sweep, frame model '{scene.frame.model}', "
                 f"pre-stretch {scene.prestretch:g}")
        block = [actuate.table(rows, title),
                 actuate.describe(actuate.characteristics(rows), solver, volts.values[-1])]
        block += [f"  {r['status']}: {r['message']}" for r in rows if not r["converged"]]
        print("\n".join(block), flush=True)
        texts += block
    notes = [actuate.compare(runs["dr"], runs["fem"])] if len(runs) == 2 else []
    print("\n".join(notes))
    texts += notes
    figures = [stroke_voltage(runs, out / "stroke_voltage.png"), energy_stroke(runs, out / "energy_stroke.png")]
    actuate.write_summary(out, "\n".join(["# Against the experiment (docs/actuation.md)", *texts]))
    actuate.write_report(out, scene, runs, figures, notes)
    print(f"wrote {out}: report.md, index.html, CSV, .pvd series (time = volts), figures")
    return 0 if all(r[-1]["converged"] for r in runs.values()) else 2


def cmd_calibrate(args: argparse.Namespace) -> int:
    from . import calibrate

    scene = load_scene(args)
    if args.prestretch:
        scene = scene.updated(prestretch=_prestretches(args, scene)[-1])
    cal = calibrate.calibrate(scene, args.refinement or 0)
    text = calibrate.describe(cal)
    print(text)
    out = Path(args.out)
    atomic_write_text(out / "calibration.txt", text + "\n")
    atomic_write_text(out / "calibration.json", json.dumps(
        {"membrane_E": cal.membrane_E, "frame_E": cal.frame_E, "sensitivities": cal.sensitivities,
         "residuals": cal.residuals, "implications": cal.implications, "tried": cal.tried}, indent=1))
    return 0


def cmd_validate(args: argparse.Namespace) -> int:
    from .validate import validate

    scene = load_scene(args)
    out = Path(args.out or f"reports/{scene.name}{'_quick' if args.quick else ''}")
    files = validate(scene, out, quick=args.quick, workers=args.workers, progress=not args.no_progress)
    print(f"wrote {out / 'index.html'} and {out / 'report.md'} in {files['elapsed_s']:.0f} s")
    return 0


def cmd_bench(args: argparse.Namespace) -> int:
    from . import bench

    return bench.main(repeats=args.repeats)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="demes", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("solve", help="form-find a scene by dynamic relaxation over pre-stretch levels")
    _common(p, "out/solve")
    p.set_defaults(func=cmd_solve)
    p = sub.add_parser("fem", help="solve a scene with the scikit-fem reference")
    _common(p, "out/fem")
    p.add_argument("--refinement", type=int, help="halve the element size this many times")
    p.set_defaults(func=cmd_fem)
    p = sub.add_parser("actuate", help="sweep the voltage from the pre-stretched equilibrium: stroke, energies, flat / pull-in")
    _common(p, "out/actuate")
    p.add_argument("--voltage", default="0:3000:100", help="start:stop:step or a list a,b,c in volts (default 0:3000:100)")
    p.add_argument("--solver", choices=("dr", "fem", "both"), default="fem", help="which solver (both: agreement reported)")
    p.add_argument("--refinement", type=int, help="FEM: halve the element size this many times")
    p.set_defaults(func=cmd_actuate)
    p = sub.add_parser("calibrate", help="fit the film and frame moduli to the experiment (flat at 2.25 kV, the 0 V shape kept)")
    _common(p, "out/calibrate")
    p.add_argument("--refinement", type=int, help="FEM: halve the element size this many times")
    p.set_defaults(func=cmd_calibrate)
    p = sub.add_parser("validate", help="DR against the FEM reference: shapes, energies, speed, hard cases; writes a report")
    p.add_argument("scene", nargs="?", default="demes_paper", help="scene .toml or built-in name (default: demes_paper)")
    p.add_argument("--out", help="report folder (default: reports/<scene>[_quick])")
    p.add_argument("--quick", action="store_true", help="coarse, short study (under 2 minutes; what the tests run)")
    p.add_argument("--workers", type=int, default=2, help="parallel solver processes (default 2)")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="change a scene field")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_validate)
    p = sub.add_parser("bench", help="time the DR solver on the elastica and the paper DEMES")
    p.add_argument("--repeats", type=int, default=3, help="runs per case (median reported)")
    p.set_defaults(func=cmd_bench)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except scenes.SceneError as exc:
        print(f"demes: bad scene: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("demes: interrupted; finished states are on disk", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
