"""One process at a time fills a folder: an advisory lock (``fcntl.flock``) on a file in it
that names the holder. The kernel drops the lock when its process ends, however it ends, so a
lock left by a process that died is taken over by the next one."""

from __future__ import annotations

import fcntl
import json
import os
import socket
import time
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

from scenes import DemesError

LOCK_NAME = ".demes.lock"


class FolderBusy(DemesError):
    """The folder is being filled by another process."""


def _holder(fd: int) -> str:
    """Who holds the lock on ``fd``, from what it wrote in the file (it may be writing it still)."""
    for _ in range(20):
        os.lseek(fd, 0, os.SEEK_SET)
        text = os.read(fd, 4096).decode("utf-8", "replace")
        try:
            h = json.loads(text)
            return f"process {h['pid']} on {h['host']} ({h['command']}, since {h['since']})"
        except (ValueError, KeyError, TypeError):
            time.sleep(0.05)
    return "another process"


@contextmanager
def folder_lock(folder: Path, command: str) -> Iterator[None]:
    """Hold ``folder``'s lock while the block runs; raise :class:`FolderBusy`, naming the
    process that holds it (PID, host, command, start), if another process does."""
    folder.mkdir(parents=True, exist_ok=True)
    fd = os.open(folder / LOCK_NAME, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise FolderBusy(f"{folder} is being filled by {_holder(fd)}; wait for it to finish or "
                             "give another output folder") from None
        me = {"pid": os.getpid(), "host": socket.gethostname(), "command": command,
              "since": time.strftime("%Y-%m-%d %H:%M:%S")}
        os.ftruncate(fd, 0)
        os.pwrite(fd, json.dumps(me).encode(), 0)
        try:
            yield
        finally:
            os.ftruncate(fd, 0)
            fcntl.flock(fd, fcntl.LOCK_UN)
    finally:
        os.close(fd)
