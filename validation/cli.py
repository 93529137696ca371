"""The ``demes`` command line; each command's route through the packages:

=========  =================================================================================
solve      ``dr.sweep`` or ``fem_reference.sweep`` per mesh level, written state by state
           (:func:`validation.solve.levels.record_states`), the discretisation error between
           levels (:mod:`validation.solve.mesh_error`) and other stable states
           (:mod:`validation.solve.other_starts`)
fem        solve with the FEM
actuate    :mod:`validation.actuation.actuate` (``dr.actuation`` / ``fem_reference.actuation``)
calibrate  :mod:`validation.actuation.calibrate`
validate   :mod:`validation.report.validate`: plan, runner, analysis, studies, report
sweep      :mod:`validation.design.sweep` over a grid (:mod:`validation.design.grid`)
gallery    :mod:`validation.solve.gallery`
bench      :mod:`validation.bench`
=========  =================================================================================

Each command imports the solvers and sub-packages it uses inside its function: importing
``dr`` (numba) takes about 2 s and ``fem_reference`` (scikit-fem) about 2 s, which a command
that needs neither, or ``--help``, does not pay.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path
from typing import Any, Iterator, Sequence

import scenes
from results import Result, atomic_write_text
from scenes import DemesError
from scenes.electric import driven_at
from scenes.fields import prestretch_list
from scenes.prestretch import parse_levels

from .common.executor import DEFAULT_WORKERS
from .common.interrupt import caused_by_interrupt, report_interrupt
from .design.grid import DEFAULT_MAX_POINTS
from .solve.levels import contact_note, print_table, record_states, state_notes


def _parse_value(text: str) -> Any:
    """A --set value: TOML-like literals (numbers, true/false, lists), numbers joined by commas
    as a list (as --prestretch takes a pair), or a bare string.

    >>> _parse_value("[1.3, 1.0]"), _parse_value("1.025,1.15"), _parse_value("gent"), _parse_value("a, 1")
    ([1.3, 1.0], [1.025, 1.15], 'gent', 'a, 1')
    """
    try:
        return json.loads(text)
    except (ValueError, RecursionError):  # not JSON (a bare word), or too deep / too many digits
        pass
    if "," in text:
        try:
            parts = [json.loads(p) for p in text.split(",")]
        except (ValueError, RecursionError):
            return text
        if all(isinstance(p, (int, float)) and not isinstance(p, bool) for p in parts):
            return parts
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


def _prestretches(args: argparse.Namespace, scene: scenes.Scene) -> tuple[scenes.Scene, list[float]]:
    """The scene with the pre-stretch pair ``--prestretch`` names (if it names pairs), and the
    requested path values, checked, sorted, each once (default: the scene's sweep)."""
    if not args.prestretch:
        return scene, sorted(set(scene.loading.sweep))
    pair, levels = parse_levels("--prestretch", args.prestretch)
    return (scene if pair is None else scene.updated(**{"loading.prestretch": list(pair)})), levels


def _unequal(scene: scenes.Scene) -> str:
    """The title's note of an unequal pre-stretch: what its levels lambda mean."""
    path = scene.prestretch_path
    if path.isotropic:
        return ""
    l1, l2 = path.pair(scene.prestretch)
    return (f"; pre-stretch {l1:g},{l2:g} along axes at {path.angle_deg:g} deg, applied along the line from 1,1 "
            "(lambda: the larger of the pair)")


def writable_folder(path: str | Path, option: str = "--out") -> Path:
    """``path`` as an output folder, created if missing and tested by writing to it, before any
    work is done (so that no solved state is lost to a bad folder)."""
    out = Path(path)
    if out.exists() and not out.is_dir():
        raise DemesError(f"{option} {str(out)!r} is a file, not a folder; give a folder name")
    try:
        out.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=out, prefix=".demes-write-test-"):
            pass
    except OSError as exc:
        raise DemesError(f"{option} {str(out)!r} cannot be written ({exc.strerror or exc}); give a folder "
                         "you can write to") from None
    return out


def _common(p: argparse.ArgumentParser, out_default: str) -> None:
    p.add_argument("scene", nargs="?", default="demes_paper", help="scene .toml or built-in name (default: demes_paper)")
    p.add_argument("--prestretch", nargs="+",
                   help="pre-stretch ratios, e.g. 1.1 1.3 1.5, or pairs l1,l2 on one line from 1,1, e.g. 1.15,1 1.3,1 "
                        "(default: the scene's sweep)")
    p.add_argument("--out", default=out_default, help=f"output folder (default: {out_default})")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="change a scene field, e.g. --set mesh.divisions=20")
    p.add_argument("--frame-model", choices=("strip", "paper"),
                   help="frame.model: 'strip' (the scene's default, the real strip) or 'paper' (Table I's isotropic beam)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")


def _run_solver(args: argparse.Namespace, solver: str) -> int:
    scene = load_scene(args)
    if solver == "fem" and args.refinement is not None:
        scene = scene.updated(**{"fem.refinement": args.refinement})
    scene, lams = _prestretches(args, scene)
    out = writable_folder(args.out)
    if solver == "dr":
        import dr

        states = dr.sweep(scene, lams)
        label = f"dr_{scene.frame.model}"
    else:
        import fem_reference

        refinement = scene.fem.refinement
        states = fem_reference.sweep(scene, lams, refinement=refinement)
        label = f"fem_{scene.frame.model}_r{refinement}"
    results = record_states(states, lams, out, label, progress=not args.no_progress)
    title = f"{scene.name}: {solver.upper()}, frame model '{scene.frame.model}'{_unequal(scene)}"
    text = print_table(results, title) + contact_note(results) + state_notes(results, lams)
    atomic_write_text(out / f"{label}.txt", text + "\n")
    print(f"wrote {out / (label + '.csv')}, {out / (label + '.pvd')} and {len(results)} .vtu states")
    if results:
        _render(results, out / f"{label}.png", title)
    return 0 if all(r.converged for r in results) else 2


def _render(results: Sequence[Result], path: Path, title: str) -> None:
    """A PNG of the states beside the CSV; a machine that cannot render says why and goes on."""
    from results.render import RenderUnavailable, render_states

    try:
        print(f"wrote {render_states(results, path, title)}")
    except RenderUnavailable as exc:
        print(f"demes: no picture: {exc}", file=sys.stderr)


def cmd_solve(args: argparse.Namespace) -> int:
    """The main job: a sweep on nested meshes, each state with its discretisation error."""
    from .common.tables import MESH_ERROR_TABLE
    from .solve import mesh_error, other_starts

    scene, lams = _prestretches(args, load_scene(args))
    out = writable_folder(args.out)
    if args.solver == "fem":
        scene = scene.updated(**{"fem.element": args.element})
        divisions_set = any(item.split("=", 1)[0].strip() == "mesh.divisions" for item in args.set or [])
        levels = mesh_error.check_levels(args.mesh_levels or mesh_error.fem_default_levels(scene, divisions_set))
        found = mesh_error.fem_levels(scene, lams, levels)
        what = f"FEM {args.element}"
    else:
        levels = mesh_error.check_levels(args.mesh_levels or mesh_error.dr_default_levels(scene))
        found = mesh_error.dr_levels(scene, lams, levels)
        what = f"DR, membrane net '{scene.dr.membrane_net}'"
    errors: dict[int, mesh_error.MeshError] = {}

    def states() -> Iterator[Result]:
        for me in found:
            errors[id(me.state)] = me
            if args.other_starts:
                other_starts.search(me.state)
            yield me.state

    def columns(res: Result) -> dict[str, Any]:
        return errors[id(res)].columns()

    label = f"{args.solver}_{scene.frame.model}"
    results = record_states(states(), lams, out, label, progress=not args.no_progress, extra=columns,
                        units=mesh_error.UNITS)
    title = (f"{scene.name}: {what}, frame model '{scene.frame.model}', mesh.divisions "
             f"{' '.join(map(str, levels))} (states on the finest; theta* and +- by Richardson over them)"
             f"{_unequal(scene)}")
    text = print_table(results, title, MESH_ERROR_TABLE, columns) + contact_note(results) + state_notes(results, lams)
    atomic_write_text(out / f"{label}.txt", text + "\n")
    print(f"wrote {out / (label + '.csv')}, {out / (label + '.pvd')} and {len(results)} .vtu states")
    if results:
        _render(results, out / f"{label}.png", f"{scene.name}: {what}, {levels[-1]} divisions")
    return 0 if all(r.converged for r in results) else 2


def cmd_fem(args: argparse.Namespace) -> int:
    return _run_solver(args, "fem")


def cmd_actuate(args: argparse.Namespace) -> int:
    from .actuation import actuate
    from .actuation.figures import energy_stroke, stroke_voltage

    scene = load_scene(args)
    if args.prestretch:
        scene, lams = _prestretches(args, scene)
        scene = scene.updated(prestretch=lams[-1])
    volts = actuate.parse_voltages(args.voltage)
    driven_at(scene, 0.0, args.electrode)  # a name the scene does not have stops here, before any solve
    out = Path(args.out)
    solvers = ("fem", "dr") if args.solver == "both" else (args.solver,)
    runs, texts = {}, []
    for solver in solvers:
        rows = actuate.run_actuation(scene, volts, solver, out, args.refinement, not args.no_progress,
                                     args.electrode)
        runs[solver] = rows
        title = (f"{scene.name}: {solver.upper()} voltage sweep, frame model '{scene.frame.model}', "
                 f"pre-stretch {scene.prestretch:g}" + (f", electrodes {', '.join(args.electrode)}" if args.electrode else ""))
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
    from .actuation import calibrate

    scene = load_scene(args)
    if args.prestretch:
        scene, lams = _prestretches(args, scene)
        scene = scene.updated(prestretch=lams[-1])
    cal = calibrate.calibrate(scene, args.refinement or 0)
    text = calibrate.describe(cal)
    print(text)
    out = Path(args.out)
    atomic_write_text(out / "calibration.txt", text + "\n")
    atomic_write_text(out / "calibration.json", json.dumps(
        {"membrane_E": cal.membrane_E, "frame_E": cal.frame_E, "sensitivities": cal.sensitivities,
         "residuals": cal.residuals, "implications": cal.implications}, indent=1))
    return 0


def cmd_validate(args: argparse.Namespace) -> int:
    from .report.validate import validate

    scene = load_scene(args)
    if not 1 <= args.workers <= 64:
        raise DemesError(f"--workers {args.workers}: give 1 to 64 worker processes")
    out = writable_folder(args.out or f"reports/{scene.name}{'_quick' if args.quick else ''}")
    if args.report_only and not (out / "runs").is_dir():
        raise DemesError(f"--report-only: {out} holds no runs; run `demes validate` without it first")
    files = validate(scene, out, quick=args.quick, workers=args.workers, progress=not args.no_progress,
                     scheduler=args.scheduler, solve=not args.report_only)
    print(f"wrote {out / 'index.html'} and {out / 'report.md'} in {files['elapsed_s']:.0f} s")
    return 0


def cmd_sweep(args: argparse.Namespace) -> int:
    from .design.grid import GridError, load_grid
    from .design.sweep import run_design_sweep

    try:
        grid = load_grid(args.grid, solver=args.solver, max_points=args.max_points)
    except GridError as exc:
        print(f"demes sweep: bad grid: {exc}", file=sys.stderr)
        return 1
    if not 1 <= args.workers <= 64:
        raise DemesError(f"--workers {args.workers}: give 1 to 64 worker processes")
    out = writable_folder(args.out or f"out/sweep/{grid.name}")
    study = run_design_sweep(grid, out, scheduler=args.scheduler, workers=args.workers, vtk=args.vtk,
                      progress=not args.no_progress)
    counts = study.table["status"].value_counts()
    print(f"{grid.n_points} points ({len(grid.families)} paths x {len(grid.prestretches)} pre-stretches), "
          f"{grid.solver.upper()}: " + ", ".join(f"{n} {status}" for status, n in counts.items())
          + f"; solved {len(study.solved)} path(s) now, in {study.wall_time:.1f} s")
    for key, error in study.failed.items():
        print(f"  path {key} failed: {error} (rerun to retry it)", file=sys.stderr)
    print(f"wrote {study.files['csv']}, {study.files['parquet']} and {len(study.files) - 2} plots in {out / 'figures'}")
    return 2 if study.failed else 0


def cmd_gallery(args: argparse.Namespace) -> int:
    from .solve.gallery import GALLERY, run_gallery, table

    if not 1 <= args.workers <= 64:
        raise DemesError(f"--workers {args.workers}: give 1 to 64 worker processes")
    names = args.scenes or list(GALLERY)
    lams = sorted(set(prestretch_list("--prestretch", args.prestretch)))
    out = writable_folder(args.out)
    rows = run_gallery(out, names, lams, divisions=args.divisions, workers=args.workers, scheduler=args.scheduler,
                       progress=not args.no_progress)
    print(table(rows), end="")
    unpictured = sorted({r["scene"] for r in rows if not (out / f"{r['scene']}.png").is_file()})
    if unpictured:
        print(f"demes: no picture for {', '.join(unpictured)}: this machine cannot render off-screen",
              file=sys.stderr)
    print(f"wrote {out / 'gallery.md'}, {out / 'gallery.csv'}, the states (.vtu) and the pictures")
    return 0 if rows and all(r["agree"] for r in rows) else 2


def cmd_bench(args: argparse.Namespace) -> int:
    from .bench import dr_cases as bench

    if not 1 <= args.repeats <= 100:
        raise DemesError(f"--repeats {args.repeats}: give 1 to 100 runs per case")
    from .common.tables import format_table

    if args.fem:
        from .bench import fem as bench_fem

        if not all(0 <= k <= 3 for k in args.levels):
            raise DemesError(f"--levels {' '.join(map(str, args.levels))}: give levels 0 to 3")
        if args.prestretch is not None and len(args.prestretch) != 1:
            raise DemesError("--prestretch: --fem times one state; give one pre-stretch, e.g. 1.3")
        lam = prestretch_list("--prestretch", args.prestretch or [1.3])[0]
        fem_rows = bench_fem.rows(levels=tuple(args.levels), prestretch=lam, repeats=args.repeats,
                                  grading=args.grading)
        print(json.dumps(fem_rows, indent=1) if args.json else format_table(fem_rows, bench_fem.COLUMNS))
        return 0
    if args.gallery is not None:
        from .bench import gallery as bench_gallery

        names = args.gallery or list(bench_gallery.SCENES)
        for name in names:
            scenes.load(name)  # a bad name fails here, before any work
        gallery_rows = bench_gallery.rows(names=names, repeats=args.repeats)
        print(json.dumps(gallery_rows, indent=1) if args.json else format_table(gallery_rows, bench_gallery.COLUMNS))
        return 0
    if args.spectrum:
        from .bench import spectrum as bench_spectrum

        lams = prestretch_list("--prestretch", args.prestretch or [1.3])
        if len(lams) != 1 or not 0 <= args.refinement <= 2:
            raise DemesError("--spectrum: give one --prestretch (e.g. 1.3) and --refinement 0 to 2")
        spectrum_rows = bench_spectrum.rows(prestretch=lams[0], refinement=args.refinement)
        print(json.dumps(spectrum_rows, indent=1) if args.json else format_table(spectrum_rows, bench_spectrum.COLUMNS))
        return 0
    if not args.strip:
        return bench.main(repeats=args.repeats)
    from .bench import strip as bench_strip

    if not 0 <= args.refinement <= 3:
        raise DemesError(f"--refinement {args.refinement}: give 0 to 3 (each halves the element size)")
    lams = sorted(set(prestretch_list("--prestretch", args.prestretch or [1.1, 1.3, 1.5])))
    rows = bench_strip.rows(nets=args.nets, dampings=args.dampings, prestretches=lams,
                            refinement=args.refinement, repeats=args.repeats, fem=not args.no_fem)
    if args.json:
        print(json.dumps(rows, indent=1))
    else:
        print(format_table(rows, bench_strip.COLUMNS))
    return 0


def _cluster_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--scheduler", metavar="tcp://HOST:8786",
                   help="run on this Dask cluster (default: a LocalCluster on this machine)")
    p.add_argument("--workers", type=int, default=DEFAULT_WORKERS,
                   help=f"LocalCluster worker processes (default {DEFAULT_WORKERS}; 1: run in this process)")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="demes", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("solve", help="form-find a scene over pre-stretch levels on nested meshes, each state "
                                     "with its discretisation error (FEM by default, DR with --solver dr)")
    _common(p, "out/solve")
    p.add_argument("--solver", choices=("fem", "dr"), default="fem",
                   help="fem (default: the smaller error for the time, docs/performance.md) or dr")
    p.add_argument("--element", choices=("P1", "P2"), default="P2", help="FEM membrane element (default P2)")
    p.add_argument("--mesh-levels", type=int, nargs="+", metavar="DIVISIONS",
                   help="mesh.divisions of the nested meshes, each twice the one before (default: FEM 20 40 80, "
                        "or d 2d 4d after --set mesh.divisions=d; DR the scene's mesh.divisions and two "
                        "halvings of it); one value: no error estimate")
    p.add_argument("--other-starts", action="store_true",
                   help="also relax each finest state's mirror image and the pre-stretch applied at once from the "
                        "lift (about three times the solver's time); a stable state of lower energy is named "
                        "under the table")
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
    p.add_argument("--electrode", action="append", metavar="NAME",
                   help="drive this one of the scene's [[electrodes]] (repeat for more; default: all); "
                        "the others hold their own voltage")
    p.set_defaults(func=cmd_actuate)
    p = sub.add_parser("calibrate", help="fit the film and frame moduli to the experiment (flat at 2.25 kV, the 0 V shape kept)")
    _common(p, "out/calibrate")
    p.add_argument("--refinement", type=int, help="FEM: halve the element size this many times")
    p.set_defaults(func=cmd_calibrate)
    p = sub.add_parser("validate", help="DR against the FEM reference: shapes, energies, speed, hard cases; writes a report")
    p.add_argument("scene", nargs="?", default="demes_paper", help="scene .toml or built-in name (default: demes_paper)")
    p.add_argument("--out", help="report folder (default: reports/<scene>[_quick])")
    p.add_argument("--quick", action="store_true", help="the study on a coarse mesh, checked against the scene's own mesh (what the tests run)")
    p.add_argument("--report-only", action="store_true",
                   help="solve nothing: rewrite the report from the runs finished in --out (unfinished ones are named)")
    _cluster_options(p)
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="change a scene field")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_validate)
    p = sub.add_parser("gallery", help="DR and the FEM on one discrete problem for built-in scenes of varied "
                                       "outlines: one table (agreement, branch, stability, jumps, time) and pictures")
    p.add_argument("--scenes", nargs="+", metavar="NAME", help="scene names or .toml files (default: the gallery's)")
    p.add_argument("--prestretch", type=float, nargs="+", default=[1.1, 1.3], help="pre-stretch levels (default 1.1 1.3)")
    p.add_argument("--divisions", type=int, default=14, help="mesh.divisions (default 14)")
    p.add_argument("--out", default="out/gallery", help="output folder (default: out/gallery)")
    _cluster_options(p)
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_gallery)
    p = sub.add_parser("sweep", help="design study over a grid of scene fields (GRID.toml), on a Dask cluster")
    p.add_argument("grid", help="grid file: base scene, swept fields, pre-stretch list (see examples/design_grid.toml)")
    p.add_argument("--out", help="output folder (default: out/sweep/<grid>); finished points there are kept")
    p.add_argument("--solver", choices=("dr", "fem"), help="solver (default: the grid's, else dr)")
    p.add_argument("--vtk", action="store_true", help="write a ParaView series per point (points/<id>/<id>.pvd)")
    p.add_argument("--max-points", type=int, default=DEFAULT_MAX_POINTS,
                   help=f"refuse larger grids (default {DEFAULT_MAX_POINTS})")
    _cluster_options(p)
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_sweep)
    p = sub.add_parser("bench", help="time the DR solver on the elastica and the paper DEMES")
    p.add_argument("--repeats", type=int, default=3, help="runs per case (median reported)")
    p.add_argument("--strip", action="store_true",
                   help="the strip DEMES for each net and damping, from flat, against the FEM on the same mesh")
    p.add_argument("--nets", nargs="+", default=["triangles", "links", "clustered"],
                   choices=["triangles", "links", "clustered"], help="with --strip: dr.membrane_net values")
    p.add_argument("--dampings", nargs="+", default=["kinetic", "viscous", "fire"],
                   choices=["kinetic", "viscous", "fire"], help="with --strip: dr.damping values")
    p.add_argument("--prestretch", nargs="+", type=float, default=None,
                   help="with --strip: levels (default 1.1 1.3 1.5); with --fem: the one state (default 1.3)")
    p.add_argument("--refinement", type=int, default=1, help="with --strip: fem.refinement (the triangles' mesh)")
    p.add_argument("--no-fem", action="store_true", help="with --strip: skip the FEM timing")
    p.add_argument("--fem", action="store_true",
                   help="the FEM reference: one state per element and level from flat (DOFs, Newton its, factorisations, time)")
    p.add_argument("--levels", nargs="+", type=int, default=[0, 1, 2], help="with --fem: refinement levels")
    p.add_argument("--gallery", nargs="*", default=None, metavar="SCENE",
                   help="gallery scenes (default wide_rectangle asymmetric_quadrilateral): DR triangles and the FEM "
                        "P1 on one mesh along the gallery's path, time, iterations and cost per iteration")
    p.add_argument("--spectrum", action="store_true",
                   help="the ends of K v = w M v at DR's state on the strip DEMES, per kind of masses, all DOFs "
                        "and frame held (what sets DR's steps)")
    p.add_argument("--grading", type=float, default=1.0,
                   help="with --fem: mesh.grading of the mesh (element size h0 / grading at the frame; 1 uniform)")
    p.add_argument("--json", action="store_true", help="with --strip, --fem, --gallery or --spectrum: rows as JSON")
    p.set_defaults(func=cmd_bench)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run a ``demes`` command. Exit codes: 0 done, 2 bad input (one line on stderr naming the
    field and the fix; argparse's usage errors too) or a state that did not converge, 130
    interrupted."""
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except DemesError as exc:
        print(f"demes: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    except BaseException as exc:
        # Ctrl-C inside compiled code arrives as a SystemError caused by the KeyboardInterrupt
        if not caused_by_interrupt(exc):
            raise
        return report_interrupt()


if __name__ == "__main__":
    sys.exit(main())
