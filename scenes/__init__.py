"""Scenes: what is modelled (frame, membrane, pre-stretch, supports, mesh), solver-independent.

>>> import scenes
>>> scene = scenes.load("demes_paper")          # the built-in paper scene (Table I)
>>> scene.frame.model, scene.prestretch, scene.mesh.divisions
('strip', 1.5, 28)
>>> scene.updated(**{"frame.model": "paper", "mesh.divisions": 20}).frame.model
'paper'
"""

from __future__ import annotations

import re
import sys
from pathlib import Path
from typing import Any

from .errors import DemesError, SceneError
from .geometry import Outline
from .prestretch import PrestretchPath
from .scene import (
    DRSpec,
    FEMSpec,
    FrameSpec,
    LoadingSpec,
    MembraneSpec,
    MeshSpec,
    PerturbationSpec,
    Scene,
    SupportSpec,
)

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

BUILTIN_DIR = Path(__file__).parent

__all__ = [
    "Scene",
    "SceneError",
    "DemesError",
    "Outline",
    "PrestretchPath",
    "FrameSpec",
    "MembraneSpec",
    "LoadingSpec",
    "SupportSpec",
    "PerturbationSpec",
    "MeshSpec",
    "DRSpec",
    "FEMSpec",
    "load",
    "paper_demes",
    "builtin_scenes",
]


def builtin_scenes() -> list[str]:
    """Names of the scenes shipped with the package."""
    return sorted(p.stem for p in BUILTIN_DIR.glob("*.toml"))


MAX_FILE_BYTES = 1_000_000
"""Largest scene file read (a scene is a few hundred bytes)."""


def load(source: str | Path) -> Scene:
    """Read and check a scene from a TOML file path or a built-in scene name.

    Raises
    ------
    SceneError
        If the file is missing, unreadable, not UTF-8 or not TOML, or a field is bad; the
        message names the field.
    """
    if not isinstance(source, (str, Path)) or not str(source).strip():
        raise SceneError(f"scene {source!r}: give a path to a .toml file or a built-in scene name")
    try:
        path = Path(source)
        if not path.exists() and path.suffix == "" and (BUILTIN_DIR / f"{path.name}.toml").exists():
            path = BUILTIN_DIR / f"{path.name}.toml"
        found = path.is_file()
        size = path.stat().st_size if found else 0
    except (OSError, ValueError) as exc:  # a name too long, a NUL in it, ...
        why = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise SceneError(f"scene file {str(source)[:80]!r} cannot be read: {why}") from None
    if not found:
        raise SceneError(
            f"scene file {str(source)[:200]!r} not found (or not a file); give a path to a .toml file "
            f"or one of the built-in scenes: {', '.join(builtin_scenes())}"
        )
    if size > MAX_FILE_BYTES:
        raise SceneError(f"{path}: {size} bytes is too large for a scene file (at most {MAX_FILE_BYTES})")
    try:
        data = tomllib.loads(path.read_bytes().decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise SceneError(f"{path}: not UTF-8 text (byte {exc.start}); save the scene as UTF-8") from None
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{path}: not valid TOML: {exc}") from None
    except RecursionError:
        raise SceneError(f"{path}: not a scene: its tables or arrays are nested too deeply") from None
    except ValueError as exc:  # the parser's int() refuses integers longer than sys.get_int_max_str_digits()
        if "integer string conversion" not in str(exc):
            raise SceneError(f"{path}: not valid TOML: {exc}") from None
        raise SceneError(f"{path}: {_long_integer_field(path.read_bytes().decode('utf-8'))} is an integer "
                         "too long to read; write a number of a few digits") from None
    except OSError as exc:
        raise SceneError(f"{path}: cannot be read: {exc.strerror or exc}") from None
    data.setdefault("name", path.stem)
    return Scene.from_dict(data)


def _long_integer_field(text: str) -> str:
    """The dotted name of the first field of TOML ``text`` whose value is an integer of more
    than a thousand digits, or 'a field' if none is found at the start of a line."""
    table = ""
    for line in text.splitlines():
        header = re.match(r"\s*\[+\s*([^\]]+?)\s*\]", line)
        if header:
            table = header.group(1).replace('"', "").replace("'", "") + "."
            continue
        field = re.match(r"\s*([^=#\s][^=#]*?)\s*=\s*[+-]?[0-9_]{1000,}", line)
        if field:
            return table + field.group(1).replace('"', "").replace("'", "")
    return "a field"


def paper_demes(prestretch: float = 1.5, frame_model: str = "strip", **changes: Any) -> Scene:
    """The paper's DEMES (Table I) at ``prestretch``, with further dotted-name ``changes``.

    ``frame_model`` 'strip' is the real 4 x 0.127 mm strip; 'paper' is Table I's isotropic
    beam, which collapses in-plane instead of curling (docs/elements.md).

    >>> scene = paper_demes(1.3, **{"mesh.divisions": 12})
    >>> scene.prestretch, scene.frame.model, round(scene.spacing, 3)
    (1.3, 'strip', 4.333)
    """
    scene = load("demes_paper")
    return scene.updated(prestretch=prestretch, **{"frame.model": frame_model}, **changes)
