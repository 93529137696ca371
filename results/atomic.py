"""Atomic file output: write beside the target, then rename, so a reader never sees half a file."""

from __future__ import annotations

import os
import secrets
from pathlib import Path
from typing import Callable

_TRIES = 100


def _new_file_beside(path: Path) -> Path:
    """Create an empty, uniquely named hidden file in ``path``'s folder and return its path.

    It is opened with mode 0666, so the kernel applies the umask (and any default ACL): the
    target ends with the mode any new file of the user gets (0644 under umask 022).
    ``tempfile.mkstemp`` would give 0600 whatever the umask.
    """
    for _ in range(_TRIES):
        tmp = path.parent / f".{path.stem}.{secrets.token_hex(6)}{path.suffix}"
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        except FileExistsError:
            continue
        os.close(fd)
        return tmp
    raise FileExistsError(f"could not create a temporary file beside {path} in {_TRIES} tries")


def atomic_write(path: str | Path, write: Callable[[Path], None]) -> Path:
    """Call ``write(tmp)`` on a temporary path in the target's folder, then rename it to ``path``.

    The temporary name keeps the target's suffix so that writers that pick a format from the
    extension (meshio, matplotlib) see the right one. The file gets the user's umask.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp_path = _new_file_beside(path)
    try:
        write(tmp_path)
        os.replace(tmp_path, path)
    finally:
        if tmp_path.exists():
            tmp_path.unlink()
    return path


def atomic_write_text(path: str | Path, text: str) -> Path:
    """Write ``text`` to ``path`` atomically."""
    return atomic_write(path, lambda p: p.write_text(text))
