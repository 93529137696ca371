"""The ``demes`` console script: the command line (:func:`validation.cli.main`), with Ctrl-C at
any moment, while importing, compiling or solving, ending in one line and exit code 130.

This module imports nothing heavy, so that an interrupt while numpy, scipy and the solvers
load is caught too.
"""

from __future__ import annotations

import sys
from typing import Sequence

from .common.interrupt import caused_by_interrupt, report_interrupt


def main(argv: Sequence[str] | None = None) -> int:
    """Run a ``demes`` command (:func:`validation.cli.main`), an interrupt while it loads
    included."""
    try:
        from .cli import main as run
    except BaseException as exc:
        if not caused_by_interrupt(exc):
            raise
        return report_interrupt()
    return run(argv)


if __name__ == "__main__":
    sys.exit(main())
