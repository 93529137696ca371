"""docs/scenes.md is the page scenes.docs writes from the field specs, and lists every field."""

import dataclasses
from pathlib import Path

from scenes import docs
from scenes.scene import Scene

PAGE = Path(__file__).resolve().parent.parent / "docs" / "scenes.md"


def test_docs_scenes_md_is_generated_from_the_specs():
    assert PAGE.read_text() == docs.markdown(), "regenerate it: python -m scenes.docs > docs/scenes.md"


def test_every_scene_field_is_listed_with_unit_default_bounds_and_meaning():
    page = PAGE.read_text()
    tables = {**Scene.SECTIONS, **Scene.LISTS}
    names = [f.name for f in dataclasses.fields(Scene) if f.name not in tables]
    names += [f"{key}.{f.name}" for key, cls in tables.items() for f in dataclasses.fields(cls) if f.init]
    rows = {line.split("|")[1].strip().strip("`"): line for line in page.splitlines() if line.startswith("| `")}
    assert set(names) == set(rows)
    listed = [d for _, _, fields in docs.sections() for d in fields]
    assert all(d.bounds and d.meaning and d.unit and d.default for d in listed)
