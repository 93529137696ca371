"""Numba's on-disk cache of the DR kernels, keyed on the sources of the whole package.

Numba stamps a cached kernel with its own file's modification time and size only; a kernel
that inlines (``inline="always"``) or calls a function of another module keeps running that
function's old code after an edit of it. So the cache index files of ``dr`` are removed
whenever the package's sources differ from those its cache was made from (a SHA-256 of every
``dr/*.py``, stored beside the cache).
"""

from __future__ import annotations

import hashlib
import os
import sys
from pathlib import Path
from types import ModuleType

from numba.core.caching import NullCache
from numba.core.dispatcher import Dispatcher

STAMP = "demes_sources.sha256"
"""Name of the file, in each cache folder, holding the digest of the sources its kernels were made from."""


def source_digest(paths: list[Path]) -> str:
    """SHA-256 (hex) of the names and contents of the files ``paths``, in the order given."""
    h = hashlib.sha256()
    for path in paths:
        h.update(path.name.encode() + b"\0" + path.read_bytes() + b"\0")
    return h.hexdigest()


def cache_dirs(modules: list[ModuleType]) -> set[Path]:
    """The folders numba caches the kernels of ``modules`` in (``__pycache__`` or under
    ``NUMBA_CACHE_DIR``)."""
    found = set()
    for module in modules:
        for obj in vars(module).values():
            if isinstance(obj, Dispatcher) and not isinstance(obj._cache, NullCache):
                found.add(Path(obj._cache._cache_path))
    return found


def clear_stale(package_dir: Path, folders: set[Path]) -> list[Path]:
    """Remove the cached kernels of the modules in ``package_dir`` from each of ``folders``
    whose stamp is not the digest of the sources now, and stamp it; returns the folders
    cleared. A folder that cannot be written is left alone (numba then compiles afresh)."""
    sources = sorted(package_dir.glob("*.py"))
    digest = source_digest(sources)
    stems = {p.stem for p in sources}
    cleared = []
    for folder in sorted(folders):
        stamp = folder / STAMP
        try:
            if stamp.read_text() == digest:
                continue
        except OSError:
            pass
        try:
            for path in [*folder.glob("*.nbi"), *folder.glob("*.nbc")]:
                if path.name.split(".", 1)[0] in stems:
                    path.unlink(missing_ok=True)
            part = folder / f".{STAMP}.{os.getpid()}"
            part.write_text(digest)
            os.replace(part, stamp)  # atomic: another process reads the old stamp or the new
        except OSError:
            continue
        cleared.append(folder)
    return cleared


def guard(package: str) -> list[Path]:
    """:func:`clear_stale` for the imported modules of ``package`` (call it before any kernel runs)."""
    modules = [m for name, m in list(sys.modules.items())
               if m is not None and (name == package or name.startswith(package + "."))]
    root = Path(sys.modules[package].__file__).parent
    return clear_stale(root, cache_dirs(modules))
