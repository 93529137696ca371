"""Save and load a Result (positions, frame, energies, solver record, scene) as one .npz file.

What is stored is what the comparisons need; the VTK cell blocks are written separately when a
state is solved and are not kept here. Files are written atomically.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from .atomic import atomic_write
from .state import Result

_SCALARS = ("solver", "converged", "status", "message", "iterations", "residual", "wall_time", "prestretch")


def _jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, (np.integer,)):
        return int(value)
    if isinstance(value, (np.floating,)):
        return float(value)
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, np.ndarray):
        return None  # arrays stay in the solver's own output (VTK), not in the record
    return value


def save_result(path: str | Path, res: Result) -> Path:
    """Write ``res`` to ``path`` (.npz); small info entries and the scene go in as JSON."""
    meta = {k: _jsonable(getattr(res, k)) for k in _SCALARS}
    meta["energy"] = _jsonable(res.energy)
    meta["info"] = {k: v for k, v in _jsonable(res.info).items() if v is not None}
    meta["scene"] = res.scene.to_dict() if res.scene is not None else None
    arrays = {"x": res.x, "x0": res.x0, "residual_history": np.asarray(res.residual_history)}
    if res.frame_nodes is not None:
        arrays["frame_nodes"] = res.frame_nodes
        arrays["frame_s"] = res.frame_s

    def write(tmp: Path) -> None:
        with open(tmp, "wb") as f:
            np.savez_compressed(f, meta=np.array(json.dumps(meta)), **arrays)

    return atomic_write(path, write)


def load_result(path: str | Path) -> Result:
    """Read a Result written by :func:`save_result` (without VTK blocks)."""
    from scenes import Scene  # results must not need scenes to be imported for plain use

    with np.load(path, allow_pickle=False) as z:
        meta = json.loads(str(z["meta"]))
        arrays = {k: z[k] for k in z.files if k != "meta"}
    scene = Scene.from_dict(meta.pop("scene")) if meta.get("scene") else None
    return Result(
        x=arrays["x"],
        x0=arrays["x0"],
        residual_history=arrays["residual_history"],
        frame_nodes=arrays.get("frame_nodes"),
        frame_s=arrays.get("frame_s"),
        scene=scene,
        **meta,
    )
