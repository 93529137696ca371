"""The quick validation report, made once by running examples/validate_paper_demes.py (so the
validation tests check the example's output, and the example is tested at no extra cost).
The environment is set in the root conftest.py."""

import contextlib
import io
import os
import runpy
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


@pytest.fixture(scope="session")
def report(tmp_path_factory):
    """``demes validate --quick`` on the paper scene, by the example: (folder, files, printed)."""
    work = tmp_path_factory.mktemp("validate_example")
    here, argv, printed = Path.cwd(), sys.argv, io.StringIO()
    os.chdir(work)
    sys.argv = ["validate_paper_demes.py"]
    try:
        with contextlib.redirect_stdout(printed):
            done = runpy.run_path(str(EXAMPLES / "validate_paper_demes.py"), run_name="__main__")
    finally:
        os.chdir(here)
        sys.argv = argv
    return work / "reports" / "demes_paper_quick", done["files"], printed.getvalue()


def pytest_collection_modifyitems(items):
    """The tests that read the quick report share one worker process (``--dist loadgroup``), so
    that the report is made once, not once in each worker."""
    for item in items:
        if "report" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.xdist_group("report"))
