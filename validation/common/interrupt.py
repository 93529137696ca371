"""What an interrupted ``demes`` command says, and how it is recognised.

A SIGINT that lands inside compiled (numba) code surfaces as a ``SystemError`` ("returned a
result with an exception set") whose cause is the ``KeyboardInterrupt``, which is why the
exception's whole chain is read.
"""

from __future__ import annotations

import sys

INTERRUPTED = 130
"""Exit code of an interrupted command (128 + SIGINT, as a shell reports it)."""


def caused_by_interrupt(exc: BaseException | None) -> bool:
    """Whether ``exc`` is a KeyboardInterrupt or was raised while handling one (its chain of
    causes and contexts)."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False


def report_interrupt() -> int:
    """Say that the command was interrupted; its exit code."""
    print("demes: interrupted; finished states are on disk", file=sys.stderr)
    return INTERRUPTED
