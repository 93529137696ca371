"""The quick validation report, made once by running examples/validate_paper_demes.py (so the
validation tests check the example's output, and the example is tested at no extra cost).
The environment is set in the root conftest.py."""

import contextlib
import fcntl
import io
import json
import os
import runpy
import shutil
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


@pytest.fixture(scope="session")
def report(tmp_path_factory):
    """``demes validate --quick`` on the paper scene, by the example: (folder, files, printed).

    Made once per test session: under pytest-xdist the first worker to ask makes it in a folder
    the workers share (under a file lock, while the others wait), and each worker gets its own
    copy, since some tests change the report they are given."""
    base = tmp_path_factory.getbasetemp()
    shared = base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base
    made = shared / "validate_example"
    with open(shared / "validate_example.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not (made / "done.json").exists():
            made.mkdir(exist_ok=True)
            files, printed = _run_validate_example(made)
            (made / "done.json").write_text(json.dumps({"files": {k: str(v) for k, v in files.items()},
                                                        "printed": printed}))
    done = json.loads((made / "done.json").read_text())
    work = tmp_path_factory.mktemp("validate_example")
    shutil.copytree(made, work, dirs_exist_ok=True)
    return work / "reports" / "demes_paper_quick", done["files"], done["printed"]


def _run_validate_example(work: Path) -> tuple[dict, str]:
    here, argv, printed = Path.cwd(), sys.argv, io.StringIO()
    os.chdir(work)
    sys.argv = ["validate_paper_demes.py"]
    try:
        with contextlib.redirect_stdout(printed):
            done = runpy.run_path(str(EXAMPLES / "validate_paper_demes.py"), run_name="__main__")
    finally:
        os.chdir(here)
        sys.argv = argv
    return done["files"], printed.getvalue()
