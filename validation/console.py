"""The ``demes`` console script: the command line (:func:`validation.cli.main`), with Ctrl-C at
any moment, while importing, compiling or solving, ending in one line and exit code 130.

This module imports nothing heavy, so that an interrupt while numpy, scipy and the solvers
load is caught too; its SIGINT handler (installed on import, unless SIGINT is ignored) notes
the signal, because a library interrupted while it loads may turn the KeyboardInterrupt into an
error of its own (numpy: "PyCapsule_Import could not import module datetime").
"""

from __future__ import annotations

import signal
import sys
from typing import Sequence

from .common.interrupt import INTERRUPTED, caused_by_interrupt, exit_interrupted, report_interrupt

_received: list[int] = []


def _on_sigint(signum: int, frame: object) -> None:
    _received.append(signum)
    raise KeyboardInterrupt


if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
    signal.signal(signal.SIGINT, _on_sigint)


def main(argv: Sequence[str] | None = None) -> int:
    """Run a ``demes`` command (:func:`validation.cli.main`), an interrupt while it loads
    included; an interrupted command ends the process (:func:`exit_interrupted`)."""
    try:
        from .cli import main as run
    except BaseException as exc:
        if not (_received or caused_by_interrupt(exc)):
            raise
        report_interrupt()
        exit_interrupted()
    code = None if _received else run(argv)
    if code == INTERRUPTED:
        exit_interrupted()
    if _received:
        # a library caught the interrupt (as an error of its own) and went on: the command
        # stops all the same, rather than run to its end and exit 0
        report_interrupt()
        exit_interrupted()
    return code


if __name__ == "__main__":
    sys.exit(main())
