"""Electrodes over regions of the film: where the Maxwell stress acts, and at what voltage.

A scene without ``[[electrodes]]`` has one electrode pair over the whole film at
``loading.voltage``. Each ``[[electrodes]]`` table instead names a polygon of the flat scene
(mm) and its own voltage; the film is an ideal dielectric under each electrode and passive
elsewhere. Electrodes may share a side but not overlap, and each must cover some film. On a mesh,
a triangle carries the dielectric energy of the fraction of its flat area under each electrode
(:func:`coverage`, exact polygon clipping by shapely), so the electrode's edge need not follow
the mesh and its energy converges with the mesh as the film's does.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np
import shapely

from .errors import SceneError
from .fields import Section, checked, non_negative, show_value, spec, vertex_list
from .geometry import Outline

OVERLAP = 1e-9
"""Shared area, as a fraction of the smaller electrode, above which two electrodes overlap
(below it they share a side, to round-off)."""


@checked("text of 1 to 40 characters, no '.'; unique; default e1, e2, ... by place")
def electrode_name(name: str, value: Any) -> str:
    if not isinstance(value, str) or not 0 < len(value) <= 40 or not value.isprintable() or "." in value:
        raise SceneError(f"{name} = {show_value(value)} must be a short text without '.', e.g. \"left\"")
    return value


@dataclass(frozen=True)
class ElectrodeSpec(Section):
    """Electrodes over parts of the film, one [[electrodes]] table each: a polygon of the flat
    scene and its voltage. The film under no electrode is passive; a triangle partly under one
    carries that share of its area. Electrodes may share a side but not overlap. Change one by
    its name: --set electrodes.left.voltage=2000. Without any, one electrode covers the whole
    film at loading.voltage."""

    _prefix = "electrodes"
    name: str = spec("e1", electrode_name, "", "the electrode's name (demes actuate --electrode NAME drives it)")
    region: Any = spec(None, vertex_list, "mm",
                       "polygon of the electrode in the flat scene's x, y; the film inside it is actuated",
                       bounds=f"required: {vertex_list.bounds}; a simple polygon over some film")
    voltage: float = spec(0.0, non_negative, "V", "voltage across the film under this electrode")

    @property
    def polygon(self) -> shapely.Polygon:
        """The region as a shapely polygon (mm)."""
        return shapely.Polygon(self.region)


def _item_name(key: str, k: int, message: str) -> str:
    """A section's error message with ``key.`` turned into ``key[k].`` (the k-th table)."""
    return message.replace(f"{key}.", f"{key}[{k}].", 1).replace(f"[{key}]", f"[[{key}]] table {k}", 1)


def electrodes_from_list(data: Any) -> tuple[ElectrodeSpec, ...]:
    """The ``[[electrodes]]`` tables as checked records, each error naming its table by index;
    an unnamed electrode is named e1, e2, ... by its place."""
    if not isinstance(data, (list, tuple)):
        raise SceneError("electrodes must be a list of tables: write each as [[electrodes]] with "
                         "name, region and voltage")
    if len(data) > 64:
        raise SceneError(f"electrodes: {len(data)} tables; a scene has at most 64 electrodes")
    out = []
    for k, item in enumerate(data):
        if isinstance(item, ElectrodeSpec):
            out.append(item)
            continue
        try:
            if not isinstance(item, dict):
                raise SceneError(f"[electrodes] must be a table of fields, not {show_value(item)}")
            if "region" not in item:
                raise SceneError("electrodes.region is missing: give the electrode's polygon, e.g. "
                                 "[[-10, 0], [10, 0], [10, 20], [-10, 20]]")
            out.append(ElectrodeSpec.from_dict({"name": f"e{k + 1}", **item}))
        except SceneError as e:
            raise SceneError(_item_name("electrodes", k, str(e))) from None
    return tuple(out)


def check_electrodes(electrodes: Sequence[ElectrodeSpec], outline: Outline, voltage: float,
                     open_regions: Sequence[shapely.Polygon] = ()) -> None:
    """Electrodes a scene can model: unique names, simple polygons that cover film and do not
    overlap or reach into an open window (``open_regions``, :mod:`scenes.windows`), and no
    whole-film ``loading.voltage`` beside them. Raises :class:`SceneError`."""
    if not electrodes:
        return
    if voltage > 0:
        raise SceneError(
            f"loading.voltage = {voltage:g} V is the voltage of one electrode over the whole film; "
            "with [[electrodes]] give each electrode its voltage and set loading.voltage = 0")
    names = [e.name for e in electrodes]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise SceneError(f"electrodes: the name {twice[0]!r} is used twice; give each electrode its own name")
    film = shapely.Polygon(outline.polyline(outline.side_length / 400)[0])
    polygons = []
    for k, e in enumerate(electrodes):
        if Outline._self_intersects(np.asarray(e.region)):
            raise SceneError(f"electrodes[{k}].region ({e.name!r}) is not a simple polygon: its sides cross")
        p = e.polygon
        if p.area <= 0:
            raise SceneError(f"electrodes[{k}].region ({e.name!r}) has no area: its points lie on one line")
        if film.intersection(p).area <= OVERLAP * p.area:
            raise SceneError(f"electrodes[{k}].region ({e.name!r}) covers no film: it lies outside the "
                             "frame's outline; give its polygon in the flat scene's x, y (mm)")
        for j, window in enumerate(open_regions):
            if window.intersection(p).area > OVERLAP * p.area:
                x, y = window.representative_point().coords[0]
                raise SceneError(
                    f"electrodes[{k}].region ({e.name!r}) reaches into the open window round [{x:.3g}, {y:.3g}] "
                    f"(frame.open_windows[{j}]), which has no film: trim the region to the covered windows, or "
                    "cover that window with film")
        polygons.append(p)
    for i in range(len(polygons)):
        for j in range(i + 1, len(polygons)):
            shared = polygons[i].intersection(polygons[j]).area
            if shared > OVERLAP * min(polygons[i].area, polygons[j].area):
                raise SceneError(
                    f"electrodes {names[i]!r} and {names[j]!r} overlap ({shared:.3g} mm^2): one film "
                    "area has one voltage; let them share a side at most")


def coverage(electrodes: Sequence[ElectrodeSpec], corners: np.ndarray) -> np.ndarray:
    """Fraction (t, e) of each flat triangle's area under each electrode, from its corners
    (t, 3, 2+) mm: exact polygon clipping."""
    corners = np.asarray(corners, float)[:, :, :2]
    triangles = shapely.polygons(np.concatenate([corners, corners[:, :1]], axis=1))
    area = shapely.area(triangles)
    out = np.empty((len(corners), len(electrodes)))
    for k, e in enumerate(electrodes):
        out[:, k] = shapely.area(shapely.intersection(triangles, e.polygon)) / area
    return np.clip(out, 0.0, 1.0)
