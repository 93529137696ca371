"""VTK output for ParaView: .vtu states (meshio) and .pvd series, written atomically."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from xml.sax.saxutils import quoteattr

import meshio
import numpy as np

from .atomic import atomic_write, atomic_write_text


@dataclass
class CellBlock:
    """Cells of one VTK type ('line', 'triangle', 'triangle6') with per-cell data (unit in name)."""

    cell_type: str
    connectivity: np.ndarray
    cell_data: dict[str, np.ndarray] = field(default_factory=dict)


def write_vtu(
    path: str | Path,
    points: np.ndarray,
    blocks: dict[str, CellBlock],
    point_data: dict[str, np.ndarray] | None = None,
) -> Path:
    """Write an unstructured grid with several cell blocks.

    Every cell-data name present in one block is given to all blocks (NaN where it does not
    apply), as the .vtu format requires; a 'block' cell array numbers the blocks in order, and
    the block names are kept in the field data so ParaView can threshold by part.
    """
    names = list(blocks)
    data_names = sorted({k for b in blocks.values() for k in b.cell_data})
    cells, cell_data = [], {k: [] for k in data_names}
    cell_data["block"] = []
    for i, name in enumerate(names):
        b = blocks[name]
        conn = np.asarray(b.connectivity, dtype=np.int64)
        cells.append((b.cell_type, conn))
        n = conn.shape[0]
        for k in data_names:
            v = b.cell_data.get(k)
            if v is None:
                shape = next(np.shape(bb.cell_data[k])[1:] for bb in blocks.values() if k in bb.cell_data)
                v = np.full((n, *shape), np.nan)
            cell_data[k].append(np.asarray(v, dtype=float))
        cell_data["block"].append(np.full(n, i, dtype=np.int32))
    mesh = meshio.Mesh(
        np.asarray(points, dtype=float),
        cells,
        point_data={k: np.asarray(v, dtype=float) for k, v in (point_data or {}).items()},
        cell_data=cell_data,
        field_data={name: np.array([i, 0]) for i, name in enumerate(names)},
    )
    return atomic_write(path, lambda p: meshio.write(p, mesh, file_format="vtu"))


def write_pvd(path: str | Path, entries: list[tuple[float, str | Path]]) -> Path:
    """Write a ParaView collection: ``entries`` are (time value, .vtu path) pairs.

    Paths are stored relative to the .pvd file, so the folder can be moved as a whole. The time
    value is what ParaView's animation steps through (here: the pre-stretch ratio).
    """
    path = Path(path).resolve()
    lines = [
        '<?xml version="1.0"?>',
        '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">',
        "  <Collection>",
    ]
    for t, f in entries:
        rel = os.path.relpath(Path(f).resolve(), path.parent)
        lines.append(f'    <DataSet timestep="{t:.10g}" group="" part="0" file={quoteattr(str(rel))}/>')
    lines += ["  </Collection>", "</VTKFile>", ""]
    return atomic_write_text(path, "\n".join(lines))
