"""A design grid for ``demes sweep GRID.toml``: which scenes to solve, checked before any solve.

A grid file names the base scene, fixed changes, the swept scene fields (``section.field``,
as ``--set`` spells them) and the pre-stretch list::

    scene = "demes_paper"            # built-in name, or a .toml path (relative to this file)
    solver = "dr"                    # or "fem"; `demes sweep --solver` overrides it
    prestretch = [1.1, 1.2, 1.3]     # every point is solved at each (default: the scene's sweep);
                                     # or pairs on one line from 1: [[1.1, 1.0], [1.3, 1.0]]

    [set]                            # fixed changes to the base scene
    frame.model = "strip"

    [product]                        # every combination of these value lists
    frame.thickness = [0.1, 0.127]
    membrane.E = [0.8, 1.0, 1.2]

    [[points]]                       # and/or listed points (each one combined with the product)
    frame.width = 3.0

The points of the grid that differ only in pre-stretch form a :class:`Family`: one path,
warm-started from each pre-stretch to the next, and one task on the cluster.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import scenes
from scenes import tomllib
from scenes.fields import prestretch_list
from scenes.prestretch import parse_levels
from scenes.scene import parent_table

DEFAULT_MAX_POINTS = 10_000
"""Largest grid (points, pre-stretches included) run without ``--max-points``."""

GRID_KEYS = ("scene", "solver", "prestretch", "set", "product", "points")
SOLVERS = ("dr", "fem")
_PRESTRETCH_FIELDS = ("prestretch", "loading.prestretch", "loading.sweep")


class GridError(ValueError):
    """A bad grid file; the message names the key or field and says how to fix it."""


@dataclass(frozen=True)
class Family:
    """The grid points that differ only in pre-stretch: one warm-started path, one task.

    Attributes
    ----------
    key
        Digest of the solver and the scene (less its pre-stretch): the folder of its records,
        so a changed scene is never mistaken for a finished one.
    fields
        The swept fields' values at this point (dotted names, as the scene checked them).
    """

    key: str
    solver: str
    fields: dict[str, Any]
    scene_data: dict[str, Any]
    prestretches: tuple[float, ...]


@dataclass(frozen=True)
class Grid:
    """A checked design grid: its families (grid order) and what the table's columns are."""

    name: str
    solver: str
    fields: tuple[str, ...]
    prestretches: tuple[float, ...]
    families: tuple[Family, ...]

    @property
    def n_points(self) -> int:
        return len(self.families) * len(self.prestretches)


def load_grid(path: str | Path, solver: str | None = None, max_points: int = DEFAULT_MAX_POINTS) -> Grid:
    """Read and check a grid file (see the module doc); ``solver`` overrides the file's.

    Raises
    ------
    GridError
        Unknown key or field, empty or non-list values, a value the scene rejects, or more
        than ``max_points`` points.
    """
    path = Path(path)
    if not path.exists():
        raise GridError(f"grid file {str(path)!r} not found")
    try:
        data = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise GridError(f"{path}: not valid TOML: {exc}") from None
    try:
        return grid_from_dict(data, name=path.stem, base_dir=path.parent, solver=solver, max_points=max_points)
    except GridError as exc:
        raise GridError(f"{path}: {exc}") from None


def grid_from_dict(data: dict[str, Any], *, name: str = "grid", base_dir: Path = Path("."),
                   solver: str | None = None, max_points: int = DEFAULT_MAX_POINTS) -> Grid:
    """A checked :class:`Grid` from the parsed grid file ``data`` (scene paths relative to
    ``base_dir``)."""
    unknown = sorted(set(data) - set(GRID_KEYS))
    if unknown:
        raise GridError(f"unknown key {unknown[0]!r}; a grid has: {', '.join(GRID_KEYS)}")
    solver = solver or data.get("solver", "dr")
    if solver not in SOLVERS:
        raise GridError(f"solver = {solver!r} must be one of {', '.join(SOLVERS)}")
    base = _base_scene(data.get("scene", "demes_paper"), base_dir)
    fixed = _flat(_table(data, "set"), "set")
    base = _checked(base, fixed, "[set]")
    product = _flat(_table(data, "product"), "product")
    _no_prestretch(product)
    for field, values in product.items():
        if not isinstance(values, list):
            raise GridError(f"product field {field!r} = {values!r} must be a list of values, e.g. [{values!r}]")
        if not values:
            raise GridError(f"product field {field!r} has an empty list: give it at least one value")
    points = _points(data.get("points", []), base)
    both = sorted(set(product) & {f for p in points for f in p})
    if both:
        raise GridError(f"field {both[0]!r} is both in [product] and in [[points]]: sweep it in one of them")
    try:
        if "prestretch" in data and not isinstance(data["prestretch"], list):
            raise scenes.SceneError("prestretch must be a list of pre-stretches, e.g. [1.1, 1.3] or [[1.1, 1.0], [1.3, 1.0]]")
        pair, levels = parse_levels("prestretch", data.get("prestretch", list(base.loading.sweep)))
        prestretches = tuple(prestretch_list("prestretch", levels))
        if pair is not None:
            base = base.updated(**{"loading.prestretch": list(pair)})
    except scenes.SceneError as exc:
        raise GridError(str(exc)) from None
    if len({f"{v:.4f}" for v in prestretches}) < len(prestretches):
        raise GridError(f"prestretch = {list(prestretches)} repeats a value (to 4 decimals)")
    n_points = len(points or [{}]) * math.prod(len(v) for v in product.values()) * len(prestretches)
    if n_points > max_points:
        sizes = [f"{len(points)} listed points"] * bool(points) + [f"{len(v)} {k}" for k, v in product.items()]
        raise GridError(
            f"the grid has {n_points} points ({' x '.join([*sizes, f'{len(prestretches)} pre-stretches'])}), "
            f"more than the limit of {max_points}: raise it with --max-points {n_points} if you mean it"
        )
    for field, values in product.items():
        for value in values:
            _checked(base, {field: value}, f"product field {field!r}")
    fields = tuple(dict.fromkeys([*(f for p in points for f in p), *product]))
    families = []
    for point in points or [{}]:
        for combo in itertools.product(*product.values()):
            changes = {**point, **dict(zip(product, combo))}
            scene = _checked(base, changes, "grid point " + ", ".join(f"{k} = {v!r}" for k, v in changes.items()))
            scene_data = scene.to_dict()
            values = {f: _lookup(scene_data, f) for f in fields}
            families.append(Family(_key(solver, scene_data), solver, values, scene_data, prestretches))
    seen: dict[str, Family] = {}
    for family in families:
        if family.key in seen:
            raise GridError(f"the grid has the point {family.fields} twice: give each value once")
        seen[family.key] = family
    return Grid(name, solver, fields, prestretches, tuple(families))


def _base_scene(source: Any, base_dir: Path) -> scenes.Scene:
    if not isinstance(source, str):
        raise GridError(f"scene = {source!r} must be a built-in scene name or a path to a .toml file")
    local = base_dir / source
    try:
        return scenes.load(local if local.is_file() else source)
    except scenes.SceneError as exc:
        raise GridError(f"scene = {source!r}: {exc}") from None


def _table(data: dict[str, Any], key: str) -> dict[str, Any]:
    table = data.get(key, {})
    if not isinstance(table, dict):
        raise GridError(f"{key} must be a table of section.field = value entries, e.g. [{key}] frame.width = 4.0")
    return table


def _flat(table: dict[str, Any], where: str, prefix: str = "") -> dict[str, Any]:
    """``{frame: {width: 4}}`` (TOML's dotted keys) and ``{"frame.width": 4}`` both as
    ``{"frame.width": 4}``."""
    out: dict[str, Any] = {}
    for key, value in table.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            out.update(_flat(value, where, f"{name}."))
        elif name in out:
            raise GridError(f"[{where}] gives field {name!r} twice")
        else:
            out[name] = value
    return out


def _points(points: Any, base: scenes.Scene) -> list[dict[str, Any]]:
    if not isinstance(points, list) or not all(isinstance(p, dict) for p in points):
        raise GridError("points must be an array of tables: [[points]] followed by section.field = value lines")
    flat = [_flat(p, "points") for p in points]
    for i, point in enumerate(flat):
        _no_prestretch(point)
        if not point:
            raise GridError(f"points[{i}] is empty: give it at least one section.field = value")
        _checked(base, point, f"points[{i}]")
    return flat


def _no_prestretch(fields: dict[str, Any]) -> None:
    for field in fields:
        if field in _PRESTRETCH_FIELDS:
            raise GridError(f"field {field!r}: pre-stretch is swept by the top-level 'prestretch = [...]' list")


def _checked(base: scenes.Scene, changes: dict[str, Any], where: str) -> scenes.Scene:
    try:
        return base.updated(**changes) if changes else base
    except scenes.SceneError as exc:
        raise GridError(f"{where}: {exc}") from None


def _lookup(data: dict[str, Any], field: str) -> Any:
    table, last = parent_table(data, field)
    return table[last]


def _key(solver: str, scene_data: dict[str, Any]) -> str:
    """Digest of what a family's results depend on: the solver and the scene less its name and
    pre-stretch."""
    scene = {k: v for k, v in scene_data.items() if k not in ("name", "description")}
    loading = scene["loading"]
    p = loading["prestretch"]
    path = scenes.PrestretchPath.of(tuple(p) if isinstance(p, list) else p, loading["prestretch_angle"])
    scene["loading"] = {k: v for k, v in loading.items() if k not in ("prestretch", "sweep")}
    if not path.isotropic:  # the line the pair is applied on, not where along it
        scene["loading"]["prestretch_rise"] = list(path.rise)
    text = json.dumps({"solver": solver, "scene": scene}, sort_keys=True)
    return hashlib.sha1(text.encode()).hexdigest()[:12]
