"""The ``demes`` command line: solve (DR), fem (reference), bench, validate."""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path
from typing import Any, Sequence

import scenes
from results import atomic_write_text
from scenes import DemesError
from scenes.scene import prestretch_list

from .sweep import print_table, run_sweep, stop_notes


def _parse_value(text: str) -> Any:
    """A --set value: TOML-like literals (numbers, true/false, lists) or a bare string."""
    try:
        return json.loads(text)
    except (ValueError, RecursionError):  # not JSON (a bare word), or too deep / too many digits
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
    """The requested pre-stretches, checked, sorted, each once."""
    if not args.prestretch:
        return sorted(set(scene.loading.sweep))
    return sorted(set(prestretch_list("--prestretch", args.prestretch)))


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
    p.add_argument("--prestretch", type=float, nargs="+", help="pre-stretch ratios, e.g. 1.1 1.3 1.5 (default: the scene's sweep)")
    p.add_argument("--out", default=out_default, help=f"output folder (default: {out_default})")
    p.add_argument("--set", action="append", metavar="KEY=VALUE", help="change a scene field, e.g. --set mesh.divisions=20")
    p.add_argument("--frame-model", choices=("paper", "strip"), help="override frame.model")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")


def _run_solver(args: argparse.Namespace, solver: str) -> int:
    scene = load_scene(args)
    if solver == "fem" and args.refinement is not None:
        scene = scene.updated(**{"fem.refinement": args.refinement})
    lams = _prestretches(args, scene)
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


def cmd_validate(args: argparse.Namespace) -> int:
    from .validate import validate

    scene = load_scene(args)
    if not 1 <= args.workers <= 64:
        raise DemesError(f"--workers {args.workers}: give 1 to 64 worker processes")
    out = writable_folder(args.out or f"reports/{scene.name}{'_quick' if args.quick else ''}")
    files = validate(scene, out, quick=args.quick, workers=args.workers, progress=not args.no_progress)
    print(f"wrote {out / 'index.html'} and {out / 'report.md'} in {files['elapsed_s']:.0f} s")
    return 0


def cmd_bench(args: argparse.Namespace) -> int:
    from . import bench

    if not 1 <= args.repeats <= 100:
        raise DemesError(f"--repeats {args.repeats}: give 1 to 100 runs per case")
    if not args.strip:
        return bench.main(repeats=args.repeats)
    from . import bench_strip
    from .tables import format_table

    if not 0 <= args.refinement <= 3:
        raise DemesError(f"--refinement {args.refinement}: give 0 to 3 (each halves the element size)")
    lams = sorted(set(prestretch_list("--prestretch", args.prestretch)))
    rows = bench_strip.rows(nets=args.nets, dampings=args.dampings, prestretches=lams,
                            refinement=args.refinement, repeats=args.repeats, fem=not args.no_fem)
    if args.json:
        print(json.dumps(rows, indent=1))
    else:
        print(format_table(rows, bench_strip.COLUMNS))
    return 0


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
    p.add_argument("--strip", action="store_true",
                   help="the strip DEMES for each net and damping, from flat, against the FEM on the same mesh")
    p.add_argument("--nets", nargs="+", default=["triangles", "links", "clustered"],
                   choices=["triangles", "links", "clustered"], help="with --strip: dr.membrane_net values")
    p.add_argument("--dampings", nargs="+", default=["kinetic", "viscous", "fire"],
                   choices=["kinetic", "viscous", "fire"], help="with --strip: dr.damping values")
    p.add_argument("--prestretch", nargs="+", type=float, default=[1.1, 1.3, 1.5], help="with --strip: levels")
    p.add_argument("--refinement", type=int, default=1, help="with --strip: fem.refinement (the triangles' mesh)")
    p.add_argument("--no-fem", action="store_true", help="with --strip: skip the FEM timing")
    p.add_argument("--json", action="store_true", help="with --strip: rows as JSON")
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
    except KeyboardInterrupt:
        print("demes: interrupted; finished states are on disk", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
