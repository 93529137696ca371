"""The page of every scene field, docs/scenes.md, written from the field specs of
:mod:`scenes.scene` (their unit, default, bounds and meaning): ``python -m scenes.docs > docs/scenes.md``."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

from .scene import Scene


@dataclass(frozen=True)
class FieldDoc:
    """One scene field as the page lists it: its dotted TOML name and its spec in words."""

    name: str
    unit: str
    default: str
    bounds: str
    meaning: str


INTRO = """# Scene fields

A scene is a TOML file of the tables below (the built-in one: `scenes/demes_paper.toml`).
`demes solve my_scene.toml` and `demes validate my_scene.toml` read one (a built-in by its name,
default `demes_paper`), `--set mesh.divisions=20` changes a field by its dotted name, and so
does `scene.updated(**{"mesh.divisions": 20})` in code. Every field may be left out (it takes
its default) and is checked when the scene is built: a bad value stops with a message naming the
field and the fix. Units: mm, N, MPa (N/mm^2), V, s; '-' is a ratio or a choice.

This page is generated from the field specs in `scenes/` (`scene.py`, `frame.py`, `electrodes.py`) by
`python -m scenes.docs > docs/scenes.md`; a test checks that it is up to date.
"""


def toml_value(value: Any) -> str:
    """A default as it is written in a scene TOML ('unset' where the field has none)."""
    if value is None:
        return "unset"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    return f"{value:g}" if isinstance(value, float) else str(value)


def _describe(f: dataclasses.Field, prefix: str) -> FieldDoc:
    return FieldDoc(name=f"{prefix}{f.name}", unit=f.metadata["unit"] or "-", default=toml_value(f.default),
                    bounds=f.metadata["bounds"], meaning=f.metadata["doc"])


def _spec_fields(cls: type) -> list[dataclasses.Field]:
    return [f for f in dataclasses.fields(cls) if "doc" in f.metadata]


def sections() -> list[tuple[str, str, list[FieldDoc]]]:
    """(TOML table, what it holds, its fields) for the scene's top level and each section."""
    top = ("", "The scene's name and description, at the top of the file.",
           [_describe(f, "") for f in _spec_fields(Scene)])
    tables = {**Scene.SECTIONS, **Scene.LISTS}
    return [top] + [(key, " ".join((cls.__doc__ or "").split()), [_describe(f, f"{key}.") for f in _spec_fields(cls)])
                    for key, cls in tables.items()]


def _cell(text: str) -> str:
    return text.replace("|", "\\|")


def markdown() -> str:
    """docs/scenes.md."""
    out = [INTRO]
    for key, what, fields in sections():
        heading = f"[[{key}]]" if key in Scene.LISTS else f"[{key}]" if key else "Top level"
        out += [f"## {heading}", "", what, "",
                "| field | unit | default | accepted | meaning |", "| --- | --- | --- | --- | --- |"]
        out += [f"| `{d.name}` | {_cell(d.unit)} | `{_cell(d.default)}` | {_cell(d.bounds)} | {_cell(d.meaning)} |"
                for d in fields]
        out.append("")
    return "\n".join(out)


if __name__ == "__main__":
    print(markdown(), end="")
